"""The ARM chapter's lamp and shadows: a spot lamp whose light falls in a disc on the floor and
the object, and a light map, seen from the lamp, of what light the particles and the object let
through; the particles' shadows fall on the object, and theirs and the object's on the floor.

The chapter's steps, each a stage of the plan (``Lamp`` is declared on a
:class:`~es2particles.render.sprites.Sprites`):

1. the object drawn from the lamp into the light map's depth, colour writes off (particles behind
   it, seen from the lamp, must not shade it);
2. the particles drawn from the lamp into the light map (``lamp/particle.vert``), depth-tested
   against it with no depth writes, each multiplying what passes by 1 - its opacity;
3. the object drawn into the picture, lit through the light map (``sprites/mesh.frag``, LAMP);
4. the object drawn black into the light map (its own shadow);
5. the floor (the meshes that cast no shadow) drawn into the picture, lit through the light map.

The lamp's light shape on the floor is made procedurally from the light map's texture
coordinates: a disc, full to 75% of the cone's radius, fading to its rim.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range
from ..frame.plan import Ref, Resource, Stage
from ..gl.bindings import generated_values, stage_interface
from ..gl.device import DrawState
from .camera import Camera
from .meshes import mesh_motion, mesh_vertex_data, plan_meshes


@dataclass(frozen=True)
class Lamp:
    """A spot ``lamp`` looking at ``target`` with a cone of ``angle`` degrees (full), a light
    map of ``size`` texels a side, the share of light a particle stops at its centre
    (``opacity``) and the ``ambient`` light the shadowed and unlit parts keep."""

    position: tuple
    target: tuple
    angle: float = 70.0
    size: int = 512
    opacity: float = 0.5
    ambient: float = 0.3

    what = "the lamp"  # how a refusal names it, as a feature of Sprites
    vertex_textures = 0  # in the sprites' own vertex shader (its passes draw them again)

    def __post_init__(self):
        for name in ("position", "target"):
            value = tuple(float(check_range(f"lamp {name}", v, -1e4, 1e4))
                          for v in getattr(self, name))
            if len(value) != 3:
                raise ParameterError(f"lamp {name} must be three numbers, got {value}")
            object.__setattr__(self, name, value)
        if np.allclose(self.position, self.target):
            raise ParameterError("the lamp must not stand at its target")
        check_range("lamp angle", self.angle, 1.0, 170.0)
        check_range("lamp map size", self.size, 16, 4096, integer=True)
        check_range("lamp opacity", self.opacity, 0.0, 1.0)
        check_range("lamp ambient", self.ambient, 0.0, 1.0)

    def camera(self):
        """The lamp's view: from its position to its target, its cone as the field of view (an
        up that is not along the view)."""
        forward = np.subtract(self.target, self.position)
        forward = forward / np.linalg.norm(forward)
        up = (0.0, 1.0, 0.0) if abs(forward[1]) < 0.9 else (0.0, 0.0, -1.0)
        distance = float(np.linalg.norm(np.subtract(self.target, self.position)))
        return Camera(eye=self.position, target=self.target, up=up, fov=self.angle,
                      near=distance * 0.02, far=distance * 4.0)


    def check_sprites(self, sprites):
        """Refuse sprites (a :class:`~es2particles.render.sprites.Sprites`) whose shadows this
        lamp cannot cast: one kind of shadow at a time, and sprites of a world size."""
        if sprites.shadow is not None:
            raise ParameterError("one kind of shadow at a time: an opacity shadow map "
                                 "(shadow) or the lamp's light map (lamp)")
        a, b, _ = sprites.attenuation
        if (a, b) != (0.0, 0.0) or sprites.size_law != "perspective":
            raise ParameterError("the lamp's shadows need sprites of a world size: "
                                 "attenuation (0, 0, c) and the perspective size law")

    def plan_scene(self, b, sprites, draw):
        """Draw the opaque scene into the picture lit by the lamp (:func:`plan_lamp`), for the
        sprites' ``draw`` (a :class:`~es2particles.render.sprites.SpriteDraw`)."""
        plan_lamp(b, sprites, sprites.light_size(b, draw, self.camera().focal_pixels(self.size)))


def plan_lamp(b, sprites, light_size):
    """Add the lamp's stages (see the module's docstring) and the meshes' to plan builder ``b``
    for ``sprites`` (a Sprites with a ``lamp``; its meshes, sprite and roles): the light map, the
    object's depth and shadow in it, the particles' light through it, the object and the floor
    drawn lit by it into the image. ``light_size``: the frame value of a sprite's size in the
    map at distance 1 (as the opacity shadow map's). Returns the stages' names."""
    lamp = sprites.lamp
    camera = lamp.camera()
    view_projection = camera.uniform(1.0)
    meshes = sprites.meshes
    casting = [i for i, m in enumerate(meshes, 1) if m.casts_shadow]
    floors = [i for i, m in enumerate(meshes, 1) if not m.casts_shadow]
    size = (lamp.size, lamp.size)
    b.resource(Resource("light map", "target", size, "rgba8", depth=True, linear=True,
                        what=f"the lamp's light map: what light passes the particles and the "
                             f"object, seen from {lamp.position}"))
    lit = {"u_lamp_view_projection": view_projection}
    names = []

    def occluders(step, state, what, clear):
        for i in casting:
            mesh = meshes[i - 1]
            name, _, _ = mesh_vertex_data(b, i, mesh)
            defines, frame = mesh_motion(mesh)
            uniforms = {"u_view_projection": view_projection}
            stage = f"lamp {step}: mesh {i}"
            b.stage(Stage(stage, "lamp", "lamp/occluder.frag", "sprites/mesh.vert", defines,
                          target=Ref("light map"), vertices=name, state=state,
                          uniforms=uniforms, frame_uniforms=frame,
                          clear=clear if not names else None, what=what))
            names.append(stage)

    # 1: the object's depth, seen from the lamp.
    occluders("depth", DrawState(depth_test=True, colour_write=False),
              "the object's depth from the lamp", (1.0, 1.0, 1.0, 1.0))
    # 2: what the particles let through.
    reads = {"position": sprites.roles["position"]}
    if "fade" in sprites.roles:
        reads["life"] = sprites.roles["fade"]
    quantities = {name: _renamed(b.graph_plan.quantities[q], name) for name, q in reads.items()}
    # The shaders declare their own uniforms (lamp/particle.vert and .frag).
    interface = stage_interface(tuple(quantities), quantities, b.format)
    defines = {"FADE": None} if "life" in quantities else {}
    if sprites.growth != 1:
        defines["GROWTH"] = None
    player = {name: q for name, q in reads.items()}
    inputs = {sampler: Ref(player[q], part)
              for sampler, (_, q, part, _) in interface.samplers.items()}
    uniforms = {"u_lamp_view_projection": view_projection, "u_lamp": lamp.position,
                "u_lamp_opacity": float(lamp.opacity)}
    if sprites.growth != 1:
        uniforms["u_growth"] = float(sprites.growth)
    b.stage(Stage(
        "lamp particles", "lamp", "lamp/particle.frag", "lamp/particle.vert", defines,
        vertex_interface=interface, inputs={**inputs, "u_sprite": Ref("sprite")},
        target=Ref("light map"), vertices=b.particle_texels(), primitive="points",
        count=b.layout.count,
        state=DrawState(blend="multiply", depth_test=True, depth_write=False, point_size=True,
                        sprites=True),
        uniforms=uniforms, generated=generated_values(interface, b.layout),
        frame_uniforms={"u_light_size": light_size},
        clear=None if casting else (1.0, 1.0, 1.0, 1.0),
        what="each particle multiplies the light that passes by 1 - its opacity"))
    names.append("lamp particles")
    shading = ({"LAMP": None}, {"u_light_map": Ref("light map")},
               {**lit, "u_ambient": float(lamp.ambient)})
    background = (*map(float, sprites.background), 1.0)
    # 3: the object, lit through the particles' shadows.
    names += plan_meshes(b, meshes, lamp.position, "image", background, only=casting,
                         lamp=shading)
    # 4: the object's own shadow in the map, for the floor.
    occluders("shadow", DrawState(), "the object's shadow, black", None)
    # 5: the floor, lit through the particles' and the object's shadows.
    floor_clear = None if casting else background
    names += _floors(b, meshes, lamp, floors, shading, floor_clear)
    return names


def _floors(b, meshes, lamp, floors, shading, clear):
    # plan_meshes clears with the first mesh it draws: only where nothing was drawn before.
    if not floors:
        return []
    return plan_meshes(b, meshes, lamp.position, "image", clear, only=floors, lamp=shading)


def _renamed(quantity, name):
    from dataclasses import replace

    return replace(quantity, name=name)

