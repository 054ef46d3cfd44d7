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

import moderngl
import numpy as np

from .camera import Camera
from ..gl.context import bytes_per_texel, numpy_dtype
from ..errors import CapabilityError, ParameterError, check_range
from ..frame.graph import format_bytes

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


def choose_format(ctx, fmt):
    """The map's format and a note saying why."""
    if fmt != "auto":
        if not ctx.caps.blendable.get(fmt):
            raise CapabilityError(f"shadow format {fmt} cannot be blended into on "
                                  f"{ctx.caps.renderer}")
        return fmt, fmt
    for candidate in ("rgba32f", "rgba16f"):
        if ctx.caps.blendable.get(candidate):
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


class ShadowMap:
    """The map's target and pass for a sprite renderer (which owns it, and it its GL objects).

    Parameters
    ----------
    ctx : Context
    settings : OpacityShadow
    quantities, layout, state_format
        What the pass reads (position, life), as the sprite renderer's.
    sprite : texture
        The sprite renderer's sprite texture (owned by it): its alpha is each particle's
        footprint in the map too.
    opacity : float
        A sprite's opacity at its centre.
    size_spread, point_size_range, growth
        As the sprite renderer's, so each particle's size matches its sprite.
    """

    def __init__(self, ctx, settings, quantities, layout, state_format, sprite, opacity,
                 size_spread, point_size_range, growth=1.0):
        from .points import ParticleStage

        self.ctx, self.settings = ctx, settings
        self.format, self.format_note = choose_format(ctx, settings.format)
        self.unit = RGBA8_UNIT if self.format == "rgba8" else 1.0
        camera = settings.camera()
        self.view_projection = camera.uniform(1.0)
        self.focal = camera.focal_pixels(settings.size)
        self.size_spread, self.point_size_range = size_spread, point_size_range
        self.opacity, self.sprite = float(opacity * self.unit), sprite
        self.group = ctx.group()
        try:
            self.stage = ParticleStage(self.group, "sprites/shadow.vert", "sprites/shadow.frag",
                                       "the shadow map pass", quantities, state_format, layout,
                                       {}, {} if growth == 1 else {"GROWTH": None})
            self.sprite_unit = len(self.stage.units)
            self.stage.set_many({"u_sprite": self.sprite_unit, **self.uniforms()})
            if growth != 1:
                self.stage.set_many({"u_growth": float(growth)})
            self.map = self.group.texture((settings.size, settings.size), self.format)
            self.framebuffer = self.group.framebuffer(self.map)
        except Exception:
            self.group.release()
            raise

    def uniforms(self):
        """What ``lib/shadow.glsl`` reads, for any program that includes it."""
        s = self.settings
        forward, front = s.axis()
        return {"u_light_view_projection": self.view_projection,
                "u_light_eye": tuple(map(float, s.light)),
                "u_light_axis": (*map(float, forward), float(front)),
                "u_shadow": (float(s.layer_depth() * LAYERS), 1.0 / self.unit,
                             float(s.extinction), float(s.ambient)),
                "u_shadow_size": float(s.size), "u_shadow_opacity": self.opacity}

    def sizes(self, world_size):
        """``u_light_size`` for sprites of diameter ``world_size`` (world units, before the
        per-particle factor): at distance d from the light they span world_size / d radians, as
        they do from the eye."""
        lo, hi = self.point_size_range
        return {"u_light_size": (float(world_size * self.focal), float(self.size_spread),
                                 float(lo), float(hi))}

    def draw(self, buffers, world_size):
        """Clear the map and add every particle, each a sprite of ``world_size`` (see
        :meth:`sizes`); returns the map."""
        self.stage.bind(buffers)
        self.sprite.use(self.sprite_unit)
        self.stage.set_many(self.sizes(world_size))
        with self.ctx.scope(self.framebuffer, blend="add", point_size=True, sprites=True):
            self.framebuffer.clear(0.0, 0.0, 0.0, 0.0)
            self.stage.vao.render(moderngl.POINTS)
        return self.map

    def read(self):
        """The map as (size, size, 4) float64 opacities (row 0 at the bottom), in opacity units."""
        data = np.frombuffer(self.map.read(), dtype=numpy_dtype(self.format))
        data = data.reshape(self.settings.size, self.settings.size, 4).astype(np.float64)
        if self.format == "rgba8":
            data /= 255.0
        return data / self.unit

    def describe(self):
        s = self.settings
        return (f"opacity shadow map: {LAYERS} layers of {s.layer_depth():.3g} m from the light "
                f"at {tuple(round(v, 3) for v in s.light)} in one {self.format_note} target "
                f"{s.size}x{s.size} "
                f"({format_bytes(s.size * s.size * bytes_per_texel(self.format))}), one additive "
                f"pass of the particles")

    def release(self):
        self.group.release()


