"""The ARM chapter's GPU-only collision in 3D: particles leave a disc above an object, fall, bounce
and slide off it and the floor (y = 0, y up), drawn as sprites with the object opaque.

The object is a union of shapes (sphere, box, capsule, torus, triangle meshes) whose voxel field
(``field3d.VoxelField``: distance and normal, a 2D slice atlas) the passes sample in the object's
own space; the object may turn (``spin``) and sway along a line, and its surface's velocity enters
the response. Forces: gravity, a constant force, Stokes friction F = -6 pi eta r v on a particle
of mass m (integrated exactly), and a random kick in flight. A member of the emitter family
(``emitter.py``): position and velocity of three components and the family's life, three passes
of ``collision3d.frag``. The field may be compressed (ASTC) where the context can decode it.
float64 twin: ``twins/collision3d.py``.
"""

import re
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ParameterError
from ..fields.field3d import Box, Capsule, Sphere, Torus, VoxelField, field_box, parse_shapes
from ..frame.motion import Motion
from ..params import param
from ..render.lamp import Lamp
from ..render.sprites import SpriteLook
from .emitter import Emitter, EmitterPhysics, blend, eye, lifetimes, sprite, target, time_step

FLOOR_HALF = 4.0  # the floor is [-4, 4]^2; x and z of the position range too
HEIGHT = 7.0  # y in [-1, 7]: 8 units, the floor y = 0 a code of the 16-bit grid (see fountain.py)
SUBSTEP_LIMIT = 4096
SUBSTEPS, FIELD_CELLS = "sub-steps a step", "field cells"  # costs named in base.COSTS
DEFAULT_SHAPE = "sphere:0,1,0,1"
# Uncompressed field formats and their encodings (field3d.py); and astcWxH (see astc.BLOCKS).
# rgba8-smooth, the 8-bit distance of the compressed fields left uncompressed, tells the two
# errors of a compressed field apart.
FIELD_ENCODINGS = {"rgba8": "packed", "rgba16f": "half", "rgba32f": "float",
                   "rgba8-smooth": "smooth"}
FIELD_FORMATS = tuple(FIELD_ENCODINGS)


@dataclass(frozen=True)
class Collision3DPhysics(EmitterPhysics):
    """The scene's physics, object and camera, SI units (metres, seconds, kilograms): what
    confetti, drawn as quads, shares with it."""

    dt: float = time_step(1 / 60, 0.1)
    lifetime: tuple = lifetimes((3.0, 4.0))
    eye: tuple = eye((0.0, 3.2, 6.5))
    target: tuple = target((0.0, 1.0, 0.0))
    shape: str = param(DEFAULT_SHAPE, text=True, metavar="SHAPE[+SHAPE...]",
                       help="the object: sphere:CX,CY,CZ,R, box:CX,CY,CZ,HX,HY,HZ, capsule:AX,AY,"
                            "AZ,BX,BY,BZ,R, torus:CX,CY,CZ,MAJOR,MINOR (around y) or a mesh file "
                            "(.obj .stl .ply: scaled to 2 m, centred at 0,1,0; the mesh extra), "
                            "a union joined by '+'")
    field_resolution: int = param(64, 16, 256, integer=True,
                                  help="voxels along the object's longest side")
    field_format: str = param("rgba8", text=True,
                              help="the field's texture: rgba8 (16-bit distance, octahedral "
                                   "normal), rgba16f (the chapter's half floats), rgba32f, "
                                   "rgba8-smooth (8-bit distance, as the compressed ones) or "
                                   "astcWxH (compressed, e.g. astc6x6, where the context has ASTC)")
    gravity: tuple = param((0.0, -9.81, 0.0), -100.0, 100.0, count=3, unit="m/s^2",
                           help="the acceleration of gravity (a vector, as in every scene)")
    force: tuple = param((0.0, 0.0, 0.0), -1e3, 1e3, count=3, unit="N",
                         help="a constant force on each particle")
    mass: float = param(1e-4, 1e-9, 1e3, unit="kg", help="a particle's mass")
    radius: float = param(0.005, 0.0, 10.0, unit="m", help="a particle's radius, for friction")
    viscosity: float = param(1.8e-5, 0.0, 1e3, unit="Pa s",
                             help="the air's viscosity: friction is -6 pi eta r v (air's)")
    jitter: float = param(0.3, 0.0, 100.0, unit="m/s^2 per sqrt(s)",
                          help="random acceleration in flight")
    sliding: float = param(0.5, 0.0, 1.0, help="the chapter's sliding factor: 1 bounces along "
                                               "the normal, 0 slides")
    # The chapter's bouncing resistance r: v' = |v| r (n s + t (1 - s)), so a contact keeps
    # r sqrt(s^2 + (1 - s)^2) of the speed (0.71 r at s = 0.5).
    bounce: float = param(0.5, 0.0, 1.0, help="the chapter's bouncing resistance r: a contact "
                                              "keeps r sqrt(s^2 + (1-s)^2) of the speed")
    emitter: tuple = param((0.0, 3.2, 0.0), -FLOOR_HALF, (FLOOR_HALF, HEIGHT, FLOOR_HALF),
                           count=3, unit="m", help="the emitter disc's centre")
    emitter_radius: float = param(0.25, 0.0, FLOOR_HALF, unit="m", option=False,
                                  help="the emitter disc's radius")
    launch: tuple = param((0.0, 0.0, 0.0), -100.0, 100.0, count=3, unit="m/s", option=False,
                          help="the launch velocity")
    launch_spread: float = param(0.3, 0.0, 100.0, unit="m/s", option=False,
                                 help="the launch velocity's random spread")
    max_speed: float = param(12.0, 0.1, 100.0, unit="m/s", option=False,
                             help="the velocity range's bound")
    spin: tuple = param((0.0,), (-3600.0, -1e3, -1e3, -1e3), (3600.0, 1e3, 1e3, 1e3),
                        count=(1, 4), unit="degrees/s", metavar="DEG[,AX,AY,AZ]",
                        help="turn the object about an axis through its centre (axis z unless "
                             "given; 0: still)")
    sway: tuple = param((0.0, 0.0, 0.0, 0.0), (-FLOOR_HALF,) * 3 + (0.0,),
                        (FLOOR_HALF,) * 3 + (1e4,), count=4, unit="m, s",
                        metavar="AX,AY,AZ,PERIOD", help="move the object to and fro (period 0: "
                                                        "still)")
    scale: float = param(1.0, 0.05, 20.0, help="the object's scale about its centre")

    def check(self):
        super().check()
        parse_field_format(self.field_format)
        r = self.emitter_radius
        if np.any(np.abs(np.asarray(self.emitter)[[0, 2]]) + r > FLOOR_HALF) or \
                not 0.0 <= self.emitter[1] <= HEIGHT:
            raise ParameterError(f"--emitter: the disc of radius {r:g} must lie within x, z in "
                                 f"[-{FLOOR_HALF:g}, {FLOOR_HALF:g}] and y in [0, {HEIGHT:g}], "
                                 f"got {self.emitter}")
        if self.launch_spread > self.max_speed or np.any(np.abs(self.launch) > self.max_speed):
            raise ParameterError(f"the launch must stay within the velocity range "
                                 f"+-{self.max_speed:g}")
        if len(self.spin) == 4 and self.spin[0] != 0 and not np.linalg.norm(self.spin[1:]) > 0:
            raise ParameterError(f"--spin's axis must not be zero, got {self.spin[1:]}")
        if self.sway[3] == 0 and any(self.sway[:3]):
            raise ParameterError("--sway needs a period > 0 with its amplitude")

    @property
    def drag(self):
        """Stokes: k = 6 pi eta r / m, the rate of v' = -k v."""
        return 6 * np.pi * self.viscosity * self.radius / self.mass

    @property
    def acceleration(self):
        """Gravity plus the constant force over the mass."""
        return np.asarray(self.gravity, float) + np.asarray(self.force, float) / self.mass

    @property
    def spin_axis(self):
        axis = np.asarray(self.spin[1:] if len(self.spin) == 4 else (0.0, 0.0, 1.0), float)
        n = np.linalg.norm(axis)
        return axis / n if n > 0 else np.array([0.0, 0.0, 1.0])

    @property
    def spin_rate(self):
        return np.radians(self.spin[0])

    def motion(self, pivot):
        """The object's motion about ``pivot`` (its field's): its spin, its sway and its scale
        (``lib/motion.glsl``)."""
        return Motion(self.dt, pivot=tuple(map(float, pivot)),
                      axis=tuple(map(float, self.spin_axis)), rate=float(self.spin_rate),
                      sway=tuple(map(float, self.sway[:3])), period=float(self.sway[3]),
                      scale=float(self.scale))


@dataclass(frozen=True)
class Collision3DParams(SpriteLook, Collision3DPhysics):
    """The scene's parameters: its physics, then the look of its sprites and the chapter's
    lamp."""

    blend: str = blend("over")
    sprite: str = sprite("disc")
    opacity: float = param(0.9, 0.0, 1.0, help="a sprite's opacity at its centre (the chapter's "
                                               "smoke: low, with --sprite puff --blend add)")
    shadows: str = param("off", choices=("on", "off"),
                         help="the chapter's shadows: a lamp whose light map the particles and "
                              "the object darken, on the object and the floor")
    lamp: tuple = param((1.6, 5.5, 1.2), (-20.0, 0.5, -20.0), (20.0, 40.0, 20.0), count=3,
                        unit="m", help="where the lamp hangs (it looks at the object)")
    lamp_angle: float = param(62.0, 10.0, 150.0, unit="degrees",
                              help="the lamp's cone, full angle: its disc of light")

    def check(self):
        super().check()
        declared = self.declarations()
        if self.shadows == "off":
            moved = [d.flag_name for n, d in declared.items() if n in ("lamp", "lamp_angle")
                     and getattr(self, n) != d.default]
            if moved:
                raise ParameterError(f"{moved[0]}: the lamp lights only the chapter's shadows; "
                                     "give --shadows on with it")


def parse_field_format(text):
    """None for an uncompressed field format, else the ASTC block (w, h) of ``astcWxH``."""
    from ..gl.astc import BLOCKS

    if text in FIELD_FORMATS:
        return None
    match = re.fullmatch(r"astc(\d+)x(\d+)", str(text))
    if match and (int(match[1]), int(match[2])) in BLOCKS:
        return int(match[1]), int(match[2])
    raise ParameterError(f"--field-format must be one of {FIELD_FORMATS} or astcWxH with a block "
                         f"of {', '.join(f'{w}x{h}' for w, h in BLOCKS)}; got {text!r}")


class Collision3D(Emitter):
    """Particles falling on an object (a voxel field; it may move) and the floor, in 3D.
    ``field``: a :class:`~es2particles.fields.field3d.VoxelField` made already, in place of the
    one ``shape`` and ``field_resolution`` make."""

    name, step, Params = "collision3d", "collision3d.frag", Collision3DParams

    def __init__(self, params=None, field=None, **given):
        super().__init__(params, **given)
        p = self.params
        self.block = parse_field_format(p.field_format)
        self.field_format = p.field_format
        if field is None:
            shapes = parse_shapes(p.shape)
            field_box(shapes, p.field_resolution)  # its refusals, before the word on its cost
            self.warn_of_cost(FIELD_CELLS)
            field = VoxelField(shapes, p.field_resolution)
        self.field = field
        f = self.field
        # The object must stay inside the position range (particles there die), whatever pose.
        lo, hi = f.bounds
        # The shapes' bounding sphere where the object turns, else their box; scaled.
        reach = np.linalg.norm(hi - lo) / 2 * p.scale
        extent = np.full(3, reach) if p.spin[0] else (hi - lo) / 2 * p.scale
        centre = (lo + hi) / 2
        sway = np.abs(p.sway[:3])
        box_lo = np.array([-FLOOR_HALF, -1.0, -FLOOR_HALF])
        box_hi = np.array([FLOOR_HALF, HEIGHT, FLOOR_HALF])
        if np.any(centre - extent - sway < box_lo) or np.any(centre + extent + sway > box_hi):
            raise ParameterError(f"the object (turned any way, and swaying) must stay "
                                 f"within x, z in [-{FLOOR_HALF:g}, {FLOOR_HALF:g}] and y in "
                                 f"[-1, {HEIGHT:g}]: move or shrink the --shape")
        self.substep = 0.5 * f.voxel * p.scale  # world units: half a voxel
        self.surface_speed = (np.linalg.norm(p.sway[:3]) * (2 * np.pi / p.sway[3] if p.sway[3] else 0)
                              + abs(p.spin_rate) * (np.linalg.norm(centre - f.pivot) + reach))
        reach_per_step = (p.max_speed * np.sqrt(3) + np.linalg.norm(p.acceleration) * p.dt
                          + self.surface_speed) * p.dt
        self.max_substeps = int(max(1, np.ceil(reach_per_step / self.substep)))
        if self.max_substeps > SUBSTEP_LIMIT:
            raise ParameterError(
                f"dt {p.dt:g} at max speed {p.max_speed:g} (and the object's motion) with voxels "
                f"of {f.voxel * p.scale:.3g} needs {_count(self.max_substeps)} sub-steps of half a voxel; "
                f"at most {SUBSTEP_LIMIT}: lower --dt or --field-resolution")
        self.warn_of_cost(SUBSTEPS)

    typical_cost = {FIELD_CELLS: 64 ** 3, SUBSTEPS: 20}

    def cost(self):
        return {FIELD_CELLS: self.params.field_resolution ** 3,
                SUBSTEPS: getattr(self, "max_substeps", 0)}

    @property
    def moves(self):
        p = self.params
        return p.spin[0] != 0 or p.sway[3] > 0

    def field_choice(self, caps):
        """(encoding, ASTC block or None, why a compressed field runs uncompressed or None) for
        a context of ``caps``."""
        from ..gl import astc

        missing = None
        if self.block is not None:
            missing = astc.unavailable(caps) if caps is not None else "no context to ask"
            if missing is None:
                return "smooth", self.block, None
        return FIELD_ENCODINGS.get(self.field_format, "packed"), None, missing

    def declare(self, g, caps):
        """Position, velocity and the field's atlas, which fits the context's largest texture
        (``caps``; None: 4096)."""
        from ..gl import astc

        p = self.params
        max_size = caps.max_texture_size if caps is not None else 4096
        g.quantity("position", (-FLOOR_HALF, -1.0, -FLOOR_HALF), (FLOOR_HALF, HEIGHT, FLOOR_HALF))
        g.quantity("velocity", -p.max_speed, p.max_speed, components=3)
        encoding, block, missing = self.field_choice(caps)
        if block is not None:
            g.texture("field", astc.compress(self.field.texels("smooth", max_size, block), block))
        else:
            g.texture("field", self.field.texels(encoding, max_size))
            if missing:
                g.notes.append(f"ASTC: {missing}; the field runs uncompressed (rgba8)")

    def defines(self, caps):
        encoding, _, _ = self.field_choice(caps)
        return {"MAX_SUBSTEPS": self.max_substeps, **{"float": {"FIELD_FLOAT": None},
                                                      "half": {"FIELD_FLOAT": None},
                                                      "smooth": {"FIELD_SMOOTH": None},
                                                      "packed": {}}[encoding]}

    def uniforms(self, caps):
        p, f = self.params, self.field
        _, block, _ = self.field_choice(caps)
        max_size = caps.max_texture_size if caps is not None else 4096
        return {"u_dt": float(p.dt), "u_lifetime": tuple(map(float, p.lifetime)),
                "u_emitter": (*map(float, p.emitter), float(p.emitter_radius)),
                "u_launch": (*map(float, p.launch), float(p.launch_spread)),
                "u_gravity": tuple(map(float, p.acceleration)), "u_drag": float(p.drag),
                "u_jitter": float(p.jitter), "u_max_speed": float(p.max_speed),
                "u_sliding": float(p.sliding), "u_bounce": float(p.bounce),
                "u_substep": float(self.substep), "u_surface_speed": float(self.surface_speed),
                **p.motion(f.pivot).uniforms(),
                **f.uniforms(max_size, block or (1, 1))}

    def begin(self, count, rng):
        return {"position": np.tile(self.params.emitter, (count, 1)),
                "velocity": np.zeros((count, 3))}

    def meshes(self):
        from ..render import meshes as shapes

        meshes = [shapes.floor(FLOOR_HALF, cell=0.5)]
        colour = (0.72, 0.45, 0.30)
        for s in self.field.shapes:
            if isinstance(s, Sphere):
                mesh = shapes.sphere(s.centre, s.radius, colour)
            elif isinstance(s, Box):
                mesh = shapes.box(s.centre, s.half_size, colour)
            elif isinstance(s, Capsule):
                mesh = shapes.capsule(s.a, s.b, s.radius, colour)
            elif isinstance(s, Torus):
                mesh = shapes.torus(s.centre, s.major, s.minor, colour=colour)
            else:
                mesh = shapes.from_triangles(s.vertices, s.faces, colour)
            meshes.append(mesh)
        # Meshes are given in world units at rest; the model matrix carries them to the pose.
        if self.moves or self.params.scale != 1:
            meshes[1:] = [replace(m, moves=True) for m in meshes[1:]]
        return meshes

    def motion(self):
        """The object's motion: its spin about the field's pivot, its sway and its scale."""
        p = self.params
        if not (self.moves or p.scale != 1):
            return None
        return p.motion(self.field.pivot)

    def sprites(self):
        p = self.params
        lamp = None
        if p.shadows == "on":
            lo, hi = self.field.bounds
            centre = tuple(float(v) for v in (lo + hi) / 2)
            lamp = Lamp(position=p.lamp, target=(centre[0], 0.0, centre[2]), angle=p.lamp_angle,
                        opacity=0.5)
        return {"size_spread": 0.3, "tint": (0.75, 0.85, 1.0, 0.8), "opacity": p.opacity,
                "lamp": lamp}

    def describe(self):
        p, f = self.params, self.field
        nx, ny, nz = f.cells
        return super().describe() + [
            f"collision field: {nx}x{ny}x{nz} voxels of {f.voxel:.4g} m around "
            f"{' + '.join(type(s).__name__.lower() for s in f.shapes)}, in a 2D slice atlas "
            f"({self.field_format}); nearest voxel, distance carried along its normal",
            f"physics: sub-steps of at most half a voxel (<= {self.max_substeps}), Stokes drag "
            f"k = 6 pi eta r / m = {p.drag:.3g}/s (exact); no acceleration pass: the forces "
            "are uniforms evaluated at every sub-step"]

    def measured(self, ctx):
        """The compression table: memory per object, and the collision error each format costs
        over a fixed run of this scene's field (see field_compression.py)."""
        from ..gl import astc
        from . import field_compression as compression

        missing = astc.unavailable(ctx)
        still = replace(self.params, jitter=0.0, spin=(0.0,), sway=(0.0, 0.0, 0.0, 0.0),
                        scale=1.0)
        blocks = () if missing else compression.MEASURED_BLOCKS
        errors = compression.collision_errors(
            ctx, lambda fmt: type(self)(replace(still, field_format=fmt), field=self.field),
            self.field, blocks=blocks)
        nx, ny, nz = self.field.cells
        lines = [f"field memory of an n^3 field (bits per voxel nominal, bytes with padding) and "
                 f"the collision error of this field ({nx}x{ny}x{nz}, still, no jitter, 4096 "
                 f"particles, 90 steps, against rgba32f; in voxels; penetration '-' for meshes):"]
        lines += ["  " + line for line in compression.table_lines(compression.memory_rows(),
                                                                  errors)]
        if missing:
            lines.append(f"  ASTC: {missing}; compressed rows not measured")
        if "GL_KHR_texture_compression_astc_hdr" not in ctx.caps.extensions:
            lines.append("  ASTC HDR (the chapter's half floats, compressed): this context lacks "
                         "GL_KHR_texture_compression_astc_hdr; no row")
        return lines


def _count(n):
    """A whole count as a person reads it: exact below a billion, else in powers of ten (a
    300-digit count was printed digit by digit)."""
    return str(n) if n < 10 ** 9 else f"{float(n):.3g}"
