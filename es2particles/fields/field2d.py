"""The collision field: signed distance and surface normal over the scene rectangle, in a texture.

Built once, in numpy, from analytic shapes (circle, box, capsule, their union) or from a PNG mask
(a silhouette). The walls and floor (the scene rectangle's edges) are exact planes in the shader,
not cells of the texture: a corner cell would hold one wall's normal and hide the other. Negative distance is inside an
object. The texture holds, per cell, the distance as 16-bit packed fixed point (RG, over
[-max_distance, max_distance]) and the unit normal as two 8-bit channels (BA, 127 n + 127: 0 and +-1 exact).

The normal is stored, not derived from the distance gradient in the shader: one NEAREST fetch then
gives a particle both (the chapter's single texture access), where a gradient would take four more
fetches per sub-step and is undefined on the medial axis and in corners. Analytic shapes give exact
normals; a mask's come from the gradient of its distance transform, computed once here.

``sample`` is the numpy twin of ``field_sample`` in ``shaders/glsl100/lib/particle.glsl``.
"""

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..twins import pack as packing
from ..gl.context import FORMAT_DTYPES, bytes_per_texel
from ..errors import ParameterError, check_range


# --- shapes: signed distance and its gradient, float64 ----------------------------------------

@dataclass(frozen=True)
class Circle:
    centre: tuple
    radius: float

    def sdf(self, p):
        q = p - np.asarray(self.centre, float)
        r = np.hypot(q[..., 0], q[..., 1])
        return r - self.radius, _unit(q, fallback=(0.0, 1.0))

    def bounds(self):
        c = np.asarray(self.centre, float)
        return c - self.radius, c + self.radius


@dataclass(frozen=True)
class Box:
    centre: tuple
    half_size: tuple

    def sdf(self, p):
        q = p - np.asarray(self.centre, float)
        h = np.asarray(self.half_size, float)
        d = np.abs(q) - h
        outside = np.maximum(d, 0)
        out_len = np.hypot(outside[..., 0], outside[..., 1])
        inside = np.minimum(np.maximum(d[..., 0], d[..., 1]), 0)
        dist = out_len + inside
        sign = np.where(q >= 0, 1.0, -1.0)
        # Outside: along the offset from the box; inside: along the axis of the nearest face.
        grad_out = _unit(outside * sign, fallback=(0.0, 1.0))
        x_face = d[..., 0] > d[..., 1]
        grad_in = np.stack([np.where(x_face, sign[..., 0], 0.0), np.where(x_face, 0.0, sign[..., 1])], -1)
        grad = np.where((out_len > 0)[..., None], grad_out, grad_in)
        return dist, grad

    def bounds(self):
        c, h = np.asarray(self.centre, float), np.asarray(self.half_size, float)
        return c - h, c + h


@dataclass(frozen=True)
class Capsule:
    a: tuple
    b: tuple
    radius: float

    def sdf(self, p):
        a, b = np.asarray(self.a, float), np.asarray(self.b, float)
        ab = b - a
        t = np.clip(((p - a) @ ab) / max(ab @ ab, 1e-300), 0, 1)
        q = p - (a + t[..., None] * ab)
        # On the centre segment q is 0 and the normal undefined: take the segment's perpendicular
        # (either side is right for half the particles; collide() in lib/particle.glsl turns it
        # round for a particle that came from the other side).
        across = _unit(np.array([-ab[1], ab[0]]), fallback=(0.0, 1.0))
        return np.hypot(q[..., 0], q[..., 1]) - self.radius, _unit(q, fallback=across)

    def bounds(self):
        a, b = np.asarray(self.a, float), np.asarray(self.b, float)
        return np.minimum(a, b) - self.radius, np.maximum(a, b) + self.radius


def _unit(v, fallback):
    n = np.hypot(v[..., 0], v[..., 1])[..., None]
    safe = np.where(n > 1e-12, v / np.where(n > 1e-12, n, 1), np.asarray(fallback, float))
    return safe


def union(distances_and_normals):
    """Union of shapes: the smallest distance, with the normal of the shape that gives it."""
    dist, normal = distances_and_normals[0]
    for d, n in distances_and_normals[1:]:
        closer = d < dist
        dist = np.where(closer, d, dist)
        normal = np.where(closer[..., None], n, normal)
    return dist, normal


def walls(p, rect):
    """Signed distance to the inside of the rectangle's walls and floor (solid outside it).
    Only the float64 checks use it: the shader tests the walls as planes."""
    x0, y0, x1, y1 = rect
    faces = np.stack([p[..., 0] - x0, x1 - p[..., 0], p[..., 1] - y0, y1 - p[..., 1]], -1)
    normals = np.array([[1, 0], [-1, 0], [0, 1], [0, -1]], float)
    nearest = np.argmin(faces, axis=-1)
    return np.take_along_axis(faces, nearest[..., None], -1)[..., 0], normals[nearest]


# --- masks: a distance transform by jump flooding, in numpy -----------------------------------

def load_mask(path, resolution, option="--shape"):
    """Boolean (h, w) solid mask from an image: alpha >= 50% where there is alpha, else dark
    (luminance < 50%) pixels are solid. Row 0 is the bottom of the scene.

    Pixels are classed at the image's own resolution, then a cell is solid if any pixel in it is
    (an area average above zero): a line one pixel wide survives at any field resolution, where
    nearest-pixel resampling kept it in one cell of every four (or none at all)."""
    from PIL import Image

    from ..io.images import read_image

    image = read_image(path, f"{option} (a mask)", mode=None)
    if "A" in image.getbands():
        pixels = np.asarray(image.getchannel("A"), dtype=np.float64) / 255 >= 0.5
    else:
        pixels = np.asarray(image.convert("L"), dtype=np.float64) / 255 < 0.5
    coverage = Image.fromarray(pixels.astype(np.float32), mode="F").resize(resolution, Image.BOX)
    solid = np.asarray(coverage)[::-1] > 0
    if not solid.any():
        raise ParameterError(f"mask {str(path)!r} is empty: no solid pixels (dark, or opaque "
                             "where the image has alpha)")
    if solid.all():
        raise ParameterError(f"mask {str(path)!r} is solid everywhere: particles have no room")
    return solid


def nearest_seed(seeds):
    """For each cell, the (row, col) of a nearest True cell of ``seeds`` (jump flooding)."""
    h, w = seeds.shape
    rows, cols = np.indices((h, w))
    best = np.where(seeds[..., None], np.stack([rows, cols], -1), -1)
    step = 1 << int(np.ceil(np.log2(max(h, w))))
    while step >= 1:
        for dy in (-step, 0, step):
            for dx in (-step, 0, step):
                if dx == 0 and dy == 0:
                    continue
                shifted = np.full_like(best, -1)
                ys = slice(max(dy, 0), h + min(dy, 0))
                yd = slice(max(-dy, 0), h + min(-dy, 0))
                xs = slice(max(dx, 0), w + min(dx, 0))
                xd = slice(max(-dx, 0), w + min(-dx, 0))
                shifted[yd, xd] = best[ys, xs]
                valid = shifted[..., 0] >= 0
                d_new = (shifted[..., 0] - rows) ** 2 + (shifted[..., 1] - cols) ** 2
                d_old = np.where(best[..., 0] >= 0,
                                 (best[..., 0] - rows) ** 2 + (best[..., 1] - cols) ** 2, np.inf)
                better = valid & (d_new < d_old)
                best[better] = shifted[better]
        step //= 2
    return best


def mask_sdf(solid, cell):
    """Signed distance (cells -> world via ``cell``) and normals of a solid mask."""
    rows, cols = np.indices(solid.shape)
    to_solid = nearest_seed(solid)
    to_empty = nearest_seed(~solid)
    d_out = np.hypot(to_solid[..., 0] - rows, to_solid[..., 1] - cols)
    d_in = np.hypot(to_empty[..., 0] - rows, to_empty[..., 1] - cols)
    # Cell centres: the surface lies half a cell from the nearest cell of the other kind.
    dist = np.where(solid, -(d_in - 0.5), d_out - 0.5) * cell
    gy, gx = np.gradient(dist / cell)
    gradient = np.stack([gx, gy], -1)
    # A distance gradient is 1 long; on a medial axis (inside a line one or two cells thick, say)
    # it cancels out and points along the wall. There, the outward direction is the one to the
    # nearest cell of the other kind: towards empty from inside, away from solid from outside.
    flood = np.where(solid[..., None], np.stack([to_empty[..., 1] - cols, to_empty[..., 0] - rows], -1),
                     np.stack([cols - to_solid[..., 1], rows - to_solid[..., 0]], -1))
    degenerate = np.hypot(gx, gy) < 0.5
    normal = np.where(degenerate[..., None], flood.astype(np.float64), gradient)
    return dist, _unit(normal, fallback=(0.0, 1.0))


# --- the field ---------------------------------------------------------------------------------

def cell_size(rect, resolution):
    """The side of a field cell (the larger one where cells are not square)."""
    x0, y0, x1, y1 = rect
    return max((x1 - x0) / resolution[0], (y1 - y0) / resolution[1])


class CollisionField:
    """Distance and normal on a ``resolution`` grid of cells over ``rect`` (x0, y0, x1, y1).

    Parameters
    ----------
    rect : tuple
        The scene rectangle; its edges are walls and floor.
    shapes : list
        Circle, Box and Capsule objects (their union is solid).
    mask : str or Path, optional
        A PNG silhouette stretched over the rectangle, used instead of or with the shapes.
    resolution : (int, int)
        Cells along x and y.
    max_distance : float
        Distances are clamped to +-max_distance (the packed range); far cells only need "far".
        It grows to the deepest interior point where an object is deeper.
    """

    def __init__(self, rect, shapes=(), mask=None, resolution=(256, 256), max_distance=0.25):
        self.rect = tuple(float(v) for v in rect)
        x0, y0, x1, y1 = self.rect
        w, h = (int(check_range("field resolution", r, 8, 4096, integer=True)) for r in resolution)
        self.resolution = (w, h)
        self.cell = cell_size(self.rect, (w, h))
        self.max_distance = check_range("max_distance", max_distance, self.cell, 1e3)
        for shape in shapes:
            lo, hi = shape.bounds()
            if np.any(hi < (x0, y0)) or np.any(lo > (x1, y1)):
                raise ParameterError(f"shape {shape} lies outside the scene rectangle {self.rect}")
        xs = x0 + (np.arange(w) + 0.5) * (x1 - x0) / w
        ys = y0 + (np.arange(h) + 0.5) * (y1 - y0) / h
        centres = np.stack(np.meshgrid(xs, ys), -1)  # (h, w, 2), row 0 at the bottom
        # The walls are not in the texture: the shader tests them as exact planes (see
        # collide() in lib/particle.glsl). Far from every object the field reads max_distance.
        far = (np.full(centres.shape[:2], self.max_distance), np.tile([0.0, 1.0], centres.shape[:2] + (1,)))
        parts = [far] + [s.sdf(centres) for s in shapes]
        if mask is not None:
            parts.append(mask_sdf(load_mask(mask, (w, h)), self.cell))
        self.shapes = tuple(shapes)
        self.distance, self.normal = union(parts)
        self.solid = self.distance < 0
        # Inside, every depth must be held, not clamped: a particle placed deep (by an emitter
        # inside an object, say) is pushed out by the depth its cell reads. Outside, far cells
        # only need "far", so the packed range grows to the deepest interior point only.
        deepest = float(-self.distance.min()) + self.cell
        if deepest > self.max_distance:
            self.max_distance = deepest
            self.distance = np.minimum(self.distance, self.max_distance)
        # The packed distance's range as the shader decodes it: (lo, lo, span, span).
        self.range = (-self.max_distance, -self.max_distance, 2 * self.max_distance,
                      2 * self.max_distance)

    def texels(self):
        """RGBA8 bytes (h, w, 4): packed distance in RG, normal in BA."""
        unit = (np.clip(self.distance, -self.max_distance, self.max_distance) + self.max_distance) / (
            2 * self.max_distance)
        out = np.empty(self.distance.shape + (4,), np.uint8)
        out[..., 0:2] = packing.pack16(unit.astype(np.float32))
        # Normal components over 254 steps around 127: 0 and +-1 are exact bytes (127, 127 +- 127),
        # where (n/2 + 1/2) 255 put 0 at 127.5 and tilted every axis-aligned face by 0.0039.
        out[..., 2:4] = (np.round(self.normal * 127) + 127).clip(0, 254).astype(np.uint8)
        return out

    def decoded(self):
        """(distance, normal) exactly as the shader decodes them from the texture."""
        t = self.texels()
        d = np.float32(-self.max_distance) + packing.unpack16(t[..., 0:2]) * np.float32(2 * self.max_distance)
        n = (t[..., 2:4].astype(np.float32) - np.float32(127)) * np.float32(1 / 127)
        n = n / np.hypot(n[..., 0], n[..., 1])[..., None]  # as normalize() in the shader
        return d.astype(np.float32), n

    def sample(self, p):
        """numpy twin of ``field_sample``: the NEAREST cell's decoded normal, and its distance
        carried from the cell's centre to p along that normal."""
        d, n = self._decoded
        x0, y0, x1, y1 = self.rect
        w, h = self.resolution
        i = np.clip(np.floor((p[..., 0] - x0) / (x1 - x0) * w), 0, w - 1).astype(int)
        j = np.clip(np.floor((p[..., 1] - y0) / (y1 - y0) * h), 0, h - 1).astype(int)
        centre = np.stack([x0 + (i + 0.5) / w * (x1 - x0), y0 + (j + 0.5) / h * (y1 - y0)], -1)
        normal = n[j, i].astype(np.float64)
        return d[j, i] + np.sum(normal * (p - centre), axis=-1), normal

    @cached_property
    def _decoded(self):
        return self.decoded()

    def exact_distance(self, p):
        """Float64 signed distance to the analytic shapes and the walls at points p (tests)."""
        return union([walls(p, self.rect)] + [s.sdf(p) for s in self.shapes])[0]


def memory_table(resolutions=((128, 128), (256, 256), (512, 512), (1024, 1024), (2048, 2048))):
    """Rows (resolution, bytes per format) of the field's texture memory."""
    return [(f"{w}x{h}", {fmt: w * h * bytes_per_texel(fmt) for fmt in FORMAT_DTYPES})
            for w, h in resolutions]


def parse_shape(spec, rect):
    """A shape list from the command line: circle, box, capsule, their '+' union, or a PNG path.

    Returns (shapes, mask_path)."""
    x0, y0, x1, y1 = rect
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    size = min(x1 - x0, y1 - y0)
    presets = {
        "circle": Circle((cx + 0.15 * size, cy - 0.2 * size), 0.11 * size),
        "box": Box((cx + 0.3 * size, cy - 0.38 * size), (0.12 * size, 0.05 * size)),
        "capsule": Capsule((cx - 0.05 * size, cy - 0.02 * size), (cx + 0.2 * size, cy + 0.06 * size),
                           0.025 * size),
    }
    if spec.lower().endswith(".png"):
        from ..io.images import check_input

        check_input(spec, "--shape (a mask)")  # a folder or a FIFO named here is not opened
        return [], spec
    shapes = []
    for name in spec.split("+"):
        if name not in presets:
            raise ParameterError(f"shape must be circle, box, capsule, a '+' union of them "
                                 f"(circle+box) or a PNG mask path, got {spec!r}")
        shapes.append(presets[name])
    return shapes, None
