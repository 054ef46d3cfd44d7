"""The 3D collision field, as the ARM chapter's: signed distance and unit normal per voxel of a
box around an object, in a 2D slice atlas (ES 2.0 has no 3D textures).

The field lives in the object's own space (its shapes at rest, the pivot at the origin); the
shader brings a particle into that space with the object's pose of the step and the normal back
out, so the object may move and turn. Voxels are cubes; ``resolution`` of them span the box's
longest side. Slices of constant z are tiled in rows of the atlas, each tile padded to a multiple
to whole compression blocks (a block never straddles two slices).

Three encodings of a voxel (see ``shaders/glsl100/lib/field3d.glsl``):

- ``packed`` (RGBA8, the ES 2.0 baseline): RG the distance in 16 bits (high, low bytes), BA the
  normal octahedral-encoded in two bytes (127 e + 127: 0 and +-1 exact);
- ``float`` (RGBA32F): distance and the three normal components;
- ``smooth`` (RGBA8 meant for lossy blocks such as ASTC): R the distance in 8 bits, GB the
  octahedral normal, A 255. The high/low byte pair of ``packed`` cannot survive lossy blocks (an
  error of one in the high byte is 255 codes of the distance); each channel of ``smooth`` is a
  smooth function of place, which block compression keeps.

The lookup is NEAREST with the distance carried from the voxel's centre along its normal (one
fetch per sub-step, as the chapter's single texture access; exact for flat faces). Interpolation
would take eight fetches across two slices and cannot filter a packed byte pair in hardware.

Shapes are analytic (sphere, box, capsule, torus, their unions; exact distance and normal at each
voxel centre) or triangle meshes (OBJ, STL, PLY through trimesh, the ``mesh`` extra): a mesh is
made a solid voxel mask (every voxel its surface touches, and the inside of a closed mesh; an
open shell grown by a voxel across its faces), then an exact Euclidean distance transform (scipy)
gives distance and normal, as the 2D masks, so a thin shell is solid voxels joined by faces.
Within NEAR_VOXELS of a closed mesh's surface the distance and normal come from the triangles
instead: the closest point on them, signed by its feature's angle-weighted pseudo-normal, so a
mesh of a sphere is the sphere to its facets, not to its voxels (the mask's normals were 13.7
degrees off on average near an icosphere's top, its surface 0.57 voxel out). A
mesh file is checked before it is used (:func:`load_mesh`), and the voxelising's work and memory
are estimated from its triangles before it starts (:func:`check_voxelising`).
"""

import io
import itertools
import re
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from ..errors import ParameterError, check_range
from . import field2d
from .field2d import union  # the smallest distance, with its shape's normal: any dimension
from ..twins import pack as packing

ENCODINGS = ("packed", "float", "half", "smooth")
FAR_VOXELS = 3  # outside, distances are held up to this many voxels; beyond, "far"


# --- analytic shapes: signed distance and unit normal, float64 --------------------------------

def _unit(v, fallback=(0.0, 1.0, 0.0)):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(n > 1e-12, v / np.where(n > 1e-12, n, 1), np.asarray(fallback, float))


@dataclass(frozen=True)
class Sphere(field2d.Circle):
    """A sphere: the circle's centre, radius and bounds, in three dimensions."""

    def sdf(self, p):
        q = p - np.asarray(self.centre, float)
        return np.linalg.norm(q, axis=-1) - self.radius, _unit(q)

    def half_thickness(self):
        return self.radius


@dataclass(frozen=True)
class Box(field2d.Box):
    """An axis-aligned box: the 2D box's centre, half sizes and bounds, in three dimensions."""

    def sdf(self, p):
        q = p - np.asarray(self.centre, float)
        d = np.abs(q) - np.asarray(self.half_size, float)
        outside = np.maximum(d, 0)
        out_len = np.linalg.norm(outside, axis=-1)
        sign = np.where(q >= 0, 1.0, -1.0)
        # Inside: along the axis of the nearest face; outside: along the offset from the box.
        face = np.argmax(d, axis=-1)[..., None] == np.arange(3)
        inside = np.where(face, sign, 0.0)
        normal = np.where((out_len > 0)[..., None], _unit(outside * sign), inside)
        return out_len + np.minimum(d.max(axis=-1), 0), normal

    def half_thickness(self):
        return min(self.half_size)


@dataclass(frozen=True)
class Capsule(field2d.Capsule):
    """The points within ``radius`` of the segment a-b: the 2D capsule's fields and bounds."""

    def sdf(self, p):
        a, b = np.asarray(self.a, float), np.asarray(self.b, float)
        ab = b - a
        t = np.clip(((p - a) @ ab) / max(ab @ ab, 1e-300), 0, 1)
        q = p - (a + t[..., None] * ab)
        # On the axis the normal is undefined: any direction across it.
        across = _unit(np.cross(ab, (1.0, 0.0, 0.0) if abs(ab[0]) < 0.9 * np.linalg.norm(ab)
                                else (0.0, 1.0, 0.0)))
        return np.linalg.norm(q, axis=-1) - self.radius, _unit(q, across)

    def half_thickness(self):
        return self.radius


@dataclass(frozen=True)
class Torus:
    """A torus around the y axis through ``centre``: ``major`` radius of the ring, ``minor`` of
    the tube."""

    centre: tuple
    major: float
    minor: float

    def sdf(self, p):
        q = p - np.asarray(self.centre, float)
        radial = np.hypot(q[..., 0], q[..., 2])
        # The nearest point of the ring (the tube's centre line), then out from it.
        ring = np.stack([q[..., 0], np.zeros_like(radial), q[..., 2]], -1)
        ring = _unit(ring, (1.0, 0.0, 0.0)) * self.major
        offset = q - ring
        return np.hypot(radial - self.major, q[..., 1]) - self.minor, _unit(offset)

    def bounds(self):
        c, r = np.asarray(self.centre, float), self.major + self.minor
        return c - (r, self.minor, r), c + (r, self.minor, r)

    def half_thickness(self):
        return self.minor


SHAPES = {"sphere": (Sphere, "CX,CY,CZ,R"), "box": (Box, "CX,CY,CZ,HX,HY,HZ"),
          "capsule": (Capsule, "AX,AY,AZ,BX,BY,BZ,R"), "torus": (Torus, "CX,CY,CZ,MAJOR,MINOR")}


# --- triangle meshes: a solid voxel mask, then an exact distance transform ----------------------

# The voxeliser's work. trimesh.remesh.subdivide_to_size bisects every edge longer than a quarter
# voxel, so a triangle becomes a number of points that grows with its size over that step
# squared, not with the file: 300 triangles across the box (a 15 KB STL) are ~160 million points
# at --field-resolution 256, where the 320-triangle icosphere of the tests is ~10 million.
# Measured on trimesh 5.2 over 400 random triangles (slivers and needles among them): a triangle
# of area A and longest edge L (in quarter voxels) gives between 0.19 and 2.75 times
# 3 + 2 A + 0.3 L^2 points (a sliver still splits into ~0.1 L^2 of them); the subdivision's peak
# is ~700 bytes a point made (its float64 xyz, the int64 faces, their edges sorted and hashed);
# 300 to 400 thousand points are made a second on one core. So the work is done in runs of
# triangles (TriangleMesh.chunks), each under a fixed memory; the whole is capped in points
# (time), and the largest run must fit in the memory available now (free_memory).
SURFACE_POINTS_PER_CHUNK = 2 ** 18  # estimated: a run's peak is under 0.55 GB (3 x 700 bytes)
MAX_SURFACE_POINTS = 2 ** 26  # estimated, the whole mesh: ~3 minutes' work; beyond, refused
BYTES_PER_SURFACE_POINT = 700
ESTIMATE_MARGIN = 3  # the most points a triangle made beyond its estimate (2.75), rounded up


def free_memory():
    """Bytes of memory this process may take now, or None where no limit could be read: the
    least of MemAvailable, a cgroup's limit and ``ulimit -v`` (``io.memory.available``, which
    every run's estimate is checked against too)."""
    from ..io.memory import available

    return available().bytes


@dataclass(frozen=True, eq=False)
class TriangleMesh:
    """An indexed triangle mesh in world units (loaded by :func:`load_mesh`); ``name`` is the
    file as the user named it."""

    vertices: np.ndarray
    faces: np.ndarray
    name: str = "mesh"
    closed: bool = True  # watertight: its inside is filled; else a shell, made face-connected

    def bounds(self):
        return self.vertices.min(axis=0), self.vertices.max(axis=0)

    def surface_points(self, voxel):
        """Estimated points the voxeliser makes of each triangle at ``voxel`` (see
        SURFACE_POINTS_PER_CHUNK's comment: 0.19 to 2.75 times the points made), float64 (F,)."""
        corners = self.vertices[self.faces] / (voxel / 4)  # in quarter voxels
        longest = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=-1).max(axis=1)
        area = np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                       corners[:, 2] - corners[:, 0]), axis=-1) / 2
        return 3 + 2 * area + 0.3 * longest ** 2

    def chunks(self, voxel):
        """The faces in runs of consecutive triangles of about SURFACE_POINTS_PER_CHUNK
        estimated points each (a triangle estimated above that is a run of its own)."""
        run = np.cumsum(self.surface_points(voxel)) // SURFACE_POINTS_PER_CHUNK
        return np.split(self.faces, np.flatnonzero(np.diff(run)) + 1)

    def solid(self, lo, voxel, cells):
        """Boolean (nz, ny, nx) mask: the voxels the surface passes through (where its points,
        a quarter voxel apart, fall), and the inside of each closed part (the holes the surface
        voxels enclose). Surface voxels found this way may meet only at an edge or a corner where
        the surface grazes one; a closed mesh's filled inside covers that, an open shell is grown
        by one voxel across its faces (6-connected) so that nothing passes between them.

        The points are made a run of triangles at a time (:meth:`chunks`) and their voxels marked
        as they come, so the peak memory is one run's, not the whole surface's. The mask is the
        one subdividing the whole mesh at once gives: trimesh bisects an edge by its length
        alone, at its midpoint (the same float64 sum from either face), so each triangle's points
        do not depend on its neighbours. :class:`VoxelField` refuses a mesh whose estimated work
        is beyond MAX_SURFACE_POINTS, or one run of which would not fit in the free memory."""
        from scipy import ndimage
        import trimesh

        mask = np.zeros(cells[::-1], bool)

        def mark(points):
            index = np.floor((points - lo) / voxel).astype(int)
            index = index[np.all((index >= 0) & (index < cells), axis=1)]
            mask[index[:, 2], index[:, 1], index[:, 0]] = True

        mark(self.vertices)
        for faces in self.chunks(voxel):
            used, corners = np.unique(faces, return_inverse=True)
            points, _ = trimesh.remesh.subdivide_to_size(
                self.vertices[used], corners.reshape(-1, 3), max_edge=voxel / 4, max_iter=40)
            mark(points)
        if not self.closed:
            mask = ndimage.binary_dilation(mask, ndimage.generate_binary_structure(3, 1))
        return ndimage.binary_fill_holes(mask)

    def field(self, lo, voxel, cells):
        """Signed distance and unit normal (float64, (nz, ny, nx) and (nz, ny, nx, 3)) at the
        voxel centres of the box from ``lo``: from the triangles themselves within NEAR_VOXELS
        of a closed mesh's surface (:func:`triangle_distance`), from the solid mask's distance
        transform (:func:`mask_field`) beyond, and everywhere for an open shell (it has no
        inside to sign a distance by)."""
        dist, normal = mask_field(self.solid(lo, voxel, cells), voxel)
        if not self.closed:
            return dist, normal
        near = np.abs(dist) <= NEAR_VOXELS * voxel
        z, y, x = np.nonzero(near)
        points = lo + (np.stack([x, y, z], -1) + 0.5) * voxel
        # The mask's distance errs by under a voxel: the band's true distances are within reach.
        dist[near], normal[near] = triangle_distance(points, self.vertices, self.faces,
                                                     (NEAR_VOXELS + 1) * voxel)
        return dist, normal

    def __repr__(self):
        return f"TriangleMesh({self.name!r}, {len(self.faces)} triangles)"


# Coordinates a mesh file may hold: trimesh merges vertices on a grid of tol.merge = 1e-8 held in
# int64, which overflows beyond 2^63 * 1e-8 = 9.2e10 (numpy's 'invalid value encountered in cast').
MAX_COORDINATE = 1e10
# The mesh formats read, by extension, each parsed as that format alone. Formats that name other
# files (glTF's buffers, an OBJ's mtllib, a PLY's texture) are not followed: only the geometry
# is used, and a named file could be a FIFO (a hang) or lie outside the mesh's folder.
MESH_TYPES = {".obj": "obj", ".stl": "stl", ".ply": "ply"}


def load_mesh(path, centre=(0.0, 1.0, 0.0), size=2.0):
    """A mesh file (OBJ, STL or PLY, by its extension) scaled so that its longest side is ``size`` and moved so
    that its bounding box's centre is ``centre``.

    The file is checked before it is used, each fault one :class:`ParameterError` naming it: a
    folder or a FIFO (never opened), a file trimesh cannot read as a mesh, vertices that are not
    finite numbers or beyond +-MAX_COORDINATE, face indices beyond its vertices, no triangles,
    and a mesh flat to a point or a line. The checks look at the file's data as read, before
    trimesh's processing (which drops the faces at a nan vertex and merges vertices). The path's
    faults come before a missing trimesh: they are the user's to fix either way."""
    from ..io.images import open_input

    check_range("mesh size", size, 1e-3, 1e3)
    named = f"mesh file {str(path)!r}"
    kind = MESH_TYPES.get(Path(path).suffix.lower())
    if kind is None:
        raise ParameterError(f"{named}: mesh files are read as OBJ, STL or PLY, by their "
                             "extension (.obj .stl .ply)")
    with open_input(path, "--shape", named) as handle:
        try:
            import scipy  # noqa: F401
            import trimesh
        except ImportError:
            raise ParameterError("mesh shapes need trimesh and scipy: pip install "
                                 "'es2particles[mesh]'") from None
        scene = _read_mesh_scene(handle, kind, Path(path), named)
    parts = [g for g in scene.geometry.values() if isinstance(g, trimesh.Trimesh)]
    for part in scene.geometry.values():
        _check_raw_mesh(part, named)
    if not any(len(part.faces) for part in parts):
        points = sum(len(g.vertices) for g in scene.geometry.values())
        raise ParameterError(f"{named} has {points} vertices but no triangles (faces)" if points
                             else f"{named} could not be read as a mesh: trimesh found no "
                             "vertices or triangles in it")
    for part in parts:
        part.process()  # as trimesh.load does: merged vertices, so that closed reads as closed
    mesh = scene.to_mesh()
    v = np.asarray(mesh.vertices, float)
    lo, hi = v.min(axis=0), v.max(axis=0)
    extent = float((hi - lo).max())
    if not extent > 0:
        raise ParameterError(f"{named} is flat to a point: all its vertices are one")
    v = (v - (lo + hi) / 2) * (size / extent) + np.asarray(centre, float)
    faces = np.asarray(mesh.faces, np.int64)
    corners = v[faces]
    area = np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                   corners[:, 2] - corners[:, 0]), axis=-1) / 2
    if not np.any(area > 1e-12 * size ** 2):  # float64 leaves ~1e-16 of a flat one
        spread = np.linalg.svd(v - v.mean(axis=0), compute_uv=False)
        where = ("its vertices lie on one line" if spread[1] <= 1e-9 * spread[0]
                 else "each has its corners on one line")
        raise ParameterError(f"{named} is flat: none of its {len(faces)} triangles has an "
                             f"area ({where})")
    return TriangleMesh(v, faces, str(path), bool(mesh.is_watertight))


def _read_mesh_scene(handle, kind, file, named):
    """The open file ``handle`` read by trimesh as ``kind``, unprocessed (each part's vertices
    and faces as the file has them), or one line saying why it is not a mesh. It is given the
    open file and no resolver, so nothing the file names (an OBJ's mtllib, a PLY's texture) is
    opened."""
    import trimesh

    data = handle.read()
    if kind == "obj":
        _check_obj_indices(data, named)
    elif kind == "ply":
        _check_ply_lists(data, named)
    stream = io.BytesIO(data)
    stream.name = file.name  # trimesh names the part after it (an open fd's name is a number)
    try:
        return trimesh.load_scene(stream, file_type=kind, process=False, skip_materials=True)
    except ImportError as error:  # a reader's optional module, wanted for this file's content
        if error.name == "charset_normalizer":  # wanted only to guess a text's encoding
            kind = "neither a binary STL nor UTF-8 text" if file.suffix.lower() == ".stl" \
                else "not UTF-8 text"
            raise ParameterError(f"{named} could not be read as a mesh: it is {kind}") from None
        raise ParameterError(f"{named} could not be read as a mesh: its reader needs the "
                             f"module {error.name!r}") from None
    except IndexError as error:  # an OBJ's face naming a vertex it lacks (numpy's words)
        beyond = re.fullmatch(r"index (\d+) is out of bounds for axis 0 with size (\d+)",
                              str(error))
        if beyond and file.suffix.lower() == ".obj":  # OBJ counts its vertices from 1
            index, count = int(beyond[1]) + 1, int(beyond[2])
            raise ParameterError(f"{named} has a face index {index} out of range: it has "
                                 f"{count} vertices (1 to {count})") from None
        raise ParameterError(f"{named} could not be read as a mesh: an index in it is out of "
                             f"range ({error})") from None
    except Exception as error:  # trimesh raises many kinds for unreadable files
        raise ParameterError(f"{named} could not be read as a mesh: {error}") from None


def _check_obj_indices(data, named):
    """Refuse an OBJ face naming vertex 0: OBJ counts from 1 (and -1 from the end), and trimesh
    reads 0 as -1, the last vertex, so such a file ran as another mesh."""
    for number, line in enumerate(data.splitlines(), 1):
        words = line.split()
        if words[:1] != [b"f"]:
            continue
        if any(word.split(b"/")[0] in (b"0", b"+0", b"-0") for word in words[1:]):
            raise ParameterError(f"{named} line {number}: a face names vertex 0; OBJ counts "
                                 "vertices from 1")


def _check_ply_lists(data, named):
    """Refuse an ASCII PLY whose face line claims another count of indices than it holds (5
    claimed, 3 given ran, trimesh reading the next line's numbers as the missing ones). A
    binary PLY's lists are the reader's to check."""
    head, _, body = data.partition(b"end_header")
    lines = head.decode("ascii", "replace").splitlines()
    if not any(line.strip() == "format ascii 1.0" for line in lines):
        return
    elements, order = {}, []
    for line in lines:
        words = line.split()
        if words[:1] == ["element"] and len(words) == 3 and words[2].isdigit():
            elements[words[1]] = int(words[2])
            order.append(words[1])
    if "face" not in elements:
        return
    rows = body.splitlines()[1:]  # after the end_header line's own end
    first = sum(elements[name] for name in order[:order.index("face")])
    for number, row in enumerate(rows[first:first + elements["face"]], first + 1):
        words = row.split()
        if words and words[0].isdigit() and int(words[0]) != len(words) - 1:
            raise ParameterError(f"{named} has face {number - first} claiming {int(words[0])} "
                                 f"indices but holding {len(words) - 1}")


def _check_raw_mesh(part, named):
    """One part of a mesh file as read: finite vertices within +-MAX_COORDINATE, faces that
    index them."""
    v = np.asarray(part.vertices, float).reshape(-1, 3)
    bad = ~np.all(np.isfinite(v), axis=1)
    if bad.any():
        first = ", ".join(f"{x:g}" for x in v[bad][0])
        count = np.count_nonzero(bad)
        which = "a vertex that is not finite:" if count == 1 else \
            f"{count} vertices that are not finite, the first"
        raise ParameterError(f"{named} has {which} ({first})")
    if v.size and np.abs(v).max() > MAX_COORDINATE:
        raise ParameterError(f"{named} has a coordinate of {np.abs(v).max():g}; coordinates "
                             f"must lie within +-{MAX_COORDINATE:g}")
    faces = np.asarray(getattr(part, "faces", np.zeros((0, 3), int)))
    if faces.size and (faces.min() < 0 or faces.max() >= len(v)):
        index = faces.max() if faces.max() >= len(v) else faces.min()
        raise ParameterError(f"{named} has a face index {index} out of range: it has "
                             f"{len(v)} vertices (0 to {len(v) - 1})")


def mask_field(solid, voxel):
    """Signed distance and unit normal (float64) at voxel centres of a solid mask (nz, ny, nx),
    by an exact Euclidean distance transform. As the 2D masks (field.mask_sdf): the surface lies
    half a voxel from the nearest voxel of the other kind, and where the distance's gradient
    vanishes (medial axes of thin walls) the normal is the direction to that voxel."""
    from scipy import ndimage

    d_in, to_empty = ndimage.distance_transform_edt(solid, return_indices=True)
    d_out, to_solid = ndimage.distance_transform_edt(~solid, return_indices=True)
    dist = np.where(solid, -(d_in - 0.5), d_out - 0.5)
    grid = np.indices(solid.shape)
    flood = np.where(solid, to_empty - grid, grid - to_solid)  # (3, nz, ny, nx), z y x order
    flood = np.moveaxis(flood[::-1], 0, -1).astype(float)  # -> x y z last
    gz, gy, gx = np.gradient(dist)
    gradient = np.stack([gx, gy, gz], -1)
    degenerate = np.linalg.norm(gradient, axis=-1) < 0.5
    normal = _unit(np.where(degenerate[..., None], flood, gradient))
    return dist * voxel, normal


# --- distance to the triangles, near a mesh's surface ---------------------------------------------

NEAR_VOXELS = 3  # a closed mesh's distance and normal come from its triangles within this band
PAIRS_PER_RUN = 2 ** 20  # (point, triangle) pairs measured at a time: ~0.3 GB of float64 temporaries


def closest_on_triangles(p, a, b, c):
    """Closest points on triangles (a, b, c) to points p, all (N, 3) float64, and their
    barycentric weights (N, 3) of a, b and c (Ericson, Real-Time Collision Detection, 5.1.5)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("ij,ij->i", ab, ap), np.einsum("ij,ij->i", ac, ap)
    bp = p - b
    d3, d4 = np.einsum("ij,ij->i", ab, bp), np.einsum("ij,ij->i", ac, bp)
    cp = p - c
    d5, d6 = np.einsum("ij,ij->i", ab, cp), np.einsum("ij,ij->i", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v, w = vb / denom, vc / denom  # the face
        weights = np.stack([1 - v - w, v, w], -1)
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    regions = [  # (condition, weights), the first that holds wins: vertices, then edges
        (d1 <= 0) & (d2 <= 0), [1, 0, 0],
        (d3 >= 0) & (d4 <= d3), [0, 1, 0],
        (d6 >= 0) & (d5 <= d6), [0, 0, 1],
        (vc <= 0) & (d1 >= 0) & (d3 <= 0), np.stack([1 - t_ab, t_ab, 0 * t_ab], -1),
        (vb <= 0) & (d2 >= 0) & (d6 <= 0), np.stack([1 - t_ac, 0 * t_ac, t_ac], -1),
        (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), np.stack([0 * t_bc, 1 - t_bc, t_bc], -1),
    ]
    done = np.zeros(len(p), bool)
    for condition, w_region in zip(regions[::2], regions[1::2]):
        take = condition & ~done
        weights[take] = np.broadcast_to(np.asarray(w_region, float), weights.shape)[take]
        done |= take
    closest = weights[:, :1] * a + weights[:, 1:2] * b + weights[:, 2:] * c
    return closest, weights


def pseudo_normals(vertices, faces):
    """Angle-weighted pseudo-normals (Baerentzen and Aanaes 2005) of a closed mesh's faces (F, 3),
    edges (as a map from each face's edge k, between corners k and k+1, to the sum of its two
    faces' normals: (F, 3, 3)) and vertices (V, 3): the sign of (p - q) . n at the closest point
    q, with n the pseudo-normal of the feature q lies on, says whether p is inside, robustly,
    whatever the mesh's angles."""
    corners = vertices[faces]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    at_vertex = np.zeros_like(vertices)
    for k in range(3):
        u = corners[:, (k + 1) % 3] - corners[:, k]
        v = corners[:, (k + 2) % 3] - corners[:, k]
        cos = np.einsum("ij,ij->i", u, v) / np.maximum(
            np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1), 1e-300)
        np.add.at(at_vertex, faces[:, k], np.arccos(np.clip(cos, -1, 1))[:, None] * normal)
    edges = np.sort(np.stack([faces, np.roll(faces, -1, axis=1)], -1), axis=-1).reshape(-1, 2)
    _, edge_of = np.unique(edges, axis=0, return_inverse=True)
    at_edge = np.zeros((edge_of.max() + 1, 3))
    np.add.at(at_edge, edge_of.ravel(), np.repeat(normal, 3, axis=0))
    return normal, at_edge[edge_of.ravel()].reshape(-1, 3, 3), at_vertex


def triangle_distance(points, vertices, faces, reach):
    """Signed distance (negative inside) and outward unit normal (float64) of a closed mesh at
    ``points`` (N, 3), for points within ``reach`` of it (others are measured against the
    triangles that a ball of that reach around the nearest centroid's triangle finds, so may
    come out too far). The normal is the direction from the closest point on the triangles to
    the point, signed by the closest feature's angle-weighted pseudo-normal (on the surface
    itself, that pseudo-normal)."""
    from scipy.spatial import cKDTree

    corners = vertices[faces]
    centroid = corners.mean(axis=1)
    radius = np.linalg.norm(corners - centroid[:, None], axis=-1).max(axis=1)
    tree = cKDTree(centroid)
    # The nearest centroid's triangle bounds the distance (d0); every triangle nearer than that
    # has its centroid within d0 + its radius (and no band point is beyond ``reach``).
    _, nearest = tree.query(points)
    c0, _ = closest_on_triangles(points, *np.moveaxis(corners[nearest], 1, 0))
    d0 = np.minimum(np.linalg.norm(points - c0, axis=1), reach)
    candidates = tree.query_ball_point(points, d0 + radius.max() + 1e-9)
    counts = np.fromiter(map(len, candidates), int, len(points))
    pair_point = np.repeat(np.arange(len(points)), counts)
    pair_face = np.fromiter(itertools.chain.from_iterable(candidates), int, counts.sum())
    face_n, edge_n, vertex_n = pseudo_normals(vertices, faces)
    best = np.full(len(points), np.inf)
    q = np.zeros_like(points)
    n = np.tile([0.0, 1.0, 0.0], (len(points), 1))
    for start in range(0, len(pair_point), PAIRS_PER_RUN):
        i = pair_point[start:start + PAIRS_PER_RUN]
        f = pair_face[start:start + PAIRS_PER_RUN]
        c, w = closest_on_triangles(points[i], *np.moveaxis(corners[f], 1, 0))
        d = np.linalg.norm(points[i] - c, axis=1)
        order = np.lexsort((d, i))  # each point's nearest pair first
        first = order[np.r_[True, i[order][1:] != i[order][:-1]]]
        better = d[first] < best[i[first]]
        k, j = i[first][better], first[better]
        best[k], q[k] = d[j], c[j]
        n[k] = _feature_normal(w[j], f[j], faces, face_n, edge_n, vertex_n)
    away = points - q
    sign = np.where(np.einsum("ij,ij->i", away, n) < 0, -1.0, 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        direction = away / best[:, None]
    normal = np.where(best[:, None] > 1e-12, sign[:, None] * direction, n)
    return sign * best, _unit(normal)


def _feature_normal(weights, face, faces, face_n, edge_n, vertex_n):
    """The pseudo-normal of the feature (vertex, edge or face) a closest point of barycentric
    ``weights`` on ``face`` lies on."""
    zero = weights <= 1e-12
    out = face_n[face].copy()
    on_edge = zero.sum(axis=1) == 1
    if on_edge.any():  # the edge opposite the zero weight: corner k+1 to k+2 is edge k+1
        k = (np.argmax(zero[on_edge], axis=1) + 1) % 3
        out[on_edge] = edge_n[face[on_edge], k]
    on_vertex = zero.sum(axis=1) == 2
    if on_vertex.any():
        k = np.argmax(~zero[on_vertex], axis=1)
        out[on_vertex] = vertex_n[faces[face[on_vertex], k]]
    return out


# --- octahedral normals --------------------------------------------------------------------------

def octahedral_encode(n):
    """Unit vectors (..., 3) to (..., 2) in [-1, 1]: projected onto the octahedron |x|+|y|+|z| = 1,
    the lower half folded out over the corners."""
    n = np.asarray(n, float)
    p = n / np.sum(np.abs(n), axis=-1, keepdims=True)
    sign = np.where(p[..., :2] >= 0, 1.0, -1.0)
    folded = (1 - np.abs(p[..., 1::-1])) * sign
    return np.where((p[..., 2] < 0)[..., None], folded, p[..., :2])


def octahedral_decode(e):
    """Twin of ``octahedral_decode`` in lib/octahedral.glsl, float32."""
    e = np.asarray(e, np.float32)
    z = np.float32(1) - np.abs(e[..., 0]) - np.abs(e[..., 1])
    sign = np.where(e >= 0, np.float32(1), np.float32(-1))
    xy = np.where((z < 0)[..., None], (np.float32(1) - np.abs(e[..., ::-1])) * sign, e)
    n = np.concatenate([xy, z[..., None]], -1).astype(np.float32)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def normal_bytes(n):
    """Octahedral normal as two bytes, 127 e + 127 (0 and +-1 exact)."""
    return (np.round(octahedral_encode(n) * 127) + 127).clip(0, 254).astype(np.uint8)


# --- the field -------------------------------------------------------------------------------

def parse_shapes(spec, mesh_centre=(0.0, 1.0, 0.0), mesh_size=2.0):
    """Shapes from the command line: ``sphere:CX,CY,CZ,R``, ``box:...``, ``capsule:...``,
    ``torus:...``, or a mesh file, joined by ``+`` into a union."""
    shapes = []
    for part in spec.split("+"):
        part = part.strip()
        kind, _, numbers = part.partition(":")
        if kind in SHAPES:
            cls, form = SHAPES[kind]
            try:
                values = [float(v) for v in numbers.split(",")] if numbers else []
            except ValueError:
                values = None
            if values is None or len(values) != form.count(",") + 1:
                raise ParameterError(f"shape {kind} is {kind}:{form} (numbers), got {part!r}")
            for v in values:
                check_range(f"shape {kind}", v, -1e3, 1e3)
            sizes = {"sphere": values[3:], "box": values[3:], "capsule": values[6:],
                     "torus": values[3:]}[kind]
            if not all(v > 0 for v in sizes):
                raise ParameterError(f"shape {kind}: its sizes ({form.split(',', 3 if kind != 'capsule' else 6)[-1]}) "
                                     f"must be > 0, got {part!r}")
            if cls is Box:
                shapes.append(Box(tuple(values[:3]), tuple(values[3:])))
            elif cls is Capsule:
                shapes.append(Capsule(tuple(values[:3]), tuple(values[3:6]), values[6]))
            elif cls is Torus:
                shapes.append(Torus(tuple(values[:3]), values[3], values[4]))
            else:
                shapes.append(Sphere(tuple(values[:3]), values[3]))
        elif Path(part).suffix.lower() in MESH_TYPES:
            shapes.append(load_mesh(part, mesh_centre, mesh_size))
        else:
            raise ParameterError(
                "shape must be sphere:CX,CY,CZ,R, box:CX,CY,CZ,HX,HY,HZ, "
                "capsule:AX,AY,AZ,BX,BY,BZ,R, torus:CX,CY,CZ,MAJOR,MINOR or a mesh file "
                f"(.obj .stl .ply), joined by '+'; got {part!r}")
    return shapes


def atlas_layout(cells, max_size, block=(1, 1)):
    """(tile width, tile height, columns, atlas width, atlas height) of the z slices of a field of
    ``cells`` (nx, ny, nz) tiled in rows, as square as ``max_size`` texels a side allows, each tile
    padded to whole compression blocks (bw, bh): no block straddles two slices."""
    nx, ny, nz = cells
    tw, th = -(-nx // block[0]) * block[0], -(-ny // block[1]) * block[1]
    columns = max(1, min(nz, max_size // tw, int(np.ceil(np.sqrt(nz * th / tw)))))
    rows = -(-nz // columns)
    if tw > max_size or rows * th > max_size:
        raise ParameterError(f"a {nx}x{ny}x{nz} voxel field does not fit a {max_size}-texel "
                             f"atlas: lower --field-resolution")
    return tw, th, columns, columns * tw, rows * th


def check_voxelising(mesh, extent, resolution, margin):
    """Refuse, in one line naming the mesh file, a mesh whose voxelising (:meth:`TriangleMesh.solid`
    at the voxel of ``resolution`` over ``extent``, less ``margin`` voxels) is estimated beyond
    MAX_SURFACE_POINTS points, or whose largest run of triangles would not fit in the memory free
    now; the line says the resolution that would do. Costs O(triangles), before any voxel."""
    free = free_memory()

    def cost(n):  # (estimated points, peak bytes of the largest run) at resolution n
        points = mesh.surface_points(extent / (n - margin))
        # A run holds under the budget plus one triangle, and no more than the whole mesh.
        run = min(points.sum(), SURFACE_POINTS_PER_CHUNK + points.max())
        return points.sum(), run * ESTIMATE_MARGIN * BYTES_PER_SURFACE_POINT

    def fits(n):
        points, peak = cost(n)
        return points <= MAX_SURFACE_POINTS and (free is None or peak <= free)

    if fits(resolution):
        return
    lower, upper = 16, resolution  # the largest resolution that fits, by bisection
    if not fits(lower):
        advice = f"even --field-resolution {lower} is too much: simplify the mesh"
    else:
        while upper - lower > 1:
            middle = (lower + upper) // 2
            lower, upper = (middle, upper) if fits(middle) else (lower, middle)
        advice = f"lower --field-resolution to {lower} or less"
    points, peak = cost(resolution)
    if points > MAX_SURFACE_POINTS:
        raise ParameterError(
            f"mesh file {mesh.name!r} needs about {points / 1e6:.0f} million points to voxelise "
            f"at --field-resolution {resolution} (its triangles cut to a quarter voxel; at most "
            f"{MAX_SURFACE_POINTS / 1e6:.0f} million, minutes of work): {advice}")
    raise ParameterError(
        f"mesh file {mesh.name!r} needs about {peak / 1e9:.1f} GB at once to voxelise at "
        f"--field-resolution {resolution} (a run of its triangles cut to a quarter voxel), more "
        f"than the {free / 1e9:.1f} GB of memory available: {advice}")


def field_box(shapes, resolution):
    """(lo, hi, voxel) of a :class:`VoxelField` of ``resolution`` around ``shapes`` (their
    bounds at rest, the cubic voxel), refusing in one line what the field cannot be made of: a
    shape thinner than two voxels, a mesh whose voxelising is too costly (check_voxelising).
    O(triangles), before any voxel: a caller may say the field's cost after it, before the
    work."""
    lo = np.min([s.bounds()[0] for s in shapes], axis=0)
    hi = np.max([s.bounds()[1] for s in shapes], axis=0)
    margin = FAR_VOXELS + 1
    # Cubic voxels, the longest side spanning resolution - 2 margin of them.
    voxel = float((hi - lo).max()) / (resolution - 2 * margin)
    for s in shapes:
        if hasattr(s, "half_thickness") and s.half_thickness() < voxel:
            raise ParameterError(
                f"{s} is thinner than two voxels of {voxel:.3g} at field resolution "
                f"{resolution}: raise --field-resolution or thicken the shape")
    for s in shapes:
        if isinstance(s, TriangleMesh):
            check_voxelising(s, float((hi - lo).max()), resolution, 2 * margin)
    return lo, hi, voxel


class VoxelField:
    """Distance and normal on cubic voxels around a union of shapes, in object space.

    Parameters
    ----------
    shapes : list
        Sphere, Box, Capsule, Torus or TriangleMesh, in world units at rest; their union is solid.
    resolution : int
        Voxels along the box's longest side (16 to 256: a 256^3 field fills a 4096^2 atlas).
    pivot : (x, y, z), optional
        The object's origin (it turns about it); default the centre of the shapes' bounds.
    """

    def __init__(self, shapes, resolution=64, pivot=None):
        if not shapes:
            raise ParameterError("a voxel field needs at least one shape")
        self.resolution = int(check_range("field resolution", resolution, 16, 256, integer=True))
        lo, hi, self.voxel = field_box(shapes, self.resolution)
        margin = FAR_VOXELS + 1
        self.bounds = (lo, hi)  # of the shapes, world units at rest
        self.pivot = np.asarray((lo + hi) / 2 if pivot is None else pivot, float)
        self.cells = tuple(int(c) for c in np.ceil((hi - lo) / self.voxel - 1e-9) + 2 * margin)
        # The box in object space: centred on the shapes' bounds, relative to the pivot.
        self.lo = (lo + hi) / 2 - np.asarray(self.cells) * self.voxel / 2 - self.pivot
        self.shapes = tuple(shapes)
        centres = self.centres()
        world = centres + self.pivot
        parts = [(np.full(centres.shape[:-1], np.inf), np.tile([0.0, 1.0, 0.0], centres.shape[:-1] + (1,)))]
        for s in shapes:
            if isinstance(s, TriangleMesh):
                parts.append(s.field(self.lo + self.pivot, self.voxel, np.asarray(self.cells)))
            else:
                parts.append(s.sdf(world))
        self.distance, self.normal = union(parts)
        # Inside, every depth is held (a particle deep inside is pushed out by what it reads);
        # outside, distances beyond FAR_VOXELS only need to say "far".
        self.range = (float(min(self.distance.min(), 0.0)) - self.voxel, FAR_VOXELS * self.voxel)
        self.distance = np.clip(self.distance, *self.range)

    def centres(self):
        """Voxel centres in object space, (nz, ny, nx, 3) as x, y, z."""
        nx, ny, nz = self.cells
        axes = [self.lo[k] + (np.arange(n) + 0.5) * self.voxel for k, n in enumerate((nx, ny, nz))]
        z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
        return np.stack([x, y, z], -1)

    # -- the atlas -------------------------------------------------------------------------

    def atlas_layout(self, max_size, block=(1, 1)):
        """See :func:`atlas_layout`."""
        return atlas_layout(self.cells, max_size, block)

    def texels(self, encoding="packed", max_size=4096, block=(1, 1)):
        """The atlas (h, w, 4): uint8 for ``packed`` and ``smooth``, float32 for ``float``,
        float16 for ``half`` (the chapter's half floats: distance and normal as they are).
        Padding texels repeat their tile's edge voxels (a smooth image for compression)."""
        if encoding not in ENCODINGS:
            raise ParameterError(f"field encoding must be one of {ENCODINGS}, got {encoding!r}")
        lo, hi = self.range
        unit = (self.distance - lo) / (hi - lo)
        if encoding in ("float", "half"):
            voxels = np.concatenate([self.distance[..., None], self.normal], -1).astype(
                np.float32 if encoding == "float" else np.float16)
        elif encoding == "packed":
            voxels = np.concatenate([packing.pack16(unit.astype(np.float32)),
                                     normal_bytes(self.normal)], -1)
        else:
            voxels = np.concatenate([np.round(unit * 255).astype(np.uint8)[..., None],
                                     normal_bytes(self.normal),
                                     np.full(unit.shape + (1,), 255, np.uint8)], -1)
        nx, ny, nz = self.cells
        tw, th, columns, w, h = self.atlas_layout(max_size, block)
        padded = np.pad(voxels, ((0, 0), (0, th - ny), (0, tw - nx), (0, 0)), mode="edge")
        atlas = np.zeros((h, w, 4), voxels.dtype)
        for z in range(nz):
            row, col = divmod(z, columns)
            atlas[row * th:(row + 1) * th, col * tw:(col + 1) * tw] = padded[z]
        return atlas

    def uniforms(self, max_size=4096, block=(1, 1)):
        """The lookup's uniforms (lib/field3d.glsl)."""
        tw, th, columns, w, h = self.atlas_layout(max_size, block)
        return {"u_field_lo": tuple(map(float, self.lo)), "u_voxel": float(self.voxel),
                "u_field_cells": tuple(map(float, self.cells)),
                "u_field_atlas": (float(tw), float(th), float(columns), 0.0),
                "u_field_atlas_size": (float(w), float(h)),
                "u_field_range": (self.range[0], self.range[1] - self.range[0])}

    # -- numpy twins -------------------------------------------------------------------------

    def decoded(self, encoding="packed", atlas=None, max_size=4096, block=(1, 1)):
        """(distance, normal) per voxel as the shader decodes them; ``atlas`` a decompressed
        atlas (what the GPU sees of a compressed one) instead of the exact texels."""
        if atlas is None:
            atlas = self.texels(encoding, max_size, block)
        nx, ny, nz = self.cells
        tw, th, columns = self.atlas_layout(max_size, block)[:3]
        voxels = np.stack([atlas[(z // columns) * th:(z // columns) * th + ny,
                                 (z % columns) * tw:(z % columns) * tw + nx] for z in range(nz)])
        lo, span = np.float32(self.range[0]), np.float32(self.range[1] - self.range[0])
        if encoding in ("float", "half"):
            d, n = voxels[..., 0].astype(np.float32), voxels[..., 1:].astype(np.float32)
            n = n / np.linalg.norm(n, axis=-1, keepdims=True)
        else:
            t = voxels.astype(np.float32) / np.float32(255)
            if encoding == "packed":
                d = lo + packing.unpack16(voxels[..., 0:2]) * span
                e = voxels[..., 2:4]
            else:
                d = lo + t[..., 0] * span
                e = voxels[..., 1:3]
            n = octahedral_decode((np.floor(e.astype(np.float32) + 0.5) - 127) / np.float32(127))
        return d.astype(np.float32), n.astype(np.float32)

    @cached_property
    def _decoded(self):
        return self.decoded()

    def sample(self, q, decoded=None):
        """Twin of ``field_sample``: at object-space points q (N, 3), the NEAREST voxel's normal
        and its distance carried from the voxel's centre to q along it; outside the box, far."""
        d, n = self._decoded if decoded is None else decoded
        cells = np.asarray(self.cells)
        cell = np.floor((q - self.lo) / self.voxel)
        inside = np.all((cell >= 0) & (cell < cells), axis=-1)
        i = np.clip(cell, 0, cells - 1).astype(int)
        normal = n[i[..., 2], i[..., 1], i[..., 0]].astype(np.float64)
        centre = self.lo + (i + 0.5) * self.voxel
        dist = d[i[..., 2], i[..., 1], i[..., 0]] + np.sum(normal * (q - centre), axis=-1)
        return np.where(inside, dist, self.range[1]), normal

    def exact(self, q):
        """Float64 signed distance and normal of the analytic shapes at object-space points."""
        return union([s.sdf(q + self.pivot) for s in self.shapes])
