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

from ..gl.context import ProgramValues, read_rgb
from ..errors import CapabilityError, ParameterError, check_range
from .points import ParticleStage

BLENDS = ("add", "over")


# --- meshes -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Mesh:
    """An opaque mesh: triangles (n, 3, 3) wound counter-clockwise seen from outside, with normals
    (n, 3, 3), a colour, and for a floor a checker of ``colour2`` in cells of ``checker`` units.
    In world coordinates, unless ``moves``: then in object coordinates, placed by the model matrix
    given to :meth:`SpriteRenderer.draw` each frame (a spinning or swaying obstacle)."""

    triangles: np.ndarray
    normals: np.ndarray
    colour: tuple = (0.7, 0.7, 0.7)
    colour2: tuple = None
    checker: float = 0.0
    uvs: np.ndarray = None  # (n, 3, 2) texture coordinates, with ``texture``
    texture: np.ndarray = None  # (h, w, 4) uint8, multiplied into the colour
    moves: bool = False


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


def _grid(points, normals, colour):
    """The mesh of a (rows + 1, cols + 1, 3) grid of points and their normals, two triangles per
    cell; the outward side is the one cross(along a row, down a column) points to."""
    def cells(g):
        a, b, c, d = g[:-1, :-1], g[:-1, 1:], g[1:, 1:], g[1:, :-1]
        return np.stack([np.stack([a, b, c], -2), np.stack([a, c, d], -2)], 2).reshape(-1, 3, 3)

    return Mesh(cells(points), cells(normals), colour)


def _directions(theta, phi):
    """Unit vectors at polar angles ``theta`` from +y and azimuths ``phi`` from +x towards +z, as
    a (len(theta), len(phi), 3) grid wound outward by :func:`_grid`."""
    s = np.sin(theta)[:, None]
    return np.stack([s * np.cos(phi), np.cos(theta)[:, None] * np.ones_like(phi),
                     s * np.sin(phi)], -1)


def _rotation(axis, name):
    """A rotation taking +y to the unit vector along ``axis`` (the identity for +y), so a shape
    built around y can be turned to any orientation."""
    w = np.asarray(axis, float)
    if w.shape != (3,) or not np.all(np.isfinite(w)) or not np.linalg.norm(w) > 0:
        raise ParameterError(f"{name} must be a finite nonzero 3-vector, got {axis!r}")
    w = w / np.linalg.norm(w)
    helper = np.eye(3)[0] if abs(w[0]) < 0.9 else np.eye(3)[2]
    u = helper - helper.dot(w) * w
    u /= np.linalg.norm(u)
    return np.stack([u, w, np.cross(u, w)], 1)  # columns: where x, y, z go


def _point(value, name):
    v = np.asarray(value, float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ParameterError(f"{name} must be three finite numbers, got {value!r}")
    return v


def _divisions(name, value, lo):
    return int(check_range(name, value, lo, 4096, integer=True))


def sphere(centre, radius, colour=(0.45, 0.55, 0.75), rings=16, segments=32):
    """A latitude-longitude sphere with smooth normals."""
    normals = _directions(np.linspace(0, np.pi, rings + 1), np.linspace(0, 2 * np.pi, segments + 1))
    return _grid(np.asarray(centre, float) + radius * normals, normals, colour)


def capsule(a, b, radius, colour=(0.45, 0.55, 0.75), rings=8, segments=32):
    """A closed capsule, the points within ``radius`` of the segment ``a``-``b``: a cylinder and
    two hemispheres of ``rings`` rings each, with smooth normals (the collision scene's pill).

    Built around y (the hemisphere about ``b`` first, then the one about ``a``; the cylinder is
    the band between them) and turned onto ``b - a``; ``a == b`` gives a sphere.
    """
    a, b = _point(a, "capsule a"), _point(b, "capsule b")
    radius = check_range("capsule radius", radius, 1e-9)
    rings, segments = _divisions("capsule rings", rings, 1), _divisions("capsule segments",
                                                                          segments, 3)
    axis = b - a if np.any(b != a) else (0.0, 1.0, 0.0)
    half = np.linspace(0, np.pi / 2, rings + 1)
    local = _directions(np.concatenate([half, half + np.pi / 2]),
                        np.linspace(0, 2 * np.pi, segments + 1))
    normals = local @ _rotation(axis, "capsule b - a").T
    ends = np.where(np.arange(2 * rings + 2)[:, None, None] <= rings, b, a)
    return _grid(ends + radius * normals, normals, colour)


def torus(centre, major, minor, axis=(0.0, 1.0, 0.0), colour=(0.45, 0.55, 0.75), rings=48,
          segments=16):
    """A torus around ``axis`` through ``centre``: a tube of radius ``minor`` about a circle of
    radius ``major``, ``rings`` steps around the axis and ``segments`` around the tube, with
    smooth normals."""
    centre = _point(centre, "torus centre")
    major = check_range("torus major radius", major, 1e-9)
    minor = check_range("torus minor radius", minor, 1e-9, major)
    rings, segments = _divisions("torus rings", rings, 3), _divisions("torus segments", segments, 3)
    phi = np.linspace(0, 2 * np.pi, rings + 1)[:, None]  # around the axis: the grid's rows
    beta = np.linspace(0, 2 * np.pi, segments + 1)  # around the tube, outward first: its columns
    radial = np.stack([np.cos(phi), np.zeros_like(phi), np.sin(phi)], -1)  # (rings + 1, 1, 3)
    local = np.cos(beta)[:, None] * radial + np.sin(beta)[:, None] * np.array([0.0, 1.0, 0.0])
    rotation = _rotation(axis, "torus axis")
    normals = local @ rotation.T
    return _grid(centre + (major * radial) @ rotation.T + minor * normals, normals, colour)


def from_triangles(vertices, faces, colour=(0.6, 0.6, 0.6)):
    """A mesh of an indexed triangle mesh (what trimesh makes of an OBJ, STL or PLY file):
    ``vertices`` (n, 3), ``faces`` (m, 3) vertex indices wound counter-clockwise from outside.

    Each vertex's normal is the average of its faces' normals weighted by their areas, so one
    sliver does not tilt it; where that average vanishes (a vertex shared by the two sides of a
    sheet), each corner keeps its face's normal.
    """
    v = np.asarray(vertices, float)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3 or not len(v) or not np.all(np.isfinite(v)):
        raise ParameterError(f"vertices must be a non-empty (n, 3) array of finite numbers, got "
                             f"shape {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3 or not len(f) or f.dtype.kind not in "iu":
        raise ParameterError(f"faces must be a non-empty (m, 3) array of integers, got shape "
                             f"{f.shape} of {f.dtype}")
    if f.min() < 0 or f.max() >= len(v):
        raise ParameterError(f"faces must index vertices in [0, {len(v) - 1}], got "
                             f"[{f.min()}, {f.max()}]")
    triangles = v[f]
    weighted = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    area = np.linalg.norm(weighted, axis=1, keepdims=True)  # twice the area
    face = np.divide(weighted, area, out=np.zeros_like(weighted), where=area > 0)
    total, scale = np.zeros_like(v), np.zeros(len(v))
    for k in range(3):
        np.add.at(total, f[:, k], weighted)
        np.add.at(scale, f[:, k], area[:, 0])
    length = np.linalg.norm(total, axis=1)
    smooth = length > 1e-9 * scale  # else the faces about the vertex cancel
    vertex = np.divide(total, length[:, None], out=np.zeros_like(total), where=smooth[:, None])
    normals = np.where(smooth[f][..., None], vertex[f], face[:, None, :])
    return Mesh(triangles, normals, colour)


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


SPRITES = {"fireball": fireball_texture, "disc": disc_texture, "smoke": smoke_texture}


def load_sprite(spec):
    """A sprite texture (h, w, 4) uint8: ``fireball``, ``disc``, ``smoke`` or a PNG path."""
    if spec in SPRITES:
        return SPRITES[spec]()
    from ..io.images import read_image

    return np.asarray(read_image(spec, f"sprite (one of {sorted(SPRITES)} or an image)"),
                      dtype=np.uint8)


# --- the renderer -----------------------------------------------------------------------------

IDENTITY = tuple(float(v) for v in np.eye(4).ravel())


def model_uniform(model):
    """A model matrix (4x4 numpy, column vectors: world = model @ [x, y, z, 1]) as the 16 floats
    of a GLSL mat4, column-major like ``Camera.uniform``. Only rotation, uniform scale and
    translation: the mesh shader turns normals by the same matrix, right only for those."""
    try:
        m = np.asarray(model, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"model must be a 4x4 matrix, got {model!r}") from None
    if m.shape != (4, 4) or not np.all(np.isfinite(m)):
        raise ParameterError(f"model must be a finite 4x4 matrix, got shape {m.shape}")
    gram = m[:3, :3].T @ m[:3, :3]
    scale = np.trace(gram) / 3  # the squared scale
    if not (scale > 0 and np.allclose(gram, scale * np.eye(3), rtol=0, atol=1e-6 * scale)
            and np.array_equal(m[3], [0, 0, 0, 1])):
        raise ParameterError("model must be a rotation, a uniform scale and a translation "
                             "(last row 0 0 0 1): normals are turned by the same matrix")
    return tuple(float(v) for v in m.T.ravel())


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
        ``fireball``, ``disc``, ``smoke`` or a PNG path.
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
    sort : None, "full" or int
        Draw order: None, the particles' texel order; ``"full"``, back to front, sorted by the
        whole sorting network every frame; k, k merge passes per frame, the order converging
        over frames as the particles move (``sort.DepthSorter``). Order matters for ``over``.
    growth : float
        A sprite's size at the end of its life, relative to its birth (smoke puffs spread).
    shadow : shadow.OpacityShadow or None
        Self-shadowing by an opacity shadow map seen from its light; needs attenuation
        (0, 0, c), so that a sprite has one world size, and a perspective camera.
    """

    READS = ("position", "life")

    def __init__(self, ctx, quantities, layout, size, state_format="rgba8", meshes=(),
                 sprite="fireball", point_size=24.0, size_spread=0.5, attenuation=(0.0, 0.0, 1.0),
                 fade=1.0, blend="add", tint=(1.0, 0.15, 0.05, 0.35), opacity=0.8,
                 light=(3.0, 6.0, 4.0), background=(0.05, 0.06, 0.09), sort=None, shadow=None,
                 growth=1.0):
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
        if shadow is not None and (a, b) != (0.0, 0.0):
            raise ParameterError(f"shadow needs attenuation (0, 0, c): sprites that shrink as "
                                 f"1 / distance, as their shadows do (got {tuple(attenuation)})")
        self.attenuation = (a, b, c)
        growth = float(check_range("growth", growth, 0.01, 100.0))
        texture = load_sprite(sprite)
        if sort is not None and sort != "full":
            sort = int(check_range("sort (merge passes per frame)", sort, 1, 10 ** 6,
                                   integer=True))
        # ES 2.0 promises no vertex texture units at all; each part of a read quantity, the
        # order, and the shadow map with the sprite (its footprint there) take one.
        needed = sum(q.parts(state_format) for q in quantities.values()) + (sort is not None) \
            + 2 * (shadow is not None)
        if needed > ctx.caps.max_vertex_texture_units:
            raise CapabilityError(f"the sprites' vertex shader samples {needed} textures; this "
                                  f"context allows {ctx.caps.max_vertex_texture_units} "
                                  "(GL_MAX_VERTEX_TEXTURE_IMAGE_UNITS): leave out sorting or "
                                  "shadows, or store the state in a float format (one texture "
                                  "per quantity)")
        self.sorter = self.shadow = None
        self.group = ctx.group()
        try:
            h, w = texture.shape[:2]
            # Not flipped: gl_PointCoord's t = 0 is the top of the point, where the image's
            # first row belongs (meshes' textures are flipped: their v = 0 is the bottom).
            self.sprite = self.group.texture((w, h), "rgba8", data=texture.tobytes(),
                                             filter_nearest=False)
            defines, texels = ({} if growth == 1 else {"GROWTH": None}), None
            if sort is not None:
                from .sort import DepthSorter

                self.sorter = DepthSorter(ctx, quantities["position"], layout, state_format,
                                          passes_per_frame=None if sort == "full" else sort)
                defines.update(self.sorter.defines(), SORTED=None)
                texels = self.sorter.slot_uv()
            if shadow is not None:
                from .shadow import ShadowMap

                self.shadow = ShadowMap(ctx, shadow, quantities, layout, state_format,
                                        self.sprite, opacity, size_spread, (lo, hi), growth)
                defines["SHADOWED"] = None
            self.stage = ParticleStage(self.group, "sprites/sprite.vert", "sprites/sprite.frag",
                                       "the sprite renderer", quantities, state_format, layout,
                                       uniforms, defines, texels)
            units = len(self.stage.units)
            self.sprite_unit, self.order_unit, self.shadow_unit = units, units + 1, units + 2
            self.stage.set_many({"u_sprite": self.sprite_unit, "u_opacity": opacity,
                                 "u_tint": tuple(float(v) for v in tint)})
            if growth != 1:
                self.stage.set_many({"u_growth": growth})
            if self.sorter is not None:
                self.stage.set_many({"u_order": self.order_unit})
            if self.shadow is not None:
                self.stage.set_many({"u_shadow_map": self.shadow_unit,
                                     "u_shadow_sprite": self.sprite_unit,
                                     **self.shadow.uniforms()})
            self.image = self.group.texture(self.size, "rgba8", filter_nearest=False)
            self.framebuffer = self.group.framebuffer(self.image, self.group.depth(self.size))
            self.meshes = [self._mesh(m, light) for m in meshes]
        except Exception:
            self.release()
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
        return state, vao, texture, mesh.moves

    def describe(self):
        w, h = self.size
        order = "texel order" if self.sorter is None else "back to front"
        line = (f"render: opaque meshes ({len(self.meshes)}, depth test and writes), then "
                f"{self.layout.count} point sprites in {order} ({self.blend} blend, depth test "
                f"without writes), vertex texture fetch of {' and '.join(self.reads)} -> rgba8 "
                f"{w}x{h} with depth")
        before = [self.sorter.describe()] if self.sorter is not None else []
        if self.shadow is not None:
            before.append(self.shadow.describe())
        return "\n  ".join(before + [line])

    def world_size(self, camera):
        """A sprite's diameter in world units (before the per-particle spread) for ``camera``:
        its pixel size at eye distance d is pixel_size / (sqrt(c) d) by the attenuation."""
        if camera.ortho is not None:
            raise ParameterError("shadows need a perspective camera (a sprite's world size)")
        return self.pixel_size / np.sqrt(self.attenuation[2]) / camera.focal_pixels(self.size[1])

    def draw(self, buffers, camera, model=None):
        """Draw the meshes and the particles seen from ``camera``; returns the colour texture.

        ``model`` (4x4, object to world for column vectors: rotation, uniform scale, translation)
        places this frame's moving meshes (``Mesh.moves``); the others stay in world coordinates.
        """
        moved = IDENTITY if model is None else model_uniform(model)
        self.ctx.make_current()
        aspect = self.size[0] / self.size[1]
        view_projection = camera.uniform(aspect)
        with self.ctx.scope(self.framebuffer, depth_test=True):
            self.framebuffer.clear(*self.background, 1.0, depth=1.0)
            for state, vao, texture, moves in self.meshes:
                if texture is not None:
                    texture.use(0)
                state.set("u_view_projection", view_projection)
                state.set("u_model", moved if moves else IDENTITY)
                vao.render(moderngl.TRIANGLES)
        if self.sorter is not None:
            self.sorter.update(buffers, camera)
        if self.shadow is not None:
            world_size = self.world_size(camera)
            self.shadow.draw(buffers, world_size)
            self.stage.set_many(self.shadow.sizes(world_size))
        self.stage.bind(buffers)
        self.sprite.use(self.sprite_unit)
        if self.sorter is not None:
            self.sorter.texture.use(self.order_unit)
        if self.shadow is not None:
            self.shadow.map.use(self.shadow_unit)
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
        for part in (self.sorter, self.shadow, self.group):
            if part is not None:
                part.release()
