"""Drawing particles in 3D: opaque meshes first, then textured billboard sprites over them.

The frame has one colour target (RGBA8) and a depth buffer. Opaque meshes (a checkered floor,
boxes, spheres) are drawn with depth test and depth writes and simple lighting from a point light;
then every particle is one point sprite (``sprites/sprite.vert``): its position and life fetched
from the state textures, its size attenuated with the eye distance and clamped to the driver's
point-size range, a sprite texture over ``gl_PointCoord`` mixed with a tint, alpha falling with
age, blended additively or "over" (premultiplied), depth-tested against the meshes with depth
writes off, so a particle behind the cube is hidden and particles never hide each other.
"""

from dataclasses import dataclass

import moderngl
import numpy as np

from .context import ProgramValues, read_rgb
from .errors import CapabilityError, ParameterError, check_range
from .render import ParticleStage

BLENDS = ("add", "over")


# --- meshes -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Mesh:
    """An opaque mesh in world coordinates: triangles (n, 3, 3) with normals (n, 3, 3), a colour,
    and for a floor a checker of ``colour2`` in cells of ``checker`` units."""

    triangles: np.ndarray
    normals: np.ndarray
    colour: tuple = (0.7, 0.7, 0.7)
    colour2: tuple = None
    checker: float = 0.0
    uvs: np.ndarray = None  # (n, 3, 2) texture coordinates, with ``texture``
    texture: np.ndarray = None  # (h, w, 4) uint8, multiplied into the colour


def floor(half_size=6.0, cell=1.0, colour=(0.32, 0.34, 0.40), colour2=(0.22, 0.23, 0.28)):
    """The floor, the plane y = 0, a checkerboard ``2 half_size`` wide."""
    h = half_size
    corners = np.array([[-h, 0, -h], [h, 0, -h], [h, 0, h], [-h, 0, h]], float)
    triangles = np.stack([corners[[0, 2, 1]], corners[[0, 3, 2]]])
    return Mesh(triangles, np.tile([0.0, 1.0, 0.0], (2, 3, 1)), colour, colour2, cell)


def box(centre, half_size, colour=(0.75, 0.55, 0.35), texture=None):
    """An axis-aligned box, 12 triangles with face normals; with ``texture`` (h, w, 4), each face
    shows the whole texture (the seed's textured cube)."""
    c, h = np.asarray(centre, float), np.asarray(half_size, float)
    triangles, normals, uvs = [], [], []
    corners_uv = [(0, 0), (1, 0), (1, 1), (0, 1)]
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = np.zeros(3)
            n[axis] = sign
            u, v = np.zeros(3), np.zeros(3)
            u[(axis + 1) % 3], v[(axis + 2) % 3] = 1.0, 1.0
            if sign < 0:
                u, v = v, u  # keep the winding outward
            q = [c + h * (n + a * u + b * v) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
            triangles += [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
            normals += [[n] * 3] * 2
            uvs += [[corners_uv[0], corners_uv[1], corners_uv[2]],
                    [corners_uv[0], corners_uv[2], corners_uv[3]]]
    if texture is None:
        return Mesh(np.array(triangles), np.array(normals), colour)
    return Mesh(np.array(triangles), np.array(normals), colour, uvs=np.array(uvs, float),
                texture=np.asarray(texture, np.uint8))


def crate_texture(size=64):
    """A wooden crate face: planks with a dark frame and a diagonal brace, (size, size, 4)."""
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size
    grain = 0.85 + 0.15 * np.sin(40 * y + 6 * np.sin(9 * x))
    planks = np.where((y * 4) % 1 < 0.06, 0.55, 1.0)  # gaps between four planks
    frame = (np.minimum.reduce([x, y, 1 - x, 1 - y]) < 0.1) | (np.abs(x - y) < 0.07)
    shade = np.where(frame, 0.6, planks * grain)
    wood = np.array([0.95, 0.7, 0.42])
    rgba = np.concatenate([shade[..., None] * wood, np.ones((size, size, 1))], -1)
    return (rgba * 255).round().astype(np.uint8)


def sphere(centre, radius, colour=(0.45, 0.55, 0.75), rings=16, segments=32):
    """A latitude-longitude sphere with smooth normals."""
    theta = np.linspace(0, np.pi, rings + 1)
    phi = np.linspace(0, 2 * np.pi, segments + 1)
    grid = np.stack([np.sin(theta)[:, None] * np.cos(phi), np.cos(theta)[:, None] * np.ones_like(phi),
                     np.sin(theta)[:, None] * np.sin(phi)], -1)
    quads = []
    for i in range(rings):
        for j in range(segments):
            a, b, c, d = grid[i, j], grid[i + 1, j], grid[i + 1, j + 1], grid[i, j + 1]
            quads += [[a, b, c], [a, c, d]]
    normals = np.array(quads)
    return Mesh(np.asarray(centre, float) + radius * normals, normals, colour)


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


SPRITES = {"fireball": fireball_texture, "disc": disc_texture}


def load_sprite(spec):
    """A sprite texture (h, w, 4) uint8: ``fireball``, ``disc`` or a PNG path."""
    if spec in SPRITES:
        return SPRITES[spec]()
    from .images import read_image

    return np.asarray(read_image(spec, f"sprite (one of {sorted(SPRITES)} or an image)"),
                      dtype=np.uint8)


# --- the renderer -----------------------------------------------------------------------------

class SpriteRenderer:
    """Opaque meshes, then one point sprite per particle, into an RGBA8 image with depth.

    Parameters
    ----------
    ctx : Context
    quantities : mapping
        What the sprites read: ``position`` (3 components) and ``life`` (age, lifetime).
    layout : Layout
    size : (int, int)
        Image size in pixels.
    state_format : str
    meshes : list of Mesh
    sprite : str
        ``fireball``, ``disc`` or a PNG path.
    point_size : float
        Sprite size in pixels of an image 1024 high (it scales with the image height) at the eye
        distance where the attenuation is 1.
    size_spread : float
        Per-particle sizes vary by +-this fraction (a hash of the texel).
    attenuation : (a, b, c)
        Size factor sqrt(1 / (a + b d + c d^2)) at eye distance d.
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
    """

    READS = ("position", "life")

    def __init__(self, ctx, quantities, layout, size, state_format="rgba8", meshes=(),
                 sprite="fireball", point_size=24.0, size_spread=0.5, attenuation=(0.0, 0.0, 1.0),
                 fade=1.0, blend="add", tint=(1.0, 0.15, 0.05, 0.35), opacity=0.8,
                 light=(3.0, 6.0, 4.0), background=(0.05, 0.06, 0.09)):
        if ctx.caps.max_vertex_texture_units < 1:
            raise CapabilityError("no support for vertex shader textures "
                                  "(GL_MAX_VERTEX_TEXTURE_IMAGE_UNITS is 0): cannot draw particles")
        if set(quantities) != set(self.READS) or quantities["position"].components != 3:
            raise ParameterError(f"the sprite renderer reads position (3 components) and life, got "
                                 f"{ {q: v.components for q, v in quantities.items()} }")
        if blend not in BLENDS:
            raise ParameterError(f"blend must be one of {BLENDS}, got {blend!r}")
        ctx.make_current()
        lo, hi = ctx.caps.point_size_range
        self.point_size = check_range("point_size", point_size, 0.0, 1e4)
        check_range("size_spread", size_spread, 0.0, 0.99)
        a, b, c = (check_range("attenuation", v, 0.0, 1e6) for v in attenuation)
        if a + b + c <= 0:
            raise ParameterError("attenuation (a, b, c) must not be all zero")
        check_range("fade", fade, 0.0, hi)
        self.ctx, self.layout, self.size, self.blend = ctx, layout, tuple(size), blend
        self.reads = tuple(self.READS)
        self.point_size_range = (lo, hi)
        self.background = tuple(float(v) for v in background)
        # Sizes are pixels of an image 1024 high and scale with the image, so a small animation
        # shows the same picture as the still.
        self.pixel_size = self.point_size * size[1] / 1024
        uniforms = {"u_eye": (0.0, 0.0, 1.0), "u_size": (self.pixel_size, size_spread, lo, hi),
                    "u_attenuation": (a, b, c), "u_fade": float(fade)}
        opacity = float(check_range("opacity", opacity, 0.0, 1.0))
        texture = load_sprite(sprite)
        self.group = ctx.group()
        try:
            self.stage = ParticleStage(self.group, "sprites/sprite.vert", "sprites/sprite.frag",
                                       "the sprite renderer", quantities, state_format, layout,
                                       uniforms)
            self.sprite_unit = len(self.stage.units)
            self.stage.set_many({"u_sprite": self.sprite_unit, "u_opacity": opacity,
                                 "u_tint": tuple(float(v) for v in tint)})
            h, w = texture.shape[:2]
            # Not flipped: gl_PointCoord's t = 0 is the top of the point, where the image's
            # first row belongs (meshes' textures are flipped: their v = 0 is the bottom).
            self.sprite = self.group.texture((w, h), "rgba8", data=texture.tobytes(),
                                             filter_nearest=False)
            self.image = self.group.texture(self.size, "rgba8", filter_nearest=False)
            self.framebuffer = self.group.framebuffer(self.image, self.group.depth(self.size))
            self.meshes = [self._mesh(m, light) for m in meshes]
        except Exception:
            self.group.release()
            raise

    def _mesh(self, mesh, light):
        defines = {"CHECKER": None} if mesh.colour2 is not None else {}
        columns = [mesh.triangles.reshape(-1, 3), mesh.normals.reshape(-1, 3)]
        layout, names = "3f 3f", ["a_position", "a_normal"]
        if mesh.texture is not None:
            defines["TEXTURED"] = None
            columns.append(mesh.uvs.reshape(-1, 2))
            layout, names = layout + " 2f", names + ["a_uv"]
        program = self.ctx.program("sprites/mesh.vert", "sprites/mesh.frag", defines)
        buffer = self.group.buffer(np.concatenate(columns, 1).astype("f4").tobytes())
        vao = self.group.vertex_array(program, [(buffer, layout, *names)])
        texture = None
        state = ProgramValues(self.ctx, program)  # meshes of one kind share a program
        if mesh.texture is not None:
            h, w = mesh.texture.shape[:2]
            texture = self.group.texture((w, h), "rgba8", data=mesh.texture[::-1].tobytes(),
                                         filter_nearest=False)
            state.set("u_texture", 0)
        state.set("u_light", tuple(float(v) for v in light))
        state.set("u_colour", tuple(float(v) for v in mesh.colour))
        if mesh.colour2 is not None:
            state.set("u_colour2", tuple(float(v) for v in mesh.colour2))
            state.set("u_checker", float(mesh.checker))
        return state, vao, texture

    def describe(self):
        w, h = self.size
        return (f"render: opaque meshes ({len(self.meshes)}, depth test and writes), then "
                f"{self.layout.count} point sprites ({self.blend} blend, depth test without "
                f"writes), vertex texture fetch of {' and '.join(self.reads)} -> rgba8 {w}x{h} "
                f"with depth")

    def draw(self, buffers, camera):
        """Draw the meshes and the particles seen from ``camera``; returns the colour texture."""
        self.ctx.make_current()
        aspect = self.size[0] / self.size[1]
        view_projection = camera.uniform(aspect)
        with self.ctx.scope(self.framebuffer, depth_test=True):
            self.framebuffer.clear(*self.background, 1.0, depth=1.0)
            for state, vao, texture in self.meshes:
                if texture is not None:
                    texture.use(0)
                state.set("u_view_projection", view_projection)
                vao.render(moderngl.TRIANGLES)
        self.stage.bind(buffers)
        self.sprite.use(self.sprite_unit)
        self.stage.set_many({"u_view_projection": view_projection,
                             "u_eye": tuple(float(v) for v in camera.eye)})
        with self.ctx.scope(self.framebuffer, blend=self.blend, point_size=True, depth_test=True,
                            depth_write=False, sprites=True):
            self.stage.vao.render(moderngl.POINTS)
        return self.image

    def read(self, texture=None):
        """The image as (h, w, 3) uint8, top row first."""
        self.ctx.make_current()
        return read_rgb(self.image)

    def release(self):
        self.group.release()
