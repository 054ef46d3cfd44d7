"""3D particles: one textured billboard sprite per particle, over opaque meshes, into an RGBA8 image
with depth; declared by a scene as :class:`Sprites` and planned as stages of the frame.

Opaque meshes (``meshes.py``) are drawn first, with depth test and writes; then every particle
is one point sprite (``sprites/sprite.vert``): its position and life fetched from the state
textures, its size attenuated with the eye distance and clamped to the point sizes the driver
draws (probed: ``Capabilities.drawn_point_size_range``), a sprite texture over ``gl_PointCoord``
mixed with a tint, alpha falling with age, blended additively or "over" (premultiplied),
depth-tested against the meshes with depth writes off, so a
particle behind the cube is hidden and particles never hide each other.

The sprites take features, each declared on its own and planning its own stages: sorting back
to front (``sort.py: DepthSort``), an opacity shadow map (``shadow.py: OpacityShadow``) or the
ARM chapter's lamp (``lamp.py: Lamp``), soft particles and a buffer at a lower resolution
(``buffer.py``), and light shafts (``shafts.py``).
"""

from dataclasses import dataclass, replace

import numpy as np

from ..errors import CapabilityError, ParameterError, check_range
from ..frame.plan import Ref, Rendering, Resource, Stage
from ..frame.settings import setting
from ..gl.bindings import generated_values, stage_interface
from ..gl.device import DrawState
from ..params import param
from .buffer import (BufferParams, SoftParams, SoftParticles, SpriteBuffer, plan_buffered,
                     scene_depth_texture)
from .lamp import Lamp
from .meshes import plan_meshes
from .points import vertex_fetch
from .shadow import OpacityShadow
from .shafts import ShaftParams, Shafts, plan_shafts
from .sort import DepthSort

BLENDS = ("add", "over")
# The renderer's inputs: role -> (the name its shader reads it by, components, define).
# How a sprite's size follows the camera: "perspective", size * sqrt(1 / (a + b d + c d^2)) at
# its eye distance d (size over d for (0, 0, c)); "jogl", the JOGL seed's scalePointSize: every
# sprite's size over the camera's squared xz distance to an anchor (the fountain's base), as a
# fraction of its squared distance at the start, clamped to the point size range.
SIZE_LAWS = ("perspective", "jogl")
ROLES = {"position": ("position", (3,), None), "fade": ("life", (2,), "FADE"),
         "size": ("size_factor", (1,), "SIZE"), "colour": ("colour", (3,), "COLOUR"),
         "orientation": ("orientation", (1,), "ORIENTATION"),
         "heading": ("heading", (3,), "HEADING")}


# --- sprite textures --------------------------------------------------------------------------

def fireball_texture(size=64):
    """A 64x64 RGBA fireball: a white-yellow core through orange to a transparent red rim."""
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size * 2 - 1
    r = np.clip(np.hypot(x, y), 0, 1)
    rgba = np.stack([np.ones_like(r), np.clip(1.2 - 1.3 * r, 0, 1) ** 1.5,
                     np.clip(1 - 2 * r, 0, 1) ** 2, np.clip(1 - r, 0, 1) ** 1.5], -1)
    return (rgba * 255).round().astype(np.uint8)


def disc_texture(size=64):
    """A soft white disc: alpha falls smoothly from the centre to the rim."""
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size * 2 - 1
    a = np.clip(1 - np.hypot(x, y), 0, 1) ** 2 * (3 - 2 * np.clip(1 - np.hypot(x, y), 0, 1))
    rgba = np.stack([np.ones_like(a)] * 3 + [a], -1)
    return (rgba * 255).round().astype(np.uint8)


def smoke_texture(size=64):
    """A soft puff: white, alpha (1 - r^2)^3, a radial falloff with no edge (the Mali sample's
    sprites fade towards their rims)."""
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size * 2 - 1
    a = np.clip(1 - (x * x + y * y), 0, 1) ** 3
    rgba = np.stack([np.ones_like(a)] * 3 + [a], -1)
    return (rgba * 255).round().astype(np.uint8)


def puff_texture(size=64, seed=7):
    """The ARM chapter's smoke sprite: a noise texture that reads as a volume. Alpha is a soft
    radial falloff broken by fractal value noise; the colour is shaded as a lit ball (its
    normal from the disc, lit from the upper left) times the noise, so overlapping puffs look
    like lumpy smoke rather than flat discs."""
    rng = np.random.default_rng(seed)
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size * 2 - 1
    noise = np.zeros((size, size))
    for octave in range(4):
        cells = 4 * 2 ** octave
        grid = rng.random((cells + 1, cells + 1))
        u = (x + 1) / 2 * cells
        v = (y + 1) / 2 * cells
        i, j = np.minimum(u.astype(int), cells - 1), np.minimum(v.astype(int), cells - 1)
        fu, fv = u - i, v - j
        fu, fv = fu * fu * (3 - 2 * fu), fv * fv * (3 - 2 * fv)
        value = ((grid[j, i] * (1 - fu) + grid[j, i + 1] * fu) * (1 - fv)
                 + (grid[j + 1, i] * (1 - fu) + grid[j + 1, i + 1] * fu) * fv)
        noise += value / 2 ** octave
    noise /= noise.max()
    r2 = np.clip(x * x + y * y, 0, 1)
    falloff = (1 - r2) ** 2
    alpha = np.clip(falloff * (0.35 + 0.9 * noise), 0, 1)
    normal_z = np.sqrt(1 - r2)
    lit = np.clip(-0.45 * x - 0.45 * y + 0.77 * normal_z, 0, 1)  # y runs down the image
    shade = np.clip((0.55 + 0.45 * lit) * (0.8 + 0.25 * noise), 0, 1)
    rgba = np.stack([shade, shade, shade, alpha], -1)
    return (rgba * 255).round().astype(np.uint8)


def arrow_texture(size=64):
    """A white dart pointing right (+x, the way a heading turns it): a triangle from its tip at
    0.92 of the width to its base at 0.18, 0.56 of the height across, its edges three texels
    soft (a sharper edge lands on either side of a pixel as two rasterisers turn it)."""
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size
    tip, base, half = 0.92, 0.18, 0.28
    along = (x - base) / (tip - base)  # 0 at the base, 1 at the tip
    edge = half * (1 - along) - np.abs(y - 0.5)  # inside where > 0, in texture widths
    inside = np.minimum(np.minimum(edge * np.hypot(1.0, half / (tip - base)),
                                   x - base), tip - x)
    a = np.clip(inside * size / 3 + 0.5, 0, 1)
    rgba = np.stack([np.ones_like(a)] * 3 + [a], -1)
    return (rgba * 255).round().astype(np.uint8)


SPRITES = {"fireball": fireball_texture, "disc": disc_texture, "smoke": smoke_texture,
           "puff": puff_texture, "arrow": arrow_texture}


def load_sprite(spec):
    """A sprite texture (h, w, 4) uint8: ``fireball``, ``disc``, ``smoke``, ``puff`` or a PNG
    path."""
    if spec in SPRITES:
        return SPRITES[spec]()
    from ..io.images import read_image

    return np.asarray(read_image(spec, sprite_option()), dtype=np.uint8)


def sprite_option():
    """How a refusal of ``--sprite`` names it."""
    return f"--sprite (one of {sorted(SPRITES)} or a PNG path)"


def check_sprite(spec):
    """Refuse a ``--sprite`` that is neither a texture's name nor a PNG file, before any work."""
    if spec not in SPRITES:
        from ..io.images import check_png

        check_png(spec, sprite_option())


def sprite_image(spec):
    """A sprite texture (h, w, 4) uint8: a name of :data:`SPRITES`, a PNG path, or an (h, w, 4)
    uint8 array as it is."""
    if isinstance(spec, np.ndarray):
        if spec.ndim != 3 or spec.shape[2] != 4 or spec.dtype != np.uint8 or 0 in spec.shape:
            raise ParameterError(f"a sprite array must be (h, w, 4) uint8, got {spec.shape} "
                                 f"{spec.dtype}")
        return spec
    return load_sprite(spec)


# --- the look a scene's options set --------------------------------------------------------------

def blend_param(default):
    return param(default, choices=BLENDS, help="sprites glow (add) or cover (over)")


def sprite_param(default):
    return param(default, text=True,
                 help="sprite texture: fireball, disc, smoke, puff (the chapter's noise volume) "
                      "or a PNG path")


@dataclass(frozen=True)
class SpriteLook(BufferParams, SoftParams, ShaftParams):
    """The sprites' look, declared by the rendering: a scene drawn by :class:`Sprites` takes
    these options beside its own, and a scene drawn otherwise lists none of them. The features
    a rendering takes declare their own (the light shafts', the soft particles', the sprite
    buffer's: ``shafts.py``, ``buffer.py``). A scene re-declares a field with
    :func:`blend_param` or :func:`sprite_param` for its own default."""

    blend: str = blend_param("add")
    sprite: str = sprite_param("fireball")
    size_law: str = param("perspective", choices=SIZE_LAWS,
                          help="how sprite sizes follow the camera: perspective (size over the "
                               "eye distance) or jogl (the seed's: size over the camera's squared "
                               "xz distance to the target, as a fraction of the first camera's)")

    def check(self):
        super().check()
        check_sprite(self.sprite)

    def sprite_look(self):
        """The :class:`Sprites` fields these options set."""
        return {"blend": self.blend, "sprite": self.sprite, "soft": self.soft_particles(),
                "buffer": self.sprite_buffer()}


# --- the declaration ----------------------------------------------------------------------------

@dataclass(frozen=True)
class Sprites(Rendering):
    """A 3D scene's rendering: ``meshes`` (opaque, first), then one point sprite per particle,
    read from ``position`` (3 components) and ``life`` (age, lifetime), into an RGBA8 image with
    depth, seen through the scene's camera.

    Parameters
    ----------
    sprite : str or array
        ``fireball``, ``disc``, ``smoke``, a PNG path, or an (h, w, 4) uint8 array.
    size_spread : float
        Per-particle sizes vary by +-this fraction (a hash of the texel), in [0, 0.99].
    attenuation : (a, b, c)
        Size factor sqrt(1 / (a + b d + c d^2)) at eye distance d. The sprite's size (the run's
        point size, in pixels of an image 1024 high: it scales with the image height) is its size
        where this factor is 1.
    fade : float
        Below this size (pixels) a sprite stays this size and fades by (size / fade)^2.
    blend : str
        ``add`` (glowing: colours sum) or ``over`` (premultiplied alpha).
    tint : (r, g, b, amount)
        The colour mixed into the sprite texture's, and how much of it.
    opacity : float
    light : (x, y, z)
        The point light of the meshes.
    background : (r, g, b)
    sort : sort.DepthSort or None
        Draw order: None, the particles' texel order; a :class:`~es2particles.render.sort.
        DepthSort`, back to front. Order matters for ``over``.
    shadow : shadow.OpacityShadow or None
        Self-shadowing by an opacity shadow map seen from its light; needs attenuation
        (0, 0, c), so that a sprite has one world size.
    growth : float
        A sprite's size at the end of its life, relative to its birth (smoke puffs spread).
    meshes : tuple of meshes.Mesh
    roles : mapping
        The renderer's inputs, role -> the scene's quantity that plays it: ``position`` (3
        components, required); ``fade`` (a life clock, (age, lifetime): alpha falls with age,
        unborn and dead particles are not drawn; without it every particle is drawn whole);
        ``size`` (1 component, a factor of the sprite's size); ``colour`` (3 components, the
        particle's tint in place of ``tint``'s colour); ``orientation`` (1 component: an angle in
        radians, the sprite's texture turned counterclockwise on screen by it; a texture's
        corners that turn out of the point's square are cut); ``heading`` (3 components, a
        velocity: the texture turned to point, on screen, the way the particle moves; its +x is
        the front). Default: position and fade by ``life``.
    lamp : lamp.Lamp or None
        The ARM chapter's spot lamp: the particles' shadows on the meshes, the meshes' on the
        floor (one kind of shadow at a time: ``shadow`` or ``lamp``).
    soft : buffer.SoftParticles or None
        Sprites that fade into the opaque scene behind them.
    buffer : buffer.SpriteBuffer or None
        The sprites drawn into a buffer at a lower resolution, laid over the picture.
    shafts : shafts.Shafts or None
        Light shafts over the picture, the sprites among their occluders.

    The sort, the shadow map, the lamp, soft particles, the buffer and the shafts are features
    of their own: each is declared by its own object (and its options, where a scene offers
    them, by its own parameters), checks what it needs of the sprites, and plans its own stages.
    """

    sprite: object = "fireball"
    size_spread: float = 0.5
    attenuation: tuple = (0.0, 0.0, 1.0)
    fade: float = 1.0
    blend: str = "add"
    tint: tuple = (1.0, 0.15, 0.05, 0.35)
    opacity: float = 0.8
    light: tuple = (3.0, 6.0, 4.0)
    background: tuple = (0.05, 0.06, 0.09)
    sort: object = None
    shadow: object = None
    growth: float = 1.0
    meshes: tuple = ()
    roles: object = None
    size_law: str = "perspective"
    law_anchor: tuple = (0.0, 0.0)
    law_distance: float = 1.0
    lamp: object = None
    soft: object = None
    buffer: object = None
    shafts: object = None

    settings = ("point_size", "vertex_fetch")
    has_camera = True
    kind = "it draws 3D sprites: no tone map or accumulation"

    # Each feature's slot and the declaration it takes.
    FEATURES = {"sort": DepthSort, "shadow": OpacityShadow, "lamp": Lamp, "soft": SoftParticles,
                "buffer": SpriteBuffer, "shafts": Shafts}

    def __post_init__(self):
        if self.blend not in BLENDS:
            raise ParameterError(f"blend must be one of {BLENDS}, got {self.blend!r}")
        check_range("size_spread", self.size_spread, 0.0, 0.99)
        a, b, c = (check_range("attenuation", v, 0.0, 1e6) for v in self.attenuation)
        if a + b + c <= 0:
            raise ParameterError("attenuation (a, b, c) must not be all zero")
        check_range("opacity", self.opacity, 0.0, 1.0)
        check_range("growth", self.growth, 0.01, 100.0)
        if self.size_law not in SIZE_LAWS:
            raise ParameterError(f"size law must be one of {', '.join(SIZE_LAWS)}, got "
                                 f"{self.size_law!r}")
        if self.size_law == "jogl":
            if len(self.law_anchor) != 2:
                raise ParameterError(f"law_anchor is the x, z of the point the camera's "
                                     f"distance is taken to, got {self.law_anchor}")
            for v in self.law_anchor:
                check_range("law_anchor", v)
            check_range("law_distance", self.law_distance, 1e-6, 1e6)
        object.__setattr__(self, "meshes", tuple(self.meshes))
        roles = {"position": "position", "fade": "life"} if self.roles is None \
            else dict(self.roles)
        unknown = [r for r in roles if r not in ROLES]
        if unknown or "position" not in roles:
            raise ParameterError(f"sprite roles are {', '.join(ROLES)} (position required), "
                                 f"got {', '.join(roles)}")
        if "heading" in roles and "orientation" in roles:
            raise ParameterError("sprite roles: a heading or an orientation turns the texture, "
                                 "not both")
        object.__setattr__(self, "roles", roles)
        for slot, kind in self.FEATURES.items():
            feature = getattr(self, slot)
            if feature is not None and not isinstance(feature, kind):
                raise ParameterError(f"sprites' {slot} must be a {kind.__name__} or None, got "
                                     f"{feature!r}")
        for feature in (self.shadow, self.lamp):  # what a shadow needs of the sprites
            if feature is not None:
                feature.check_sprites(self)

    @property
    def reads(self):
        """The quantities the sprites read, the roles' players."""
        return tuple(dict.fromkeys(self.roles.values()))

    def role_quantities(self, graph_plan):
        """Each role's quantity under the name its shader reads it by (its texture is the
        scene's quantity's), checked for its components: name -> Quantity."""
        out = {}
        for role, quantity in self.roles.items():
            name, components, _ = ROLES[role]
            q = graph_plan.quantities[quantity]
            if q.components not in components:
                raise ParameterError(f"the sprites' {role} role takes a quantity of "
                                     f"{' or '.join(map(str, components))} components; "
                                     f"{quantity!r} has {q.components}")
            out[name] = replace(q, name=name)
        return out

    def role_inputs(self, interface):
        """The :class:`Ref` of each sampler of an interface written for :meth:`role_quantities`:
        the scene's quantity behind the role."""
        player = {ROLES[role][0]: quantity for role, quantity in self.roles.items()}
        return {sampler: Ref(player[q], part) for sampler, (_, q, part, _) in
                interface.samplers.items()}

    def role_attributes(self, interface):
        """The :class:`Ref` of each attribute of an interface written for
        :meth:`role_quantities` that reads the state back: the scene's quantity behind it."""
        player = {ROLES[role][0]: quantity for role, quantity in self.roles.items()}
        return {name: Ref(player[q], part) for name, (q, part) in interface.attributes.items()}

    def unlit_message(self, point_size, size, camera):
        """Why a picture of these sprites may have no lit pixel: their diameter at the camera's
        distance from its target, from ``point_size`` (pixels of an image 1024 high), the image
        ``size`` and the attenuation."""
        a, b, c = self.attenuation
        d = float(np.linalg.norm(np.subtract(camera.eye, camera.target)))
        diameter = point_size * size[1] / 1024 / np.sqrt(a + b * d + c * d * d)
        return (f"no sprite lit a pixel: sprites of point size {point_size:g} with attenuation "
                f"({a:g}, {b:g}, {c:g}) are {diameter:.2g} pixels across at the camera's "
                f"distance {d:.3g} from its target; raise the point size, lower the "
                f"attenuation or bring the camera closer (or the particles are out of sight)")

    def plan(self, b, defaults):
        """Add the features' stages (the sort's network, the shadow map, the lamp's), the
        meshes, the sprites and the light shafts to plan builder ``b``; returns the picture the
        frame presents."""
        caps, layout, fmt = b.caps, b.layout, b.format
        quantities = self.role_quantities(b.graph_plan)
        fetch = vertex_fetch(b)
        self._check_fetch(b, fetch, quantities)
        pixel_size = setting("point_size", b.setting("point_size")) * b.size[1] / 1024
        texture = sprite_image(self.sprite)
        h, w = texture.shape[:2]
        # Not flipped: gl_PointCoord's t = 0 is the top of the point, where the image's first
        # row belongs (meshes' textures are flipped: their v = 0 is the bottom).
        b.resource(Resource("sprite", "image", (w, h), "rgba8", linear=True, data=texture,
                            what="the sprite texture"))
        # A buffer of their own: soft sprites take one at the picture's resolution.
        buffer = self.buffer or (SpriteBuffer() if self.soft is not None else None)
        draw = self._draw(b, quantities, fetch, pixel_size, buffer)
        # The light shafts' occluders draw the same sprites in texel order (the multiply blend
        # needs no order), unshadowed.
        occluder = draw.copy()
        if self.sort is not None:
            self.sort.attach(b, self, draw)
        else:
            draw.vertices = b.particle_texels()  # each sprite's texel: its hashed size, its state
            b.left_out.append("depth sort (switched off: texel order)")
        if self.shadow is not None:
            self.shadow.attach(b, self, draw)
        else:
            b.left_out.append("shadow map (switched off)")
        # where a buffer's sprites read the scene's distance (a buffer without soft sprites:
        # the default rule, the texture where the context has one)
        depth_texture = buffer is not None and scene_depth_texture(
            caps, self.meshes, self.soft.scene_depth if self.soft else "auto")
        b.resource(Resource("image", "target", b.size, "rgba8",
                            depth="texture" if depth_texture else True, linear=True,
                            what="the picture, with its depth" + (
                                " (a texture the sprites read)" if depth_texture else "")))
        if self.lamp is not None:
            self.lamp.plan_scene(b, self, draw)
        else:
            background = tuple(float(v) for v in self.background)
            plan_meshes(b, self.meshes, self.light, "image", (*background, 1.0))
        if fetch:
            how = f"vertex texture fetch of {', '.join(self.reads)}"
        else:
            texels = sum(q.parts(fmt) for q in quantities.values())
            how = (f"no vertex texture fetch: {', '.join(self.reads)} read back each frame and "
                   f"uploaded as vertex attributes ({texels} texture read{'s' * (texels > 1)})")
        draw.what = f"{layout.count} point sprites in {draw.order}, {how}"
        if buffer is not None:
            picture = plan_buffered(b, self, draw, buffer, self.soft, depth_texture)
        else:
            picture = self._plan_direct(b, draw)
        return plan_shafts(b, self.shafts, picture,
                           self.lamp.position if self.lamp is not None else self.light,
                           self.meshes,
                           lambda target, clear: self._plan_occluders(b, occluder, target, clear))

    def light_size(self, b, draw, light_focal):
        """The frame value of a sprite's size seen from a light of focal length
        ``light_focal`` pixels (a shadow map's, the lamp's): its world size, the picture's
        ``draw.pixel_size`` at distance 1 over the camera's focal length (attenuation (0, 0, c),
        which both shadows need), in the light's pixels."""
        per_focal = draw.pixel_size / np.sqrt(self.attenuation[2])
        return ("light_size", per_focal, light_focal, float(self.size_spread), b.size[1])

    def _check_fetch(self, b, fetch, quantities):
        """Refuse the features that read textures in the sprites' vertex shader (or draw the
        sprites again) without vertex texture fetch, and more textures there than the context
        allows."""
        # ES 2.0 promises no vertex texture units at all; each part of a read quantity and
        # each of a feature's textures take one. Without them (--vertex-fetch off, or auto on
        # a context with none) the state is read back into vertex attributes each frame, as
        # the points do.
        caps = b.caps
        features = [f for f in (self.sort, self.shadow, self.lamp, self.shafts) if f is not None]
        if not fetch and features:
            why = ("--vertex-fetch off" if b.setting("vertex_fetch") == "off"
                   else "this context has no vertex texture units")
            raise CapabilityError(f"{why}: {' and '.join(f.what for f in features)} of this "
                                  "scene's sprites read textures in their vertex shader, which "
                                  "needs vertex texture fetch (switch them off where the scene "
                                  "offers it: --sort off, --shadows off, --shafts off)")
        needed = (sum(q.parts(b.format) for q in quantities.values())
                  + sum(f.vertex_textures for f in features))
        if fetch and needed > caps.max_vertex_texture_units:
            raise CapabilityError(f"the sprites' vertex shader samples {needed} textures; this "
                                  f"context allows {caps.max_vertex_texture_units} "
                                  "(GL_MAX_VERTEX_TEXTURE_IMAGE_UNITS): leave out sorting or "
                                  "shadows, or store the state in a float format (one texture "
                                  "per quantity)")

    def _draw(self, b, quantities, fetch, pixel_size, buffer):
        """The sprites' draw before any feature changes it: their shader's defines, samplers,
        uniforms and frame values, and its interface to the state."""
        lo, hi = b.caps.drawn_point_size_range
        fade = check_range("fade", self.fade, 0.0, hi)
        a, b_, c = (float(v) for v in self.attenuation)
        defines = {} if self.growth == 1 else {"GROWTH": None}
        defines.update({ROLES[role][2]: None for role in self.roles if ROLES[role][2]})
        uniforms = {"u_attenuation": (a, b_, c), "u_fade": float(fade),
                    "u_opacity": float(self.opacity),
                    "u_tint": tuple(float(v) for v in self.tint)}
        if self.growth != 1:
            uniforms["u_growth"] = float(self.growth)
        if "heading" in self.roles:  # a screen direction's pixels: x times the aspect
            uniforms["u_aspect"] = float(b.size[0] / b.size[1])
        # A buffer at a lower resolution draws the sprites at its own scale.
        drawn_pixels = pixel_size * float(buffer.scale if buffer is not None else 1.0)
        frame = {"u_view_projection": ("view_projection",), "u_eye": ("eye",),
                 "u_size": ("sprite_size", drawn_pixels, float(self.size_spread))}
        if self.size_law == "jogl":  # one size a frame, from the camera: no attenuation
            uniforms["u_attenuation"] = (1.0, 0.0, 0.0)
            frame["u_size"] = ("jogl_sprite_size", drawn_pixels, float(self.size_spread),
                               *map(float, self.law_anchor), float(self.law_distance))
        own = {"u_eye": (0.0, 0.0, 1.0), "u_size": (pixel_size, self.size_spread, lo, hi),
               "u_attenuation": (a, b_, c), "u_fade": float(fade)}
        interface = stage_interface(tuple(quantities), quantities, b.format, own,
                                    attributes=not fetch)
        return SpriteDraw(interface, defines, {"u_sprite": Ref("sprite")}, uniforms, frame,
                          pixel_size)

    def _plan_occluders(self, b, occluder, target, clear):
        """The sprites into the light shafts' occluders, at the picture's resolution: each
        multiplies the light passing by one less its opacity (``OCCLUDER``), behind the meshes
        hidden by their depth."""
        size = list(occluder.frame["u_size"])
        size[1] = occluder.pixel_size  # the picture's size, not a smaller sprite buffer's
        b.stage(Stage(
            "shaft occluders: sprites", "shafts", "sprites/sprite.frag", "sprites/sprite.vert",
            {**occluder.defines, "OCCLUDER": None}, vertex_interface=occluder.interface,
            inputs={**self.role_inputs(occluder.interface), **occluder.inputs},
            target=Ref(target), vertices=b.particle_texels(), primitive="points",
            count=b.layout.count,
            state=DrawState(blend="multiply", depth_test=bool(self.meshes), depth_write=False,
                            point_size=True, sprites=True),
            uniforms=occluder.uniforms, generated=generated_values(occluder.interface, b.layout),
            frame_uniforms={**occluder.frame, "u_size": tuple(size)}, clear=clear,
            what="each lets 1 - its opacity of the light through"))

    def _plan_direct(self, b, draw):
        """The sprites straight into the picture, depth-tested against the meshes."""
        layout, background = b.layout, tuple(float(v) for v in self.background)
        b.stage(Stage(
            "sprites", "sprites", "sprites/sprite.frag", "sprites/sprite.vert", draw.defines,
            vertex_interface=draw.interface,
            inputs={**self.role_inputs(draw.interface), **draw.inputs},
            attributes=self.role_attributes(draw.interface),
            target=Ref("image"), vertices=draw.vertices, primitive="points", count=layout.count,
            state=DrawState(blend=self.blend, depth_test=True, depth_write=False,
                            point_size=True, sprites=True),
            uniforms=draw.uniforms, generated=generated_values(draw.interface, layout),
            frame_uniforms=draw.frame,
            clear=None if self.meshes or self.lamp else (*background, 1.0), what=draw.what))
        return "image"


@dataclass
class SpriteDraw:
    """The sprites' draw as :class:`Sprites` and its features build it, before it is staged:
    the shader's ``interface`` to the state, its ``defines``, samplers (``inputs``), uniforms
    and ``frame`` values, the ``vertices`` it walks (the texels, or the sort's slots) in
    ``order``, ``pixel_size`` (a sprite's size in the picture, pixels, where its factor is 1)
    and what the plan says of it."""

    interface: object
    defines: dict
    inputs: dict
    uniforms: dict
    frame: dict
    pixel_size: float
    vertices: str = None
    order: str = "texel order"
    what: str = ""

    def copy(self):
        """A copy whose mappings a feature may change without changing these."""
        return replace(self, defines=dict(self.defines), inputs=dict(self.inputs),
                       uniforms=dict(self.uniforms), frame=dict(self.frame))
