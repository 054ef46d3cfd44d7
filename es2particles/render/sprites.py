"""3D particles: one textured billboard sprite per particle, over opaque meshes, into an RGBA8 image
with depth; declared by a scene as :class:`Sprites` and planned as stages of the frame.

Opaque meshes (``meshes.py``) are drawn first, with depth test and writes; then every particle
is one point sprite (``sprites/sprite.vert``): its position and life fetched from the state
textures, its size attenuated with the eye distance and clamped to the point sizes the driver
draws (probed: ``Capabilities.drawn_point_size_range``), a sprite texture over ``gl_PointCoord``
mixed with a tint, alpha falling with age, blended additively or "over" (premultiplied),
depth-tested against the meshes with depth writes off, so a
particle behind the cube is hidden and particles never hide each other. Sorting back to front
(``render/sort.py``) and an opacity shadow map (``render/shadow.py``) are stages of the same plan.
"""

from dataclasses import dataclass, replace

import numpy as np

from ..errors import CapabilityError, ParameterError, check_range
from ..frame.plan import Ref, Rendering, Resource, Stage, Vertices
from ..frame.settings import setting
from ..gl.bindings import generated_values, stage_interface
from ..gl.device import DrawState
from ..params import param
from .meshes import plan_mesh_passes, plan_meshes
from .points import vertex_fetch
from .shafts import ShaftParams

BLENDS = ("add", "over")
# The renderer's inputs: role -> (the name its shader reads it by, components, define).
# How a sprite's size follows the camera: "perspective", size * sqrt(1 / (a + b d + c d^2)) at
# its eye distance d (size over d for (0, 0, c)); "jogl", the JOGL seed's scalePointSize: every
# sprite's size over the camera's squared xz distance to an anchor (the fountain's base), as a
# fraction of its squared distance at the start, clamped to the point size range.
SIZE_LAWS = ("perspective", "jogl")
# Sprites drawn into a buffer of their own (soft, or at a lower resolution) come back over the
# picture by one of these (sprites/upsample.frag); the scene's distance they fade by is read
# from the picture's depth texture or from a packed pre-pass (lib/depth.glsl).
UPSAMPLES = ("nearest", "bilinear", "bilateral")
SCENE_DEPTHS = ("auto", "texture", "packed")
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


def plan_depth_prepass(b, meshes, size):
    """The opaque scene's distance packed into an RGBA8 target (for a context that cannot
    sample a depth buffer): each mesh drawn again with ``sprites/depth.frag``."""
    b.resource(Resource("scene depth", "target", size, "rgba8", depth=True,
                        what="the opaque scene's distance, packed in 16 bits (no depth "
                             "textures to sample)"))
    far = (254 / 255, 254 / 255, 0.0, 1.0)  # pack16(1): the far plane
    plan_mesh_passes(b, meshes, "depth", "depth", "sprites/depth.frag", "scene depth", far,
                     "its distance, packed", {"u_planes": ("depth_planes",)})


# --- the look a scene's options set --------------------------------------------------------------

def blend_param(default):
    return param(default, choices=BLENDS, help="sprites glow (add) or cover (over)")


def sprite_param(default):
    return param(default, text=True,
                 help="sprite texture: fireball, disc, smoke, puff (the chapter's noise volume) "
                      "or a PNG path")


@dataclass(frozen=True)
class SpriteLook(ShaftParams):
    """The sprites' look, declared by the rendering: a scene drawn by :class:`Sprites` takes
    these options (and the light shafts') beside its own, and a scene drawn otherwise lists
    none of them. A scene re-declares a field with :func:`blend_param` or :func:`sprite_param`
    for its own default."""

    blend: str = blend_param("add")
    sprite: str = sprite_param("fireball")
    soft: float = param(0.0, 0.0, 100.0, unit="m",
                        help="soft particles (the ARM chapter's): a sprite fades over this "
                             "distance into the opaque scene behind it; 0: depth-tested")
    buffer_scale: float = param(1.0, 0.05, 1.0,
                                help="draw the sprites into a buffer of this share of the "
                                     "picture's resolution (the chapter's 640x360 under 1080p: "
                                     "0.33), laid over the picture by --upsample")
    scene_depth: str = param("auto", choices=SCENE_DEPTHS,
                             help="where soft sprites read the scene's distance: its depth "
                                  "texture (OES_depth_texture), a packed pre-pass (plain ES "
                                  "2.0), or auto: the texture where the context has it")
    upsample: str = param("bilateral", choices=UPSAMPLES,
                          help="how a smaller sprite buffer comes back over the picture: the "
                               "nearest texel, bilinear, or bilateral (following the scene's "
                               "depth at object edges)")
    size_law: str = param("perspective", choices=SIZE_LAWS,
                          help="how sprite sizes follow the camera: perspective (size over the "
                               "eye distance) or jogl (the seed's: size over the camera's squared "
                               "xz distance to the target, as a fraction of the first camera's)")

    def check(self):
        super().check()
        check_sprite(self.sprite)
        # Options that act only beside another: each given without it is refused in one line
        # (it did nothing).
        declared = self.declarations()
        if self.scene_depth != declared["scene_depth"].default and self.soft == 0:
            raise ParameterError("--scene-depth: only soft sprites read the scene's distance; "
                                 "give --soft D (above 0) with it")
        if self.upsample != declared["upsample"].default and self.buffer_scale == 1:
            raise ParameterError("--upsample: only a sprite buffer smaller than the picture "
                                 "comes back over it; give --buffer-scale below 1 with it")

    def sprite_look(self):
        """The :class:`Sprites` fields these options set."""
        return {"blend": self.blend, "sprite": self.sprite, "soft": self.soft,
                "buffer_scale": self.buffer_scale, "upsample": self.upsample,
                "scene_depth": self.scene_depth}


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
    sort : None, "full" or int
        Draw order: None, the particles' texel order; ``"full"``, back to front, sorted by the
        whole sorting network every frame; k, k merge passes per frame, the order converging
        over frames as the particles move (``render/sort.py``). Order matters for ``over``.
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
    soft: float = 0.0
    buffer_scale: float = 1.0
    upsample: str = "bilateral"
    scene_depth: str = "auto"
    shafts: object = None

    settings = ("point_size", "vertex_fetch")
    has_camera = True
    kind = "it draws 3D sprites: no tone map or accumulation"

    def __post_init__(self):
        if self.blend not in BLENDS:
            raise ParameterError(f"blend must be one of {BLENDS}, got {self.blend!r}")
        check_range("size_spread", self.size_spread, 0.0, 0.99)
        a, b, c = (check_range("attenuation", v, 0.0, 1e6) for v in self.attenuation)
        if a + b + c <= 0:
            raise ParameterError("attenuation (a, b, c) must not be all zero")
        if self.shadow is not None and (a, b) != (0.0, 0.0):
            raise ParameterError(f"shadow needs attenuation (0, 0, c): sprites that shrink as "
                                 f"1 / distance, as their shadows do (got {tuple(self.attenuation)})")
        check_range("opacity", self.opacity, 0.0, 1.0)
        check_range("growth", self.growth, 0.01, 100.0)
        if self.lamp is not None:
            if self.shadow is not None:
                raise ParameterError("one kind of shadow at a time: an opacity shadow map "
                                     "(shadow) or the lamp's light map (lamp)")
            if (a, b) != (0.0, 0.0) or self.size_law != "perspective":
                raise ParameterError("the lamp's shadows need sprites of a world size: "
                                     "attenuation (0, 0, c) and the perspective size law")
        check_range("soft (fade distance)", self.soft, 0.0, 1e3)
        if not 0.0 < float(self.buffer_scale) <= 1.0:
            raise ParameterError(f"buffer scale must be in (0, 1], got {self.buffer_scale!r}")
        check_range("buffer scale", self.buffer_scale, 0.01, 1.0)
        if self.upsample not in UPSAMPLES:
            raise ParameterError(f"upsample must be one of {', '.join(UPSAMPLES)}, got "
                                 f"{self.upsample!r}")
        if self.scene_depth not in SCENE_DEPTHS:
            raise ParameterError(f"scene depth must be one of {', '.join(SCENE_DEPTHS)}, got "
                                 f"{self.scene_depth!r}")
        if self.size_law not in SIZE_LAWS:
            raise ParameterError(f"size law must be one of {', '.join(SIZE_LAWS)}, got "
                                 f"{self.size_law!r}")
        if self.size_law == "jogl":
            if self.shadow is not None:
                raise ParameterError("the jogl size law gives every sprite one size a frame; a "
                                     "shadow needs sprites that shrink as 1 / distance "
                                     "(perspective)")
            if len(self.law_anchor) != 2:
                raise ParameterError(f"law_anchor is the x, z of the point the camera's "
                                     f"distance is taken to, got {self.law_anchor}")
            for v in self.law_anchor:
                check_range("law_anchor", v)
            check_range("law_distance", self.law_distance, 1e-6, 1e6)
        if self.sort is not None and self.sort != "full":
            check_range("sort (merge passes per frame)", self.sort, 1, 10 ** 6, integer=True)
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
        if self.shadow is not None and "fade" not in roles:
            raise ParameterError("shadow needs a fade role: the map's pass reads each "
                                 "particle's life")
        object.__setattr__(self, "roles", roles)

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
        """Add the sort, shadow map, mesh and sprite stages to plan builder ``b``; the image is
        what the frame presents."""
        from .shadow import plan_shadow
        from .sort import plan_sort

        caps, layout, fmt = b.caps, b.layout, b.format
        quantities = self.role_quantities(b.graph_plan)
        lo, hi = caps.drawn_point_size_range
        point_size = setting("point_size", b.setting("point_size"))
        fade = check_range("fade", self.fade, 0.0, hi)
        # ES 2.0 promises no vertex texture units at all; each part of a read quantity, the
        # order, and the shadow map with the sprite (its footprint there) take one. Without
        # them (--vertex-fetch off, or auto on a context with none) the state is read back into
        # vertex attributes each frame, as the points do; the features that read textures in
        # the sprites' vertex shader (or draw the sprites again) need the fetch.
        why = ("--vertex-fetch off" if b.setting("vertex_fetch") == "off"
               else "this context has no vertex texture units")
        fetch = vertex_fetch(b)
        if not fetch:
            needs = [name for name, on in (("the depth sort", self.sort is not None),
                                           ("the shadow map", self.shadow is not None),
                                           ("the lamp", self.lamp is not None),
                                           ("light shafts", self.shafts is not None)) if on]
            if needs:
                raise CapabilityError(f"{why}: {' and '.join(needs)} of this scene's sprites read "
                                      "textures in their vertex shader, which needs vertex "
                                      "texture fetch (switch them off where the scene offers "
                                      "it: --sort off, --shadows off, --shafts off)")
        needed = (sum(q.parts(fmt) for q in quantities.values()) + (self.sort is not None)
                  + 2 * (self.shadow is not None))
        if fetch and needed > caps.max_vertex_texture_units:
            raise CapabilityError(f"the sprites' vertex shader samples {needed} textures; this "
                                  f"context allows {caps.max_vertex_texture_units} "
                                  "(GL_MAX_VERTEX_TEXTURE_IMAGE_UNITS): leave out sorting or "
                                  "shadows, or store the state in a float format (one texture "
                                  "per quantity)")
        size = b.size
        # Sizes are pixels of an image 1024 high and scale with the image, so a small animation
        # shows the same picture as the still.
        pixel_size = point_size * size[1] / 1024
        a, b_, c = (float(v) for v in self.attenuation)
        texture = sprite_image(self.sprite)
        h, w = texture.shape[:2]
        # Not flipped: gl_PointCoord's t = 0 is the top of the point, where the image's first
        # row belongs (meshes' textures are flipped: their v = 0 is the bottom).
        b.resource(Resource("sprite", "image", (w, h), "rgba8", linear=True, data=texture,
                            what="the sprite texture"))
        defines = {} if self.growth == 1 else {"GROWTH": None}
        defines.update({ROLES[role][2]: None for role in self.roles if ROLES[role][2]})
        inputs = {"u_sprite": Ref("sprite")}
        uniforms = {"u_attenuation": (a, b_, c), "u_fade": float(fade),
                    "u_opacity": float(self.opacity),
                    "u_tint": tuple(float(v) for v in self.tint)}
        if self.growth != 1:
            uniforms["u_growth"] = float(self.growth)
        if "heading" in self.roles:  # a screen direction's pixels: x times the aspect
            uniforms["u_aspect"] = float(b.size[0] / b.size[1])
        # A buffer of their own at a lower resolution draws the sprites at its own scale.
        buffered = self.soft > 0 or self.buffer_scale < 1
        drawn_pixels = pixel_size * float(self.buffer_scale)
        frame = {"u_view_projection": ("view_projection",), "u_eye": ("eye",),
                 "u_size": ("sprite_size", drawn_pixels, float(self.size_spread))}
        if self.size_law == "jogl":  # one size a frame, from the camera: no attenuation
            uniforms["u_attenuation"] = (1.0, 0.0, 0.0)
            frame["u_size"] = ("jogl_sprite_size", drawn_pixels, float(self.size_spread),
                               *map(float, self.law_anchor), float(self.law_distance))
        # The light shafts' occluders draw the same sprites in texel order (the multiply blend
        # needs no order), unshadowed.
        occluder = (dict(defines), dict(inputs), dict(uniforms), dict(frame), pixel_size)
        vertices = None
        order = "texel order"
        if self.sort is not None:
            network = plan_sort(b, b.graph_plan.quantities[self.roles["position"]],
                                None if self.sort == "full" else int(self.sort))
            defines.update(network.defines(), SORTED=None)
            inputs["u_order"] = Ref("order")
            vertices = b.vertex_data(Vertices("slots", "texels", layout.count, network.width,
                                              network.height)).name
            order = "back to front"
        else:
            vertices = b.particle_texels()  # each sprite's texel: its hashed size, its state
            b.left_out.append("depth sort (switched off: texel order)")
        if self.shadow is not None:
            per_focal = pixel_size / np.sqrt(c)
            shadow_uniforms, light_focal = plan_shadow(b, self, per_focal)
            defines["SHADOWED"] = None
            inputs.update(u_shadow_map=Ref("shadow map"), u_shadow_sprite=Ref("sprite"))
            uniforms.update(shadow_uniforms)
            frame["u_light_size"] = ("light_size", per_focal, light_focal,
                                     float(self.size_spread), size[1])
        else:
            b.left_out.append("shadow map (switched off)")
        own = {"u_eye": (0.0, 0.0, 1.0), "u_size": (pixel_size, self.size_spread, lo, hi),
               "u_attenuation": (a, b_, c), "u_fade": float(fade)}
        interface = stage_interface(tuple(quantities), quantities, fmt, own,
                                    attributes=not fetch)
        background = tuple(float(v) for v in self.background)
        depth_texture = False
        if buffered:
            if self.scene_depth == "texture" and not caps.depth_texture:
                raise CapabilityError("scene depth 'texture': this context cannot sample a depth "
                                      "buffer (no OES_depth_texture); use packed (or auto)")
            depth_texture = self.meshes and (self.scene_depth == "texture" or (
                self.scene_depth == "auto" and caps.depth_texture))
        b.resource(Resource("image", "target", size, "rgba8",
                            depth="texture" if depth_texture else True, linear=True,
                            what="the picture, with its depth" + (
                                " (a texture the sprites read)" if depth_texture else "")))
        if self.lamp is not None:
            from .lamp import plan_lamp

            per_focal = pixel_size / np.sqrt(c)
            light_focal = self.lamp.camera().focal_pixels(self.lamp.size)
            plan_lamp(b, self, ("light_size", per_focal, light_focal, float(self.size_spread),
                                size[1]))
        else:
            plan_meshes(b, self.meshes, self.light, "image", (*background, 1.0))
        if fetch:
            how = f"vertex texture fetch of {', '.join(self.reads)}"
        else:
            texels = sum(q.parts(fmt) for q in quantities.values())
            how = (f"no vertex texture fetch: {', '.join(self.reads)} read back each frame and "
                   f"uploaded as vertex attributes ({texels} texture read{'s' * (texels > 1)})")
        what = f"{layout.count} point sprites in {order}, {how}"
        if buffered:
            picture = self._plan_buffered(b, defines, interface,
                                          {**self.role_inputs(interface), **inputs},
                                          vertices, uniforms, frame, depth_texture, what)
        else:
            picture = self._plan_direct(b, defines, interface, inputs, vertices, uniforms,
                                        frame, what)
        from .shafts import plan_shafts

        return plan_shafts(b, self.shafts, picture,
                           self.lamp.position if self.lamp is not None else self.light,
                           self.meshes, lambda target, clear: self._plan_occluders(
                               b, interface, occluder, target, clear))

    def _plan_occluders(self, b, interface, occluder, target, clear):
        """The sprites into the light shafts' occluders, at the picture's resolution: each
        multiplies the light passing by one less its opacity (``OCCLUDER``), behind the meshes
        hidden by their depth."""
        defines, inputs, uniforms, frame, pixel_size = occluder
        size = list(frame["u_size"])
        size[1] = pixel_size  # the picture's size, not a smaller sprite buffer's
        b.stage(Stage(
            "shaft occluders: sprites", "shafts", "sprites/sprite.frag", "sprites/sprite.vert",
            {**defines, "OCCLUDER": None}, vertex_interface=interface,
            inputs={**self.role_inputs(interface), **inputs}, target=Ref(target),
            vertices=b.particle_texels(), primitive="points", count=b.layout.count,
            state=DrawState(blend="multiply", depth_test=bool(self.meshes), depth_write=False,
                            point_size=True, sprites=True),
            uniforms=uniforms, generated=generated_values(interface, b.layout),
            frame_uniforms={**frame, "u_size": tuple(size)}, clear=clear,
            what="each lets 1 - its opacity of the light through"))

    def _plan_direct(self, b, defines, interface, inputs, vertices, uniforms, frame, what):
        """The sprites straight into the picture, depth-tested against the meshes."""
        layout, background = b.layout, tuple(float(v) for v in self.background)
        b.stage(Stage(
            "sprites", "sprites", "sprites/sprite.frag", "sprites/sprite.vert", defines,
            vertex_interface=interface, inputs={**self.role_inputs(interface), **inputs},
            attributes=self.role_attributes(interface),
            target=Ref("image"), vertices=vertices, primitive="points", count=layout.count,
            state=DrawState(blend=self.blend, depth_test=True, depth_write=False,
                            point_size=True, sprites=True),
            uniforms=uniforms, generated=generated_values(interface, layout),
            frame_uniforms=frame, clear=None if self.meshes or self.lamp else (*background, 1.0),
            what=what))
        return "image"

    def _plan_buffered(self, b, defines, interface, inputs, vertices, uniforms, frame,
                       depth_texture, what):
        """The sprites into a buffer of their own (soft: fading into the scene behind them; at
        ``buffer_scale`` of the picture's resolution), then laid over the picture by the
        upsample stage into the picture that is presented."""
        size, layout = b.size, b.layout
        scene = {}
        if self.meshes:
            scene = {"SCENE_DEPTH": None, **({"SCENE_DEPTH_TEXTURE": None} if depth_texture
                                            else {})}
            if depth_texture:
                depth = Ref("image", when="depth")
            else:
                depth = Ref("scene depth")
                plan_depth_prepass(b, self.meshes, size)
        w, h = (max(1, int(round(v * self.buffer_scale))) for v in size)
        fmt = "rgba16f" if b.caps.blendable.get("rgba16f") else "rgba8"
        b.resource(Resource("sprite buffer", "target", (w, h), fmt, linear=True,
                            what=f"the sprites alone, premultiplied, at {self.buffer_scale:g} "
                                 f"of the picture's resolution"))
        # With no opaque scene behind them, nothing hides or softens the sprites.
        planes = {"u_planes": ("depth_planes",)} if self.meshes else {}
        depth_input = {"u_scene_depth": depth} if self.meshes else {}
        soft = {"u_soft": max(float(self.soft), 1e-3),
                "u_target_size": (float(w), float(h))} if self.meshes else {}
        b.stage(Stage(
            "sprites", "sprites", "sprites/sprite.frag", "sprites/sprite.vert",
            {**defines, **({"SOFT": None} if self.meshes else {}), **scene},
            vertex_interface=interface, attributes=self.role_attributes(interface),
            inputs={**inputs, **depth_input}, target=Ref("sprite buffer"), vertices=vertices,
            primitive="points", count=layout.count,
            state=DrawState(blend=self.blend, point_size=True, sprites=True),
            uniforms={**uniforms, **soft},
            generated=generated_values(interface, layout), frame_uniforms={**frame, **planes},
            clear=(0.0, 0.0, 0.0, 0.0),
            what=what + (f", fading over {self.soft:g} m into the scene behind"
                         if self.soft > 0 else ", hidden behind the scene")))
        b.resource(Resource("picture", "target", size, "rgba8", linear=True,
                            what="the picture with the sprites laid over it"))
        bilateral = self.upsample == "bilateral" and self.meshes  # it follows the scene's depth
        b.stage(Stage(
            "upsample", "upsample", "sprites/upsample.frag",
            defines={f"UPSAMPLE_{self.upsample.upper()}": None, **(scene if bilateral else {}),
                     **({"ADDITIVE": None} if self.blend == "add" else {})},
            inputs={"u_image": Ref("image"), "u_smoke": Ref("sprite buffer"),
                    **(depth_input if bilateral else {})},
            target=Ref("picture"),
            uniforms={"u_smoke_size": (float(w), float(h)),
                      **({"u_depth_falloff": 0.1} if bilateral else {})},
            frame_uniforms=planes if bilateral else {},
            what=f"{self.upsample} upsampling of the sprites' {w}x{h} buffer over the picture"))
        return "picture"
