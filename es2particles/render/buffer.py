"""Soft particles and a sprite buffer: two features a
:class:`~es2particles.render.sprites.Sprites` rendering takes, each declared on its own with its
own options. Soft particles are the ARM chapter's: a sprite fades as it nears the opaque scene
behind it. The buffer draws the sprites at a lower resolution than the picture (the chapter's
640x360 under 1080p).

Either draws the sprites into a buffer of their own (premultiplied, RGBA16F where the context
blends into it), laid back over the picture by ``sprites/upsample.frag``: the nearest texel,
bilinear, or bilateral (following the scene's depth at object edges). Soft sprites read the
scene's distance from the picture's depth texture (OES_depth_texture) or, on plain ES 2.0, from
a pre-pass that packs it into RGBA8 (``lib/depth.glsl``).
"""

from dataclasses import dataclass

from ..errors import CapabilityError, ParameterError, check_range
from ..frame.plan import Ref, Resource, Stage
from ..gl.bindings import generated_values
from ..gl.device import DrawState
from ..params import Params, param
from .meshes import plan_mesh_passes

UPSAMPLES = ("nearest", "bilinear", "bilateral")
SCENE_DEPTHS = ("auto", "texture", "packed")


@dataclass(frozen=True)
class SoftParticles:
    """Sprites that fade over ``distance`` (world units) into the opaque scene behind them,
    reading its distance from ``scene_depth``: ``texture`` (the picture's depth texture),
    ``packed`` (a pre-pass), or ``auto`` (the texture where the context has it)."""

    distance: float
    scene_depth: str = "auto"

    def __post_init__(self):
        check_range("soft (fade distance)", self.distance, 0.0, 1e3)
        if self.scene_depth not in SCENE_DEPTHS:
            raise ParameterError(f"scene depth must be one of {', '.join(SCENE_DEPTHS)}, got "
                                 f"{self.scene_depth!r}")



@dataclass(frozen=True)
class SpriteBuffer:
    """The sprites drawn into a buffer of ``scale`` of the picture's resolution and laid over
    it by ``upsample`` (``nearest``, ``bilinear`` or ``bilateral``)."""

    scale: float = 1.0
    upsample: str = "bilateral"

    def __post_init__(self):
        if not 0.0 < float(self.scale) <= 1.0:
            raise ParameterError(f"buffer scale must be in (0, 1], got {self.scale!r}")
        check_range("buffer scale", self.scale, 0.01, 1.0)
        if self.upsample not in UPSAMPLES:
            raise ParameterError(f"upsample must be one of {', '.join(UPSAMPLES)}, got "
                                 f"{self.upsample!r}")


# --- the options that declare them ------------------------------------------------------------

@dataclass(frozen=True)
class SoftParams(Params):
    """The soft particles' options (a base of :class:`~es2particles.render.sprites.SpriteLook`)."""

    soft: float = param(0.0, 0.0, 100.0, unit="m",
                        help="soft particles (the ARM chapter's): a sprite fades over this "
                             "distance into the opaque scene behind it; 0: depth-tested")
    scene_depth: str = param("auto", choices=SCENE_DEPTHS,
                             help="where soft sprites read the scene's distance: its depth "
                                  "texture (OES_depth_texture), a packed pre-pass (plain ES "
                                  "2.0), or auto: the texture where the context has it")

    def check(self):
        super().check()
        if self.scene_depth != self.declarations()["scene_depth"].default and self.soft == 0:
            raise ParameterError("--scene-depth: only soft sprites read the scene's distance; "
                                 "give --soft D (above 0) with it")

    def soft_particles(self):
        """The :class:`SoftParticles` these options ask for, or None."""
        return SoftParticles(self.soft, self.scene_depth) if self.soft > 0 else None


@dataclass(frozen=True)
class BufferParams(Params):
    """The sprite buffer's options (a base of :class:`~es2particles.render.sprites.SpriteLook`)."""

    buffer_scale: float = param(1.0, 0.05, 1.0,
                                help="draw the sprites into a buffer of this share of the "
                                     "picture's resolution (the chapter's 640x360 under 1080p: "
                                     "0.33), laid over the picture by --upsample")
    upsample: str = param("bilateral", choices=UPSAMPLES,
                          help="how a smaller sprite buffer comes back over the picture: the "
                               "nearest texel, bilinear, or bilateral (following the scene's "
                               "depth at object edges)")

    def check(self):
        super().check()
        if self.upsample != self.declarations()["upsample"].default and self.buffer_scale == 1:
            raise ParameterError("--upsample: only a sprite buffer smaller than the picture "
                                 "comes back over it; give --buffer-scale below 1 with it")

    def sprite_buffer(self):
        """The :class:`SpriteBuffer` these options ask for, or None."""
        return SpriteBuffer(self.buffer_scale, self.upsample) if self.buffer_scale < 1 else None


# --- planning --------------------------------------------------------------------------------

def scene_depth_texture(caps, meshes, scene_depth):
    """Whether sprites in a buffer read the scene's distance from the picture's depth texture
    (else from the packed pre-pass, or nothing where there are no ``meshes``), by
    ``scene_depth`` (one of :data:`SCENE_DEPTHS`) on a context of ``caps``."""
    if scene_depth == "texture" and not caps.depth_texture:
        raise CapabilityError("scene depth 'texture': this context cannot sample a depth "
                              "buffer (no OES_depth_texture); use packed (or auto)")
    return bool(meshes) and (scene_depth == "texture" or (
        scene_depth == "auto" and caps.depth_texture))


def plan_depth_prepass(b, meshes, size):
    """The opaque scene's distance packed into an RGBA8 target (for a context that cannot
    sample a depth buffer): each mesh drawn again with ``sprites/depth.frag``."""
    b.resource(Resource("scene depth", "target", size, "rgba8", depth=True,
                        what="the opaque scene's distance, packed in 16 bits (no depth "
                             "textures to sample)"))
    far = (254 / 255, 254 / 255, 0.0, 1.0)  # pack16(1): the far plane
    plan_mesh_passes(b, meshes, "depth", "depth", "sprites/depth.frag", "scene depth", far,
                     "its distance, packed", {"u_planes": ("depth_planes",)})


def plan_buffered(b, sprites, draw, buffer, soft, depth_texture):
    """The sprites' ``draw`` (a :class:`~es2particles.render.sprites.SpriteDraw`) into a buffer
    of their own (``buffer``'s scale of the picture; ``soft``: fading into the scene behind
    them, its distance from the depth texture if ``depth_texture``, else from the packed
    pre-pass), then laid over the picture by the upsample stage into the presented picture,
    whose name it returns."""
    size, layout, meshes = b.size, b.layout, sprites.meshes
    scene = {}
    if meshes:
        scene = {"SCENE_DEPTH": None, **({"SCENE_DEPTH_TEXTURE": None} if depth_texture
                                        else {})}
        if depth_texture:
            depth = Ref("image", when="depth")
        else:
            depth = Ref("scene depth")
            plan_depth_prepass(b, meshes, size)
    w, h = (max(1, int(round(v * buffer.scale))) for v in size)
    fmt = "rgba16f" if b.caps.blendable.get("rgba16f") else "rgba8"
    b.resource(Resource("sprite buffer", "target", (w, h), fmt, linear=True,
                        what=f"the sprites alone, premultiplied, at {buffer.scale:g} "
                             f"of the picture's resolution"))
    # With no opaque scene behind them, nothing hides or softens the sprites.
    distance = soft.distance if soft is not None else 0.0
    planes = {"u_planes": ("depth_planes",)} if meshes else {}
    depth_input = {"u_scene_depth": depth} if meshes else {}
    fade = {"u_soft": max(float(distance), 1e-3),
            "u_target_size": (float(w), float(h))} if meshes else {}
    b.stage(Stage(
        "sprites", "sprites", "sprites/sprite.frag", "sprites/sprite.vert",
        {**draw.defines, **({"SOFT": None} if meshes else {}), **scene},
        vertex_interface=draw.interface, attributes=sprites.role_attributes(draw.interface),
        inputs={**sprites.role_inputs(draw.interface), **draw.inputs, **depth_input},
        target=Ref("sprite buffer"), vertices=draw.vertices, primitive="points",
        count=layout.count, state=DrawState(blend=sprites.blend, point_size=True, sprites=True),
        uniforms={**draw.uniforms, **fade},
        generated=generated_values(draw.interface, layout),
        frame_uniforms={**draw.frame, **planes}, clear=(0.0, 0.0, 0.0, 0.0),
        what=draw.what + (f", fading over {distance:g} m into the scene behind"
                          if distance > 0 else ", hidden behind the scene")))
    b.resource(Resource("picture", "target", size, "rgba8", linear=True,
                        what="the picture with the sprites laid over it"))
    bilateral = buffer.upsample == "bilateral" and meshes  # it follows the scene's depth
    b.stage(Stage(
        "upsample", "upsample", "sprites/upsample.frag",
        defines={f"UPSAMPLE_{buffer.upsample.upper()}": None, **(scene if bilateral else {}),
                 **({"ADDITIVE": None} if sprites.blend == "add" else {})},
        inputs={"u_image": Ref("image"), "u_smoke": Ref("sprite buffer"),
                **(depth_input if bilateral else {})},
        target=Ref("picture"),
        uniforms={"u_smoke_size": (float(w), float(h)),
                  **({"u_depth_falloff": 0.1} if bilateral else {})},
        frame_uniforms=planes if bilateral else {},
        what=f"{buffer.upsample} upsampling of the sprites' {w}x{h} buffer over the picture"))
    return "picture"
