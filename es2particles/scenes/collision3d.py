"""The ARM chapter's GPU-only collision in 3D: particles leave a disc above an object, fall, bounce
and slide off it and the floor (y = 0, y up), drawn as sprites with the object opaque.

The object is a union of shapes (sphere, box, capsule, torus, triangle meshes) whose voxel field
(``field3d.VoxelField``: distance and normal, a 2D slice atlas) the passes sample in the object's
own space; the object may turn (``spin``) and sway along a line, and its surface's velocity enters
the response. Forces: gravity, a constant force, Stokes friction F = -6 pi eta r v on a particle
of mass m (integrated exactly), and a random kick in flight. Three quantities (position and
velocity of three components, life) and three passes of ``collision3d.frag``. The field may be
compressed (ASTC) where the context can decode it. float64 twin: ``twins/collision3d.py``.
"""

import re
from dataclasses import dataclass

import numpy as np

from ..render.camera import Camera, orbit
from ..errors import ParameterError, check_range
from ..fields.field3d import Box, Capsule, Sphere, Torus, VoxelField, parse_shapes
from ..frame.graph import PassGraph
from ..twins.life import life_range, longest_life, staggered_births
from .base import Defaults, Scene, parse_numbers, steady_steps

FLOOR_HALF = 4.0  # the floor is [-4, 4]^2; x and z of the position range too
HEIGHT = 7.0  # y in [-1, 7]: 8 units, the floor y = 0 a code of the 16-bit grid (see fountain.py)
SUBSTEP_LIMIT = 4096
DEFAULT_SHAPE = "sphere:0,1,0,1"
# Uncompressed field formats and their encodings (field3d.py); and astcWxH (see astc.BLOCKS).
# rgba8-smooth, the 8-bit distance of the compressed fields left uncompressed, tells the two
# errors of a compressed field apart.
FIELD_ENCODINGS = {"rgba8": "packed", "rgba32f": "float", "rgba8-smooth": "smooth"}
FIELD_FORMATS = tuple(FIELD_ENCODINGS)


@dataclass(frozen=True)
class Physics3D:
    """The scene's parameters, SI units (metres, seconds, kilograms)."""

    dt: float = 1 / 60
    gravity: float = 9.81
    force: tuple = (0.0, 0.0, 0.0)  # a constant force on each particle, newtons
    mass: float = 1e-4
    radius: float = 0.005
    viscosity: float = 1.8e-5  # air; Stokes drag k = 6 pi eta r / m
    jitter: float = 0.3  # random acceleration, m/s^2 per sqrt(s)
    sliding: float = 0.5  # the chapter's sliding factor: 1 bounces along the normal, 0 slides
    # The chapter's bouncing resistance r: v' = |v| r (n s + t (1 - s)), so a contact keeps
    # r sqrt(s^2 + (1 - s)^2) of the speed (0.71 r at s = 0.5).
    bounce: float = 0.5
    emitter: tuple = (0.0, 3.2, 0.0)
    emitter_radius: float = 0.25
    launch: tuple = (0.0, 0.0, 0.0)
    launch_spread: float = 0.3
    lifetime: tuple = (3.0, 4.0)
    max_speed: float = 12.0
    spin: tuple = (0.0, 0.0, 1.0, 0.0)  # degrees per second, then the axis
    sway: tuple = (0.0, 0.0, 0.0, 0.0)  # amplitude x, y, z and period (0: none)
    scale: float = 1.0

    def __post_init__(self):
        for name, length in (("force", 3), ("emitter", 3), ("launch", 3), ("lifetime", 2),
                             ("spin", 4), ("sway", 4)):
            if len(getattr(self, name)) != length:
                raise ParameterError(f"{name} must be {length} numbers, got {getattr(self, name)}")
        check_range("dt", self.dt, 1e-4, 0.1)
        check_range("gravity", self.gravity, 0.0, 100.0)
        for v in self.force:
            check_range("force", v, -1e3, 1e3)
        check_range("mass", self.mass, 1e-9, 1e3)
        check_range("radius", self.radius, 0.0, 10.0)
        check_range("viscosity", self.viscosity, 0.0, 1e3)
        check_range("jitter", self.jitter, 0.0, 100.0)
        check_range("sliding", self.sliding, 0.0, 1.0)
        check_range("bounce", self.bounce, 0.0, 1.0)
        check_range("max_speed", self.max_speed, 0.1, 100.0)
        check_range("emitter radius", self.emitter_radius, 0.0, FLOOR_HALF)
        check_range("launch spread", self.launch_spread, 0.0, self.max_speed)
        for k, v in enumerate(self.emitter):
            edge = (FLOOR_HALF - self.emitter_radius, HEIGHT, FLOOR_HALF - self.emitter_radius)[k]
            check_range("emitter " + "xyz"[k], v, 0.0 if k == 1 else -edge, edge)
        for v in self.launch:
            check_range("launch velocity", v, -self.max_speed, self.max_speed)
        lo, hi = (check_range("lifetime", v, self.dt, longest_life(self.dt)) for v in self.lifetime)
        if hi < lo:
            raise ParameterError(f"lifetime must have min <= max, got {self.lifetime}")
        check_range("spin", self.spin[0], -3600.0, 3600.0)
        for v in self.spin[1:]:
            check_range("spin axis", v, -1e3, 1e3)
        if self.spin[0] != 0 and not np.linalg.norm(self.spin[1:]) > 0:
            raise ParameterError(f"spin axis must not be zero, got {self.spin[1:]}")
        for v in self.sway[:3]:
            check_range("sway amplitude", v, -FLOOR_HALF, FLOOR_HALF)
        check_range("sway period", self.sway[3], 0.0, 1e4)
        if self.sway[3] == 0 and any(self.sway[:3]):
            raise ParameterError("sway needs a period > 0 with its amplitude")
        check_range("scale", self.scale, 0.05, 20.0)

    @property
    def drag(self):
        """Stokes: k = 6 pi eta r / m, the rate of v' = -k v."""
        return 6 * np.pi * self.viscosity * self.radius / self.mass

    @property
    def acceleration(self):
        """Gravity plus the constant force over the mass."""
        return np.array([0.0, -self.gravity, 0.0]) + np.asarray(self.force, float) / self.mass

    @property
    def spin_axis(self):
        axis = np.asarray(self.spin[1:], float)
        n = np.linalg.norm(axis)
        return axis / n if n > 0 else np.array([0.0, 0.0, 1.0])

    @property
    def spin_rate(self):
        return np.radians(self.spin[0])

    def pose(self, t):
        """(centre offset from the pivot, angle, velocity of the pivot) at time t (float64 twin of
        ``object_pose``)."""
        amplitude, period = np.asarray(self.sway[:3], float), self.sway[3]
        if period > 0:
            w = 2 * np.pi / period
            return amplitude * np.sin(w * t), self.spin_rate * t, amplitude * w * np.cos(w * t)
        return np.zeros(3), self.spin_rate * t, np.zeros(3)


def parse_field_format(text):
    """None for an uncompressed field format, else the ASTC block (w, h) of ``astcWxH``."""
    from ..gl.astc import BLOCKS

    if text in FIELD_FORMATS:
        return None
    match = re.fullmatch(r"astc(\d+)x(\d+)", str(text))
    if match and (int(match[1]), int(match[2])) in BLOCKS:
        return int(match[1]), int(match[2])
    raise ParameterError(f"field format must be one of {FIELD_FORMATS} or astcWxH with a block "
                         f"of {', '.join(f'{w}x{h}' for w, h in BLOCKS)}; got {text!r}")


class Collision3D(Scene):
    """Particles falling on an object (a voxel field; it may move) and the floor, in 3D."""

    name = "collision3d"

    def __init__(self, shape=DEFAULT_SHAPE, physics=Physics3D(), field_resolution=64,
                 field_format="rgba8", camera="fixed", field=None):
        if camera not in ("fixed", "orbit"):
            raise ParameterError(f"camera must be one of ('fixed', 'orbit'), got {camera!r}")
        self.block = parse_field_format(field_format)
        self.physics, self.camera, self.field_format = physics, camera, field_format
        self.field = field if field is not None else VoxelField(parse_shapes(shape),
                                                                field_resolution)
        p, f = physics, self.field
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
                f"of {f.voxel * p.scale:.3g} needs {self.max_substeps} sub-steps of half a voxel; "
                f"at most {SUBSTEP_LIMIT}: lower --dt or --field-resolution")
        steps = steady_steps(p)
        self.defaults = Defaults(particles=2 ** 14, point_size=9.0, steps=steps, rounding="dither")

    @classmethod
    def add_arguments(cls, parser):
        add = parser.add_argument
        add("--shape", default=DEFAULT_SHAPE,
            help="the object: sphere:CX,CY,CZ,R, box:CX,CY,CZ,HX,HY,HZ, "
                 "capsule:AX,AY,AZ,BX,BY,BZ,R, torus:CX,CY,CZ,MAJOR,MINOR (around y) or a mesh "
                 "file (.obj .stl .ply: scaled to 2 m, centred at 0,1,0; needs the mesh extra), "
                 f"a union joined by '+' (default {DEFAULT_SHAPE})")
        add("--field-resolution", type=int, default=64,
            help="voxels along the object's longest side, 16 to 256 (default 64)")
        add("--field-format", default="rgba8",
            help="the field's texture: rgba8 (16-bit distance, octahedral normal), rgba32f, "
                 "rgba8-smooth (8-bit distance, as the compressed ones) or astcWxH (compressed, "
                 "e.g. astc6x6, where the context has ASTC; default rgba8)")
        add("--emitter", default="0,3.2,0", help="the emitter disc's centre x,y,z (default 0,3.2,0)")
        add("--dt", type=float, default=1 / 60, help="time step in seconds (default 1/60)")
        add("--gravity", type=float, default=9.81, help="downward acceleration (default 9.81)")
        add("--force", default="0,0,0", help="a constant force on each particle, newtons "
            "fx,fy,fz (default 0,0,0)")
        add("--mass", type=float, default=1e-4, help="particle mass in kg (default 1e-4)")
        add("--radius", type=float, default=0.005, help="particle radius in m, for Stokes "
            "friction (default 0.005)")
        add("--viscosity", type=float, default=1.8e-5, help="the air's viscosity in Pa s; "
            "friction is -6 pi eta r v (default 1.8e-5, air)")
        add("--jitter", type=float, default=0.3, help="random acceleration in flight, m/s^2 per "
            "sqrt(s) (default 0.3)")
        add("--sliding", type=float, default=0.5, help="sliding factor in [0, 1]: 1 bounces "
            "along the normal, 0 slides (default 0.5)")
        add("--bounce", type=float, default=0.5, help="the chapter's bouncing resistance r in "
            "[0, 1]: a contact keeps r sqrt(s^2 + (1-s)^2) of the speed (default 0.5)")
        add("--lifetime", type=float, nargs=2, default=(3.0, 4.0), metavar=("MIN", "MAX"),
            help="lifetime range in seconds (default 3 4)")
        add("--spin", default="0", help="turn the object: degrees per second, optionally with "
            "an axis: DEG[,AX,AY,AZ] (default axis z, 0: still)")
        add("--sway", default=None, help="move the object to and fro: AX,AY,AZ,PERIOD (metres, "
            "seconds)")
        add("--scale", type=float, default=1.0, help="scale of the object about its centre "
            "(default 1)")
        add("--camera", choices=("fixed", "orbit"), default="fixed",
            help="fixed, or orbit: circle the scene once over an animation (default fixed)")

    @classmethod
    def from_args(cls, args):
        numbers = parse_numbers
        spin = numbers("spin", args.spin, (1, 4))
        physics = Physics3D(
            dt=args.dt, gravity=args.gravity, force=numbers("force", args.force, (3,)),
            mass=args.mass, radius=args.radius, viscosity=args.viscosity, jitter=args.jitter,
            sliding=args.sliding, bounce=args.bounce, emitter=numbers("emitter", args.emitter, (3,)),
            lifetime=tuple(args.lifetime), spin=spin if len(spin) == 4 else (spin[0], 0.0, 0.0, 1.0),
            sway=numbers("sway", args.sway, (4,)) if args.sway else (0.0, 0.0, 0.0, 0.0),
            scale=args.scale)
        return cls(args.shape, physics, args.field_resolution, args.field_format, args.camera)

    @property
    def moves(self):
        p = self.physics
        return p.spin[0] != 0 or p.sway[3] > 0

    def uniforms(self, max_size, block):
        p, f = self.physics, self.field
        axis = p.spin_axis
        return {"u_dt": float(p.dt), "u_lifetime": tuple(map(float, p.lifetime)),
                "u_emitter": (*map(float, p.emitter), float(p.emitter_radius)),
                "u_launch": (*map(float, p.launch), float(p.launch_spread)),
                "u_gravity": tuple(map(float, p.acceleration)), "u_drag": float(p.drag),
                "u_jitter": float(p.jitter), "u_max_speed": float(p.max_speed),
                "u_sliding": float(p.sliding), "u_bounce": float(p.bounce),
                "u_substep": float(self.substep), "u_surface_speed": float(self.surface_speed),
                "u_pose": (*map(float, f.pivot), float(p.scale)),
                "u_spin": (*map(float, axis), float(p.spin_rate)),
                "u_sway": tuple(map(float, p.sway)),
                **f.uniforms(max_size, block)}

    def graph(self, caps=None):
        """The passes; the atlas fits the context's largest texture (``caps``; None: 4096 and no
        ASTC) and the field is ASTC-compressed where the context decodes it and astcenc encodes
        it (else uncompressed, and the plan says why)."""
        from ..gl import astc

        max_size = caps.max_texture_size if caps is not None else 4096
        missing = (astc.unavailable(caps) if caps is not None else "no context to ask") \
            if self.block is not None else None
        p = self.physics
        g = PassGraph()
        g.quantity("position", (-FLOOR_HALF, -1.0, -FLOOR_HALF), (FLOOR_HALF, HEIGHT, FLOOR_HALF))
        g.quantity("velocity", -p.max_speed, p.max_speed, components=3)
        g.quantity("life", *life_range(p.dt), storage="rgba8")
        defines = {"MAX_SUBSTEPS": self.max_substeps}
        if self.block is not None and missing is None:
            texels = self.field.texels("smooth", max_size, self.block)
            g.texture("field", astc.compress(texels, self.block))
            defines["FIELD_SMOOTH"] = None
            uniforms = self.uniforms(max_size, self.block)
        else:
            encoding = FIELD_ENCODINGS.get(self.field_format, "packed")
            g.texture("field", self.field.texels(encoding, max_size))
            defines.update({"float": {"FIELD_FLOAT": None}, "smooth": {"FIELD_SMOOTH": None},
                            "packed": {}}[encoding])
            uniforms = self.uniforms(max_size, (1, 1))
            if missing:
                g.notes.append(f"ASTC: {missing}; the field runs uncompressed (rgba8)")
        state = ("position", "velocity", "life")
        for name in state:
            g.add(name, "collision3d.frag", writes=name, reads=state, textures=["field"],
                  uniforms=uniforms, defines={**defines, f"WRITE_{name.upper()}": None})
        return g

    def start(self, count, rng):
        p = self.physics
        return {"life": staggered_births(count, p.lifetime, rng),
                "position": np.tile(p.emitter, (count, 1)), "velocity": np.zeros((count, 3))}

    # -- drawing -------------------------------------------------------------------------------

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
        if self.moves or self.physics.scale != 1:
            from dataclasses import replace

            meshes[1:] = [replace(m, moves=True) for m in meshes[1:]]
        return meshes

    def motion(self):
        """The object's motion: its spin about the field's pivot, its sway and its scale."""
        from ..frame.motion import Motion

        p = self.physics
        if not (self.moves or p.scale != 1):
            return None
        return Motion(p.dt, pivot=tuple(map(float, self.field.pivot)),
                      axis=tuple(map(float, p.spin_axis)), rate=float(p.spin_rate),
                      sway=tuple(map(float, p.sway[:3])), period=float(p.sway[3]),
                      scale=float(p.scale))

    def camera_at(self, frame, frames):
        if self.camera == "orbit":
            return orbit(frame, frames, radius=6.5, height=3.2, target=(0.0, 1.0, 0.0))
        return Camera(eye=(0.0, 3.2, 6.5), target=(0.0, 1.0, 0.0))

    def rendering(self):
        from ..render.sprites import Sprites

        d0 = np.linalg.norm(np.subtract((0.0, 3.2, 6.5), (0.0, 1.0, 0.0)))
        return Sprites(sprite="disc", size_spread=0.3, attenuation=(0.0, 0.0, 1.0 / d0 ** 2),
                       blend="over", tint=(0.75, 0.85, 1.0, 0.8), opacity=0.9,
                       meshes=self.meshes())

    def describe(self):
        p, f = self.physics, self.field
        nx, ny, nz = f.cells
        lines = [f"collision field: {nx}x{ny}x{nz} voxels of {f.voxel:.4g} m around "
                 f"{' + '.join(type(s).__name__.lower() for s in f.shapes)}, in a 2D slice atlas "
                 f"({self.field_format}); nearest voxel, distance carried along its normal",
                 f"physics: dt {p.dt:.4g}, sub-steps of at most half a voxel (<= "
                 f"{self.max_substeps}), gravity {p.gravity:g}, force {p.force} N, Stokes drag "
                 f"k = 6 pi eta r / m = {p.drag:.3g}/s (exact), jitter {p.jitter:g}, sliding "
                 f"{p.sliding:g}, bounce {p.bounce:g}"
                 + (f"; object spins {p.spin[0]:g} deg/s" if p.spin[0] else "")
                 + (f"; sways {p.sway[:3]} over {p.sway[3]:g} s" if p.sway[3] else ""),
                 "no acceleration pass: the forces are uniforms evaluated at every sub-step"]
        return lines

    def measured(self, ctx):
        """The compression table: memory per object, and the collision error each format costs
        over a fixed run of this scene's field (see report/compression.py)."""
        from dataclasses import replace

        from ..gl import astc
        from . import field_compression as compression

        missing = astc.unavailable(ctx)
        still = replace(self.physics, jitter=0.0, spin=(0.0, 0.0, 0.0, 1.0),
                        sway=(0.0, 0.0, 0.0, 0.0), scale=1.0)
        blocks = () if missing else compression.MEASURED_BLOCKS
        errors = compression.collision_errors(
            ctx, lambda fmt: Collision3D(physics=still, field_format=fmt, field=self.field),
            self.field, blocks=blocks)
        nx, ny, nz = self.field.cells
        lines = [f"field memory of an n^3 field (bits per voxel nominal, bytes with padding) and "
                 f"the collision error of this field ({nx}x{ny}x{nz}, still, no jitter, 4096 "
                 f"particles, 90 steps, against rgba32f; in voxels; penetration '-' for meshes):"]
        lines += ["  " + line for line in compression.table_lines(compression.memory_rows(),
                                                                  errors)]
        if missing:
            lines.append(f"  ASTC: {missing}; compressed rows not measured")
        return lines
