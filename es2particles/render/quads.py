"""3D particles as oriented quads: the ARM chapter's confetti, declared by a scene as
:class:`Quads` and planned as stages of the frame.

Each particle is a quad facing its ``normal`` role (an octahedral unit vector, the last surface it
touched), at its ``position``, with a shape made from the quad's own coordinates (disc, square,
star) and a colour of the palette picked by a hash of its texel. ES 2.0 has no instancing: the
vertex buffer holds four vertices per particle, each naming the particle's texel and its corner,
drawn through one static index buffer as two triangles (``quads/confetti.vert`` fetches the
state by the texel). Opaque meshes first, then the quads, all with depth test and writes.
"""

from dataclasses import dataclass, replace
from functools import partial

import numpy as np

from ..errors import ParameterError, check_range
from ..frame.plan import Ref, Rendering, Resource, Stage, Vertices
from ..gl.bindings import generated_values, glsl_type, stage_interface, uniform_value
from ..gl.device import DrawState
from .meshes import plan_meshes

SHAPES = ("disc", "square", "star")
# Bright paper colours, as the chapter's confetti.
PALETTE = ((0.95, 0.26, 0.21), (1.0, 0.76, 0.03), (0.30, 0.69, 0.31), (0.13, 0.59, 0.95),
           (0.61, 0.15, 0.69), (1.0, 0.60, 0.0))
ROLES = {"position": 3, "normal": 2, "fade": 2}


def quad_vertices(layout):
    """(4 count, 4) float32: texel u, v and corner x, y, four corners a particle."""
    texels = np.repeat(layout.texel_uv(), 4, axis=0)
    corners = np.tile(np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], np.float32),
                      (layout.count, 1))
    return np.concatenate([texels, corners], 1).astype(np.float32)


def quad_indices(layout):
    """(6 count,) uint32: two triangles of each particle's four corners."""
    first = np.arange(layout.count, dtype=np.uint32)[:, None] * 4
    return (first + np.array([0, 1, 2, 0, 2, 3], np.uint32)).ravel()


@dataclass(frozen=True)
class Quads(Rendering):
    """A 3D scene's rendering as oriented quads (see the module's docstring).

    Parameters
    ----------
    half_size : float
        Half a quad's side, in world units.
    shapes : tuple of str
        The shapes on offer (``disc``, ``square``, ``star``), spread evenly over the particles.
    lift : float
        How far a quad sits off its surface along its normal (world units), so that a resting
        quad does not fight the floor for depth.
    light : (x, y, z)
        The lamp: quads are lit by it on both faces, and so are the meshes.
    background : (r, g, b)
    meshes : tuple of meshes.Mesh
    roles : mapping
        role -> the scene's quantity: ``position`` (3 components), ``normal`` (2: octahedral),
        ``fade`` (a life clock: unborn and dead particles are not drawn).
    shafts : shafts.Shafts or None
        Light shafts streaming from ``light`` past the meshes and the quads (opaque occluders).
    """

    half_size: float = 0.03
    shapes: tuple = SHAPES
    lift: float = 0.01
    light: tuple = (0.0, 6.0, 2.0)
    background: tuple = (0.05, 0.06, 0.09)
    meshes: tuple = ()
    roles: object = None
    shafts: object = None

    settings = ()
    has_camera = True
    kind = "it draws 3D quads of a world size: no point size or tone map"

    def __post_init__(self):
        check_range("quad half size", self.half_size, 1e-6, 1e3)
        check_range("quad lift", self.lift, 0.0, 1.0)
        shapes = tuple(self.shapes)
        unknown = [s for s in shapes if s not in SHAPES]
        if unknown or not 1 <= len(shapes) <= len(SHAPES) or len(set(shapes)) != len(shapes):
            raise ParameterError(f"confetti shapes are one to three of {', '.join(SHAPES)}, each "
                                 f"once; got {', '.join(map(str, shapes)) or 'none'}")
        object.__setattr__(self, "shapes", shapes)
        object.__setattr__(self, "meshes", tuple(self.meshes))
        roles = {"position": "position", "normal": "normal", "fade": "life"} \
            if self.roles is None else dict(self.roles)
        if set(roles) != set(ROLES):
            raise ParameterError(f"quad roles are {', '.join(ROLES)}, got {', '.join(roles)}")
        object.__setattr__(self, "roles", roles)

    @property
    def reads(self):
        return tuple(dict.fromkeys(self.roles.values()))

    def plan(self, b, defaults):
        """Add the mesh stages and the quads' stage to plan builder ``b``; the image is what the
        frame presents."""
        layout, size = b.layout, b.size
        quantities = {}
        for role, quantity in self.roles.items():
            q = b.graph_plan.quantities[quantity]
            if q.components != ROLES[role]:
                raise ParameterError(f"the quads' {role} role takes a quantity of "
                                     f"{ROLES[role]} components; {quantity!r} has {q.components}")
            name = {"fade": "life"}.get(role, role)  # the name the shader reads it by
            quantities[name] = replace(q, name=name)
        own = {"u_half_size": float(self.half_size), "u_lift": float(self.lift),
               "u_light": tuple(map(float, self.light)),
               "u_shapes": np.array([[SHAPES.index(s)] for s in self.shapes], float),
               "u_shape_count": float(len(self.shapes)),
               "u_palette": np.array(PALETTE, float)}
        interface = stage_interface(tuple(quantities), quantities, b.format, own)
        own = {name: uniform_value(name, value, glsl_type(name, value))
               for name, value in own.items()}
        background = tuple(float(v) for v in self.background)
        b.resource(Resource("image", "target", size, "rgba8", depth=True, linear=True,
                            what="the picture, with its depth"))
        plan_meshes(b, self.meshes, self.light, "image", (*background, 1.0))
        b.vertex_data(Vertices("quads", "data", 4 * layout.count,
                               data=partial(quad_vertices, layout),
                               indices=partial(quad_indices, layout),
                               index_count=6 * layout.count,
                               attributes=(("a_texel", 2), ("a_corner", 2))))
        player = {{"fade": "life"}.get(r, r): q for r, q in self.roles.items()}
        inputs = {sampler: Ref(player[q], part)
                  for sampler, (_, q, part, _) in interface.samplers.items()}
        quads = dict(vertex_interface=interface, inputs=inputs, vertices="quads",
                     primitive="triangles", count=6 * layout.count, uniforms=own,
                     generated=generated_values(interface, layout),
                     frame_uniforms={"u_view_projection": ("view_projection",)})
        b.stage(Stage(
            "quads", "quads", "quads/confetti.frag", "quads/confetti.vert",
            {"PALETTE": len(PALETTE)}, target=Ref("image"), state=DrawState(depth_test=True),
            clear=None if self.meshes else (*background, 1.0),
            what=f"{layout.count} quads of {2 * self.half_size:g} m ({', '.join(self.shapes)}): "
                 f"4 vertices each through one index buffer, vertex texture fetch of "
                 f"{', '.join(self.reads)}", **quads))
        from .shafts import plan_shafts

        def occluders(target, clear):  # opaque: black, hidden behind the meshes
            b.stage(Stage("shaft occluders: quads", "shafts", "quads/confetti.frag",
                          "quads/confetti.vert", {"PALETTE": len(PALETTE), "OCCLUDER": None},
                          target=Ref(target), state=DrawState(depth_test=True), clear=clear,
                          what="black: each stops the light", **quads))

        return plan_shafts(b, self.shafts, "image", self.light, self.meshes, occluders)
