"""Opacity shadow maps (Kim and Neumann 2001), as the Mali smoke sample: particles shadow each other.

Seen from the light, every particle is drawn as a point sprite of its world size and adds its
opacity to the channel of its depth layer: four layers of a slab around the smoke in one RGBA
target, one pass, one render target (``sprites/shadow.vert``). The sprites then fetch the map
once per particle (``lib/shadow.glsl``): the opacity in front of a particle is the layers nearer
the light plus the share of its own layer in front of it, and it is lit by exp(-extinction *
opacity) above an ambient floor.

The map is float (RGBA32F, else RGBA16F) where the context can blend into it. RGBA8, the ES 2.0
baseline and the Mali sample's format, saturates at 1 per channel and rounds every blended
addition to 1/255: the opacities are stored in units of ``RGBA8_UNIT`` (so a channel holds
1 / RGBA8_UNIT opaque particles before it saturates) and a sprite's faint rim, below half a code
per addition, adds nothing (``tests/test_smoke.py`` measures both).
"""

from dataclasses import dataclass

import numpy as np

from ..errors import CapabilityError, ParameterError, check_range
from ..frame.plan import Ref, Resource, Stage
from ..gl.bindings import generated_values, stage_interface
from ..gl.device import DrawState
from .camera import Camera

LAYERS = 4
FORMATS = ("auto", "rgba32f", "rgba16f", "rgba8")
RGBA8_UNIT = 1 / 32


@dataclass(frozen=True)
class OpacityShadow:
    """Settings of an opacity shadow map: a point ``light`` looking at the sphere of ``radius``
    around ``centre`` that holds the particles (the layers divide its depth from the light), a
    ``size`` x ``size`` map, ``extinction`` (optical depth per unit of summed opacity),
    ``ambient`` (the light a fully shadowed particle keeps) and the map's ``format``."""

    light: tuple
    centre: tuple
    radius: float
    size: int = 256
    extinction: float = 1.0
    ambient: float = 0.2
    format: str = "auto"

    what = "the shadow map"  # how a refusal names it, as a feature of Sprites
    vertex_textures = 2  # the map and the sprite texture, for a sprite's footprint in it

    def __post_init__(self):
        for name in ("light", "centre"):
            value = tuple(float(check_range(f"shadow {name}", v)) for v in getattr(self, name))
            if len(value) != 3:
                raise ParameterError(f"shadow {name} must be three numbers, got {value}")
            object.__setattr__(self, name, value)
        check_range("shadow radius", self.radius, 1e-3, 1e6)
        check_range("shadow size", self.size, 16, 4096, integer=True)
        check_range("shadow extinction", self.extinction, 0.0, 1e3)
        check_range("shadow ambient", self.ambient, 0.0, 1.0)
        if self.format not in FORMATS:
            raise ParameterError(f"shadow format must be one of {FORMATS}, got {self.format!r}")
        if self.distance < 1.1 * self.radius:
            raise ParameterError(f"the light must be outside the shadowed sphere (at least 1.1 "
                                 f"radius = {1.1 * self.radius:g} from its centre), got "
                                 f"{self.distance:.3g}")

    @property
    def distance(self):
        return float(np.linalg.norm(np.subtract(self.light, self.centre)))

    def camera(self):
        """The light's view: a perspective camera whose cone just holds the sphere."""
        d, r = self.distance, self.radius
        fov = 2 * np.degrees(np.arcsin(r / d))
        up = (0.0, 1.0, 0.0) if abs(np.subtract(self.centre, self.light)[1]) < 0.99 * d \
            else (0.0, 0.0, 1.0)
        return Camera(eye=self.light, target=self.centre, up=up, fov=fov, near=d - r, far=d + r)

    def axis(self):
        """(unit viewing direction, depth of the slab's front): the layers' frame."""
        return self.camera().forward, self.distance - self.radius

    def layer_depth(self):
        return 2 * self.radius / LAYERS

    def check_sprites(self, sprites):
        """Refuse sprites (a :class:`~es2particles.render.sprites.Sprites`) this map cannot
        shadow: it draws each at its world size, from its life."""
        a, b, _ = sprites.attenuation
        if (a, b) != (0.0, 0.0):
            raise ParameterError(f"shadow needs attenuation (0, 0, c): sprites that shrink as "
                                 f"1 / distance, as their shadows do (got "
                                 f"{tuple(sprites.attenuation)})")
        if sprites.size_law == "jogl":
            raise ParameterError("the jogl size law gives every sprite one size a frame; a "
                                 "shadow needs sprites that shrink as 1 / distance "
                                 "(perspective)")
        if "fade" not in sprites.roles:
            raise ParameterError("shadow needs a fade role: the map's pass reads each "
                                 "particle's life")

    def attach(self, b, sprites, draw):
        """Plan the map before the sprites' ``draw`` (a
        :class:`~es2particles.render.sprites.SpriteDraw`) and shadow them by it."""
        uniforms, light_size = plan_shadow(b, sprites, draw)
        draw.defines["SHADOWED"] = None
        draw.inputs.update(u_shadow_map=Ref("shadow map"), u_shadow_sprite=Ref("sprite"))
        draw.uniforms.update(uniforms)
        draw.frame["u_light_size"] = light_size


def choose_format(caps, fmt):
    """The map's format on a context of ``caps``, and a note saying why."""
    if fmt != "auto":
        if not caps.blendable.get(fmt):
            raise CapabilityError(f"shadow format {fmt} cannot be blended into on "
                                  f"{caps.renderer}")
        return fmt, fmt
    for candidate in ("rgba32f", "rgba16f"):
        if caps.blendable.get(candidate):
            return candidate, f"{candidate} (auto: float, blendable)"
    return "rgba8", (f"rgba8 (no float target can be blended into: opacity in units of "
                     f"{RGBA8_UNIT:g}, saturating at {1 / RGBA8_UNIT:g})")


def light_through(opacity_before, settings):
    """numpy twin of ``shadow_light``: the light reaching a particle with ``opacity_before`` in
    front of it."""
    s = settings
    return s.ambient + (1 - s.ambient) * np.exp(-s.extinction * np.asarray(opacity_before))


def opacity_map(points, opacity, settings):
    """float64 twin of the map for sprites of one pixel: (size, size, 4), row 0 at the bottom,
    each point's ``opacity`` added to the channel of its layer at the pixel it falls in."""
    s = settings
    pixels, _, visible = s.camera().project(points, (s.size, s.size))
    forward, front = s.axis()
    depth = (np.asarray(points, float) - s.light) @ forward
    layer = np.clip((depth - front) / s.layer_depth(), 0, LAYERS - 1e-3).astype(int)
    x = np.floor(pixels[:, 0]).astype(int)
    y = s.size - 1 - np.floor(pixels[:, 1]).astype(int)  # project() counts rows from the top
    inside = visible & (x >= 0) & (x < s.size) & (y >= 0) & (y < s.size)
    out = np.zeros((s.size, s.size, LAYERS))
    np.add.at(out, (y[inside], x[inside], layer[inside]),
              np.broadcast_to(np.asarray(opacity, float), len(points))[inside])
    return out


def map_uniforms(settings, fmt, opacity):
    """What ``lib/shadow.glsl`` reads, for a map of ``settings`` in ``fmt`` (RGBA8 keeps
    opacities in units of :data:`RGBA8_UNIT`) and sprites of ``opacity``."""
    unit = RGBA8_UNIT if fmt == "rgba8" else 1.0
    forward, front = settings.axis()
    return {"u_light_view_projection": settings.camera().uniform(1.0),
            "u_light_eye": tuple(map(float, settings.light)),
            "u_light_axis": (*map(float, forward), float(front)),
            "u_shadow": (float(settings.layer_depth() * LAYERS), 1.0 / unit,
                         float(settings.extinction), float(settings.ambient)),
            "u_shadow_size": float(settings.size),
            "u_shadow_opacity": float(opacity * unit)}


def plan_shadow(b, sprites, draw):
    """Add the opacity shadow map of ``sprites.shadow`` (a :class:`~es2particles.render.sprites.
    Sprites`'s, drawn by ``draw``) to plan builder ``b``: its target and the pass that draws
    every particle into it, seen from the light as a sprite of its world size
    (:meth:`~es2particles.render.sprites.Sprites.light_size`), adding its opacity to the channel
    of its layer. Returns (the uniforms of ``lib/shadow.glsl`` for any program that includes it,
    the frame value of a sprite's size in the map)."""
    settings, growth = sprites.shadow, sprites.growth
    fmt, note = choose_format(b.caps, settings.format)
    light_size = sprites.light_size(b, draw, settings.camera().focal_pixels(settings.size))
    uniforms = map_uniforms(settings, fmt, sprites.opacity)
    b.resource(Resource("shadow map", "target", (settings.size, settings.size), fmt,
                        what=f"opacity shadow map: {LAYERS} layers of {settings.layer_depth():.3g} "
                             f"m from the light at {tuple(round(v, 3) for v in settings.light)}, "
                             f"{note}"))
    quantities = {name: q for name, q in sprites.role_quantities(b.graph_plan).items()
                  if name in ("position", "life", "size_factor")}
    interface = stage_interface(tuple(quantities), quantities, b.format, {})
    own = dict(uniforms)
    if growth != 1:
        own["u_growth"] = float(growth)
    b.stage(Stage(
        "shadow map", "shadow map", "sprites/shadow.frag", "sprites/shadow.vert",
        {"FADE": None, **({} if growth == 1 else {"GROWTH": None}),
         **({"SIZE": None} if "size_factor" in quantities else {})}, vertex_interface=interface,
        inputs={**sprites.role_inputs(interface), "u_sprite": Ref("sprite")},
        target=Ref("shadow map"), vertices=b.particle_texels(), primitive="points",
        count=b.layout.count, state=DrawState(blend="add", point_size=True, sprites=True),
        uniforms=own, generated=generated_values(interface, b.layout),
        frame_uniforms={"u_light_size": light_size},
        clear=(0.0, 0.0, 0.0, 0.0), what="each particle adds its opacity to its layer"))
    return uniforms, light_size
