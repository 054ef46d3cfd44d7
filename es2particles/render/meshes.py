"""Opaque meshes of a 3D scene: shapes (floor, box, sphere, capsule, torus, an indexed triangle
mesh), placed each frame by the scene's :class:`~es2particles.frame.motion.Motion` where they
move, and the mesh stages a frame plan draws them with (``sprites/mesh.vert``, ``sprites/mesh.frag``: a point light,
ambient plus Lambert, a checker or a texture), depth-tested and writing depth, before the
particles.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range
from ..frame.plan import MOTION_UNIFORMS, Ref, Resource, Stage, Vertices
from ..gl.device import DrawState


@dataclass(frozen=True)
class Mesh:
    """An opaque mesh: triangles (n, 3, 3) wound counter-clockwise seen from outside, with normals
    (n, 3, 3), a colour, and for a floor a checker of ``colour2`` in cells of ``checker`` units.
    In world coordinates, unless ``moves``: then at rest, placed each frame by the model matrix of
    the scene's :class:`Motion` (a spinning or swaying obstacle). ``casts_shadow``: it stops a
    lamp's light (``render/lamp.py``; a floor only receives shadows)."""

    triangles: np.ndarray
    normals: np.ndarray
    colour: tuple = (0.7, 0.7, 0.7)
    colour2: tuple = None
    checker: float = 0.0
    uvs: np.ndarray = None  # (n, 3, 2) texture coordinates, with ``texture``
    texture: np.ndarray = None  # (h, w, 4) uint8, multiplied into the colour
    moves: bool = False
    casts_shadow: bool = True


def floor(half_size=6.0, cell=1.0, colour=(0.32, 0.34, 0.40), colour2=(0.22, 0.23, 0.28)):
    """The floor, the plane y = 0, a checkerboard ``2 half_size`` wide."""
    h = half_size
    corners = np.array([[-h, 0, -h], [h, 0, -h], [h, 0, h], [-h, 0, h]], float)
    triangles = np.stack([corners[[0, 2, 1]], corners[[0, 3, 2]]])
    return Mesh(triangles, np.tile([0.0, 1.0, 0.0], (2, 3, 1)), colour, colour2, cell,
                casts_shadow=False)


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


def mesh_vertex_data(b, i, mesh):
    """Register mesh ``i``'s vertex data (and its texture) with plan builder ``b`` the first time;
    returns (the vertex data's name, defines, inputs) of the mesh's shaders."""
    name = f"mesh {i}"
    defines = {"CHECKER": None} if mesh.colour2 is not None else {}
    inputs = {}
    if mesh.texture is not None:
        defines["TEXTURED"] = None
        inputs["u_texture"] = Ref(f"{name} texture")
    if name in b.vertices:
        return name, defines, inputs
    columns = [mesh.triangles.reshape(-1, 3), mesh.normals.reshape(-1, 3)]
    attributes = (("a_position", 3), ("a_normal", 3))
    if mesh.texture is not None:
        columns.append(mesh.uvs.reshape(-1, 2))
        attributes += (("a_uv", 2),)
        h, w = mesh.texture.shape[:2]
        # Row 0 of the upload is texture row v = 0, the bottom of the image.
        b.resource(Resource(f"{name} texture", "image", (w, h), "rgba8", linear=True,
                            data=np.ascontiguousarray(mesh.texture[::-1]),
                            what="a mesh's texture"))
    data = np.concatenate(columns, 1).astype(np.float32)
    b.vertex_data(Vertices(name, "data", len(data), data=data, attributes=attributes))
    return name, defines, inputs


def mesh_motion(mesh):
    """(defines, frame uniforms) placing ``mesh`` in ``sprites/mesh.vert``: none for a mesh in
    world coordinates; for a moving one, MOVES and ``lib/motion.glsl``'s uniforms, each frame's
    from the plan's motion (:data:`~es2particles.frame.plan.MOTION_UNIFORMS`)."""
    if not mesh.moves:
        return {}, {}
    return {"MOVES": None}, {name: ("motion", name) for name in MOTION_UNIFORMS}


def plan_meshes(b, meshes, light, target, clear, only=None, lamp=None):
    """Add a stage per mesh to plan builder ``b``: each drawn into ``target`` with depth test and
    writes, the first clearing it to ``clear`` (and its depth to 1); ``only``: the meshes'
    numbers (1-based) to draw, in that order (default all); ``lamp``: (defines, inputs,
    uniforms) of a lamp's light (``render/lamp.py``). Returns the stages' names."""
    light = tuple(float(v) for v in light)
    names = []
    for i in (only if only is not None else range(1, len(meshes) + 1)):
        mesh = meshes[i - 1]
        name, defines, inputs = mesh_vertex_data(b, i, mesh)
        uniforms = {"u_light": light, "u_colour": tuple(float(v) for v in mesh.colour)}
        if lamp is not None:
            defines, inputs = {**defines, **lamp[0]}, {**inputs, **lamp[1]}
            uniforms.update(lamp[2])
        if mesh.colour2 is not None:
            uniforms.update(u_colour2=tuple(float(v) for v in mesh.colour2),
                            u_checker=float(mesh.checker))
        moving_defines, moving = mesh_motion(mesh)
        defines = {**defines, **moving_defines}
        frame = {"u_view_projection": ("view_projection",), **moving}
        what = ", ".join(filter(None, [f"{len(mesh.triangles)} triangles",
                                       "checkered" if mesh.colour2 is not None else "",
                                       "textured" if mesh.texture is not None else "",
                                       "moves" if mesh.moves else "",
                                       "lit by the lamp through the light map" if lamp else ""]))
        b.stage(Stage(name, "mesh", "sprites/mesh.frag", "sprites/mesh.vert", defines,
                      inputs=inputs, target=Ref(target), vertices=name,
                      state=DrawState(depth_test=True), uniforms=uniforms, frame_uniforms=frame,
                      clear=clear if not names else None, what=what))
        names.append(name)
    return names


def plan_mesh_passes(b, meshes, kind, label, fragment, target, clear, what, frame=None):
    """A stage per mesh (``LABEL: mesh i``) drawing it again with ``fragment`` (``mesh.vert``
    placing it, depth test and writes) into ``target``, the first clearing it to ``clear``: the
    depth pre-pass and the light shafts' occluders. ``frame``: more frame uniforms it reads."""
    for i, mesh in enumerate(meshes, 1):
        name, _, _ = mesh_vertex_data(b, i, mesh)
        defines, moving = mesh_motion(mesh)
        frames = {"u_view_projection": ("view_projection",), **(frame or {}), **moving}
        b.stage(Stage(f"{label}: mesh {i}", kind, fragment, "sprites/mesh.vert", defines,
                      target=Ref(target), vertices=name, state=DrawState(depth_test=True),
                      frame_uniforms=frames,
                      clear=clear if i == 1 else None, what=what))
