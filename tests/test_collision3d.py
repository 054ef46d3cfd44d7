"""The 3D collision scene: its voxel field against the analytic shapes (float64), the GPU step
against the float64 twin, and the guarantees: no particle deeper than a voxel (also for a moving
object and a thin shell), no tunnelling at the largest accepted speed, no energy from contact;
meshes, compression and the command line."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from PIL import Image

from conftest import needs
from bounds import (DIVISION_ULPS, EXP_ULPS, HASH_ERROR, NORMALIZE, TRIG_ERROR, U, codec_error,
                    push_out_rescale, push_out_work)
from es2particles.gl import astc
from es2particles.cli import main
from es2particles.errors import ParameterError
from es2particles.fields.field3d import (Box, Capsule, Sphere, Torus, VoxelField, load_mesh,
                                  normal_bytes, octahedral_decode, octahedral_encode, parse_shapes)
from es2particles.scenes.field_compression import collision_errors, memory_rows
from es2particles.scenes.collision3d import Collision3D, Collision3DParams
from es2particles.frame.simulation import Simulation
from es2particles.twins.collision3d import Object, flight_random, random_tangent, step_reference
from es2particles.twins.drag import exact_drag

DATA = Path(__file__).parent / "data"
SHAPES = {"sphere": [Sphere((0, 1, 0), 1.0)], "box": [Box((0, 0.5, 0), (0.8, 0.5, 0.4))],
          "capsule": [Capsule((-1, 0.5, 0), (1, 1.2, 0.3), 0.3)],
          "torus": [Torus((0, 1, 0), 0.8, 0.25)],
          "union": [Sphere((0, 1, 0), 0.7), Box((0.8, 0.5, 0), (0.5, 0.5, 0.5))]}


def angle_degrees(a, b):
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1, 1)))


# --- the field, float64 ---------------------------------------------------------------------

@pytest.mark.parametrize("name", SHAPES)
def test_field_matches_the_analytic_shapes(name):
    field = VoxelField(SHAPES[name], 48)
    q = field.centres().reshape(-1, 3)
    exact_d, exact_n = (a.reshape(len(q), -1) for a in field.exact(q))
    exact_d = exact_d[:, 0]
    held = (exact_d > field.range[0]) & (exact_d < field.range[1])
    near = held & (np.abs(exact_d) < 3 * field.voxel)
    for encoding, distance_bound, angle_bound in (("packed", 0.001, 1.0), ("float", 1e-6, 0.05),
                                                  ("smooth", 0.5, 1.0)):
        d, n = (a.reshape(len(q), -1) for a in field.decoded(encoding))
        assert np.abs(d[:, 0] - exact_d)[held].max() < distance_bound * field.voxel, encoding
        # Where the exact normal is defined (not on a medial axis or a union's seam).
        defined = near & (np.linalg.norm(exact_n, axis=1) > 0.5)
        assert angle_degrees(n, exact_n)[defined].max() < angle_bound, encoding
    # Between centres: the nearest voxel's distance carried along its normal, within a voxel
    # of the truth near the surface (box edges and corners are the worst), far closer on average.
    rng = np.random.default_rng(0)
    p = field.lo + rng.random((100_000, 3)) * np.asarray(field.cells) * field.voxel
    sampled, _ = field.sample(p)
    truth = field.exact(p)[0]
    close = np.abs(truth) < 2 * field.voxel
    error = np.abs(sampled - truth)[close] / field.voxel
    assert error.max() < 1.1 and error.mean() < 0.02, (error.max(), error.mean())


def test_octahedral_normals_round_trip():
    rng = np.random.default_rng(1)
    n = rng.normal(size=(100_000, 3))
    n = np.concatenate([n / np.linalg.norm(n, axis=1, keepdims=True),
                        np.eye(3), -np.eye(3), [[1, 1, -1]] / np.sqrt(3)])
    assert np.abs(octahedral_decode(octahedral_encode(n)) - n).max() < 1e-6  # float32 decode
    stored = (normal_bytes(n).astype(np.float32) - 127) / np.float32(127)
    assert angle_degrees(octahedral_decode(stored), n).max() < 1.0
    # The axes are exact bytes.
    assert angle_degrees(octahedral_decode((normal_bytes(np.eye(3)) - 127) / 127.0),
                         np.eye(3)).max() < 1e-4


def test_atlas_tiles_slices_in_rows_within_the_size():
    field = VoxelField(SHAPES["box"], 48)
    nx, ny, nz = field.cells
    tw, th, columns, w, h = field.atlas_layout(256, block=(8, 5))
    assert tw % 8 == 0 and th % 5 == 0 and tw - nx < 8 and th - ny < 5 and w <= 256 and h <= 256
    atlas = field.texels("packed", 256, (8, 5))
    assert atlas.shape == (h, w, 4)
    expected = field.texels("packed", 4096)  # another layout, the same voxels
    d_small, _ = field.decoded("packed", atlas, 256, (8, 5))
    d_big, _ = field.decoded("packed", expected)
    assert np.array_equal(d_small, d_big)
    # The last slice's first voxel sits where the layout says.
    row, col = divmod(nz - 1, columns)
    assert np.array_equal(atlas[row * th, col * tw], expected_voxel(field, nz - 1))
    with pytest.raises(ParameterError, match="does not fit"):
        field.atlas_layout(16)


def expected_voxel(field, z):
    from es2particles.twins import pack

    lo, hi = field.range
    unit = np.float32((field.distance[z, 0, 0] - lo) / (hi - lo))
    return np.concatenate([pack.pack16(unit), normal_bytes(field.normal[z, 0, 0])])


def test_thin_shapes_are_refused():
    with pytest.raises(ParameterError, match="thinner than two voxels"):
        VoxelField([Box((0, 1, 0), (1.0, 0.01, 1.0))], 32)


@pytest.mark.parametrize("spec, message", [
    ("sphere:0,1,0", "sphere:CX,CY,CZ,R"), ("cube:0,1,0,1", "shape must be"),
    ("box:0,1,0,a,b,c", "box:CX"), ("sphere:0,1,0,inf", "must be finite"),
    ("missing.obj", "does not exist"), ("sphere:0,1,0,0", "must be > 0"),
    ("box:0,1,0,1,-1,1", "must be > 0")])
def test_bad_shapes_are_named(spec, message):
    with pytest.raises(ParameterError, match=message):
        parse_shapes(spec)


@pytest.mark.slow
def test_mesh_field_matches_the_sphere_it_approximates():
    """A closed mesh (an icosphere of radius 1, 320 facets) against the sphere, near the surface:
    the distance within the facets' own gap from the sphere (float64, from the file's vertices:
    the largest gap is at a facet's centre, 1 less its plane's distance from the centre), and
    the normal within the largest angle between a facet's normal and the sphere's at its corners
    (here 4.5 mean, 9.9 worst, against 10.8; through the voxel mask alone 12.7 and 37.4, and its
    distance 0.49 voxel short on average, 1.2 at worst, which these bounds fail). Beyond the
    band, the mask's distance: within a voxel. A thin open shell (a dome) is solid where its
    surface is."""
    needs("trimesh", "mesh")
    mesh = load_mesh(DATA / "icosphere.obj", centre=(0.0, 0.0, 0.0))
    field = VoxelField([mesh], 40)
    q = field.centres().reshape(-1, 3)
    sphere = Sphere((0.0, 0.0, 0.0), 1.0)  # object space: the pivot is the mesh's centre
    exact, radial = sphere.sdf(q)
    corners = mesh.vertices[mesh.faces]
    facet = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    facet /= np.linalg.norm(facet, axis=1, keepdims=True)
    gap = 1 - np.abs(np.einsum("ij,ij->i", facet, corners[:, 0])).min()
    tilt = angle_degrees(facet[:, None], corners / np.linalg.norm(corners, axis=-1,
                                                                  keepdims=True)).max()
    near = (np.abs(exact) < 2 * field.voxel)
    d, n = field.distance.reshape(-1), field.normal.reshape(-1, 3)
    error = np.abs(d - exact)[near]
    angle = angle_degrees(n, radial)[near]
    print(f"icosphere near its surface ({near.sum()} voxels): distance error max "
          f"{error.max() / field.voxel:.3f} voxel (facet gap {gap / field.voxel:.3f}); normal "
          f"error mean {angle.mean():.2f}, max {angle.max():.2f} degrees (facet tilt {tilt:.2f})")
    assert error.max() <= gap + 1e-9
    assert angle.max() <= tilt + 1e-6
    held = (exact > field.range[0]) & (exact < field.range[1])
    assert np.abs(d - exact)[held].max() < 1.0 * field.voxel
    dome = VoxelField([load_mesh(DATA / "dome.obj")], 40)
    solid = dome.distance < 0
    assert solid.any() and not solid.all()


def test_a_box_mesh_is_the_box_near_its_surface():
    """Twelve triangles of a turned box against the box's closed-form distance and normal
    (float64, in the box's own axes): exact to rounding within NEAR_VOXELS of the surface, at
    faces, edges and corners, inside and out; the sign from the pseudo-normals, not the mask."""
    from es2particles.fields.field3d import NEAR_VOXELS, TriangleMesh

    needs("trimesh", "mesh")  # TriangleMesh subdivides with it

    half = np.array([0.8, 0.5, 0.3])
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    a, b = 0.4, 0.3  # a turn about z, then about x
    turn = (np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
            @ np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]]))
    centre = np.array([0.1, 1.0, -0.2])
    mesh = TriangleMesh(signs * half @ turn.T + centre, faces, "box")
    field = VoxelField([mesh], 48)
    world = field.centres().reshape(-1, 3) + field.pivot
    local = (world - centre) @ turn  # the box's own axes
    exact, normal = Box((0.0, 0.0, 0.0), tuple(half)).sdf(local)
    normal = normal @ turn.T
    band = np.abs(exact) <= NEAR_VOXELS * field.voxel - field.voxel  # surely in the band
    d, n = field.distance.reshape(-1)[band], field.normal.reshape(-1, 3)[band]
    print(f"box: {band.sum()} voxels in the band, distance error max "
          f"{np.abs(d - exact[band]).max():.2e}, normal error max "
          f"{angle_degrees(n, normal[band]).max():.2e} degrees")
    assert np.abs(d - exact[band]).max() <= 1e-12
    assert angle_degrees(n, normal[band]).max() <= 1e-5


# --- the GPU step against the float64 twin --------------------------------------------------

def _uv(sim):
    w, h = sim.layout.width, sim.layout.height
    i = np.arange(sim.count)
    return np.column_stack([(i % w + 0.5) / w, (i // w + 0.5) / h]), (w, h)


def _scatter(sim, rng, speed=3.0):
    n = sim.count
    x = np.column_stack([rng.uniform(-1.5, 1.5, n), rng.uniform(0.05, 3.0, n),
                         rng.uniform(-1.5, 1.5, n)])
    sim.upload("position", x)
    sim.upload("velocity", rng.uniform(-speed, speed, (n, 3)))
    sim.upload("life", np.tile([1.0, 300.0], (n, 1)))


# The float64 step with each particle's float32 error bound: step_with_bound() is
# twins/collision3d.py's step_reference line for line in float64 (the test verifies that the two
# agree to the bit), carrying beside each particle a bound, per component, on how far the
# shader's float32 computation of it can be: each operation's rounding, GLSL's precision of exp,
# division, sqrt and normalize, the built-in sin and cos of the object's pose within TRIG_ERROR
# (tests/test_smoke.py asserts it for them), the errors in flight carried through each
# operation's local derivative (a push-out keeps a position error's part across the normal; a
# direction turns by the error across it over its length), and where float32 may take the other
# side of a branch (a contact, the turn, head-on or not, the thin-wall side, the floor, the
# field's voxel, the sub-step count) the other branch's outcome. As tests/test_collision.py's,
# in 3D, with the object's pose.


def _norm(a):
    return np.linalg.norm(a, axis=-1)


def _dot(u, e):
    """Bound of |u . delta| for |delta_i| <= e_i."""
    return np.sum(np.abs(u) * e, axis=-1)


def _across(n, e):
    """Bound of each component of (I - n n^T) delta for |delta_i| <= e_i (n unit)."""
    projector = np.eye(3) - n[:, :, None] * n[:, None, :]
    return np.einsum("nij,nj->ni", np.abs(projector), e)


def _pick(outcomes, chosen, possible):
    """Merge branch outcomes ((x, v, ex, ev) each): outcome k where the float64 step takes it
    (``chosen[k]``); where the GPU may take outcome k instead (``possible[k]``), the bound grows
    to k's own plus its distance from the chosen one."""
    merged = [sum(np.where(c[:, None], o[k], 0.0) for o, c in zip(outcomes, chosen))
              for k in range(4)]
    x, v, ex, ev = merged
    for (xk, vk, exk, evk), may in zip(outcomes, possible):
        ex = np.where(may[:, None], np.maximum(ex, exk + np.abs(xk - x)), ex)
        ev = np.where(may[:, None], np.maximum(ev, evk + np.abs(vk - v)), ev)
    return x, v, ex, ev


def _respond(state, a, ea, d, ed, n, en, p, turn, moved, e_moved):
    """respond() of twins/collision3d.py for a contact at every particle, with its bound. The
    depth d errs by n . (the position's error) + ``ed``; ``en``: the normal's error per
    component; ``turn``: the random tangent's (a hash, not bit-exact: within HASH_ERROR);
    ``moved``: the sub-step's move along n, within ``e_moved``."""
    x, v, ex, ev = state
    r, s = p.bounce, p.sliding
    with np.errstate(divide="ignore", invalid="ignore"):
        vn = np.sum(v * n, axis=1)
        speed = _norm(v)
        along = v - vn[:, None] * n
        along_len = _norm(along)
        has_tangent = along_len > 1e-6 * speed
        random = random_tangent(n, turn)
        t = np.where(has_tangent[:, None], along / np.where(has_tangent, along_len, 1)[:, None],
                     random)
        new_v = speed[:, None] * (n * s + t * (1 - s)) * r
        products = np.sum(np.abs(v * n), axis=1)
        e_n = _norm(en)
        e_vn = _dot(n, ev) + _dot(v, en) + 3 * U * products
        e_speed = np.where(speed > 0, _dot(v, ev) / speed, _norm(ev)) + 3 * U * speed
        # along = (I - n n^T) v: v's error by its part across n; the normal's error and
        # float32's rounding (off the plane too)
        off_plane = (speed + np.abs(vn)) * e_n + 3 * U * products + U * np.abs(vn)
        e_along = _across(n, ev) + np.abs(n) * off_plane[:, None] + U * np.abs(along)
        # t = along / |along| turns by along's error across t over |along|; it may point
        # anywhere if |along| is within the error of 0
        e_t = np.minimum(2, _across(t, e_along) / along_len[:, None]) \
            + 2 * DIVISION_ULPS * U * np.abs(t)
        e_t = np.where((along_len <= _norm(e_along))[:, None], 2.0, e_t)
        # head-on: random_tangent(n, turn): the turn's angle 2 pi turn off by 2 pi HASH_ERROR
        # (and its roundings), the side normalize(n x up) by the normal's error over |n x up|
        # (any way where float32 may pick the other up, |n.y| within e_n of 0.99)
        side = np.sqrt(np.maximum(1 - np.where(np.abs(n[:, 1]) < 0.99, n[:, 1], n[:, 0]) ** 2,
                                  1e-12))
        e_random = 2 * np.pi * (HASH_ERROR + 2 * U) + 2 * e_n / side + 12 * U
        e_random = np.where(np.abs(np.abs(n[:, 1]) - 0.99) <= np.abs(en[:, 1]) + 2 * U, 2.0,
                            np.minimum(2, e_random))
        e_t = np.where(has_tangent[:, None], e_t, e_random[:, None])
        m = n * s + t * (1 - s)
        e_m = s * en + (1 - s) * e_t + U * (np.abs(n) * s + np.abs(t) * (1 - s) + np.abs(m))
        e_new = r * (e_speed[:, None] * np.abs(m) + speed[:, None] * e_m) \
            + 3 * U * r * speed[:, None] * np.abs(m)
        headon_unsure = np.abs(along_len - 1e-6 * speed) <= _norm(e_along) + 1e-6 * e_speed
        e_new = e_new + np.where(headon_unsure, 2 * r * speed * (1 - s), 0)[:, None]
        turn_ = vn < 0
        turned = np.where(turn_[:, None], new_v, v)
        e_turned = np.where(turn_[:, None], e_new, ev)
        turn_unsure = (np.abs(vn) <= e_vn)[:, None]
        e_turned = np.where(turn_unsure, np.maximum(e_new, ev) + np.abs(new_v - v), e_turned)
        out = x - d[:, None] * n
        e_out = (_across(n, ex) + np.abs(n) * ed[:, None] + np.abs(d)[:, None] * en
                 + U * (np.abs(d[:, None] * n) + np.abs(out)))
        # v * sqrt(max(v2 - work, 0) / v2): sqrt(max(v2 - work, 0)) along v
        v2 = np.sum(turned * turned, axis=1)
        an = n @ a
        e_v2 = 2 * _dot(turned, e_turned) + _norm(e_turned) ** 2 + 3 * U * v2
        e_an = _dot(n, ea) + _dot(a, en) + 3 * U * np.sum(np.abs(a * n), axis=1)
        e_depth = _dot(n, ex) + ed
        work, e_work = push_out_work(turn_, turn_unsure[:, 0], vn, e_vn, d, e_depth, an, e_an,
                                     moved, e_moved, speed, e_speed, v2, e_v2)
        rescaled, e_rescaled = push_out_rescale(
            turned, v2, e_v2, work, e_work,
            lambda u: np.minimum(2, _across(u, e_turned) / np.sqrt(v2)[:, None]))
    return out, rescaled, e_out, e_rescaled


def _respond_where(mask, state, a, ea, d, ed, n, en, p, turn, moved, e_moved):
    """_respond for the particles of ``mask`` (the others keep their state: never taken)."""
    out = [np.array(part) for part in state]
    if mask.any():
        picked = _respond([part[mask] for part in state], a, ea, d[mask], ed[mask], n[mask],
                          en[mask], p, turn[mask], moved[mask], e_moved[mask])
        for whole, part in zip(out, picked):
            whole[mask] = part
    return out


def _pose_bound(p, field, t, e_t):
    """The object's pose at time t (twin Object.at) and the bounds of the shader's: its centre,
    velocity (per component) and angle; ``e_t``: the time's error."""
    obj = Object(field, p)
    centre, rot, velocity = obj.at(t)
    amplitude, period = np.abs(np.asarray(p.sway[:3], float)), p.sway[3]
    angle = p.spin_rate * t
    e_angle = 2 * U * abs(angle) + abs(p.spin_rate) * e_t
    e_centre = 2 * U * np.abs(centre)
    e_velocity = 2 * U * np.abs(velocity)
    if period > 0:
        w = 2 * np.pi / period
        e_argument = 8 * U * abs(w * t) + w * e_t  # w = TAU / period, times t
        e_centre = e_centre + amplitude * (TRIG_ERROR + e_argument)
        e_velocity = e_velocity + amplitude * w * (TRIG_ERROR + e_argument + 6 * U)
    return (centre, rot, velocity), (e_centre, e_velocity, e_angle)


def _to_object(obj, x, ex, pose, e_pose):
    """to_object (R^T (x - c) / s) with the bound of the pose's part and the position's part
    of its error: (q, e_q from the pose, e_q from x)."""
    centre, rot, _ = pose
    e_centre, _, e_angle = e_pose
    q = obj.to_object(x, pose)
    offset = _norm(x - centre)
    # rotate(x - c, k, -angle): the built-in cos and sin within TRIG_ERROR, the angle's error,
    # a dozen roundings of |x - c|; then / s
    from_pose = (np.abs(rot.T) @ e_centre + (offset * (e_angle + 3 * TRIG_ERROR + 12 * U))[:, None]
                 ) / obj.p.scale + 2 * U * np.abs(q)
    from_x = (np.abs(rot.T) @ ex.T).T / obj.p.scale
    return q, from_pose, from_x


def _sample(field, q, i, decoded):
    """VoxelField.sample at object points q from voxels i (n, 3) (a neighbour's too)."""
    d, n = decoded
    normal = n[i[:, 2], i[:, 1], i[:, 0]].astype(np.float64)
    centre = field.lo + (i + 0.5) * field.voxel
    return d[i[:, 2], i[:, 1], i[:, 0]] + np.sum(normal * (q - centre), axis=-1), normal, centre


def _collide(state, a, ea, q_before, e_before, obj, pose, e_pose, p, turn, decoded, x_before,
             ex_before):
    """collide() of twins/collision3d.py with its bound."""
    field = obj.field
    x, v, ex, ev = state
    centre, rot, velocity = pose
    e_centre, e_velocity, e_angle = e_pose
    q, q_pose, q_x = _to_object(obj, x, ex, pose, e_pose)
    d, n = field.sample(q, decoded)
    cells = np.asarray(field.cells)
    cell = np.floor((q - field.lo) / field.voxel)
    inside = np.all((cell >= 0) & (cell < cells), axis=-1)
    i = np.clip(cell, 0, cells - 1).astype(int)
    d_check, n_check, voxel_centre = _sample(field, q, i, decoded)
    assert np.array_equal(np.where(inside, d_check, field.range[1]), d) \
        and np.array_equal(n_check, n)
    d = d.astype(np.float64)
    lo, hi = field.range
    # object units: the voxel's decode (a driver may fuse it), the normal's decode (normalize),
    # the centre's and the dot's roundings; the pose's part of q's error along n
    e_n = NORMALIZE * np.abs(n) + 4 * U
    e_d = (codec_error(lo, hi) + _dot(q - voxel_centre, e_n) + 4 * U * _norm(voxel_centre)
           + 3 * U * _norm(q - voxel_centre) + U * np.abs(d) + _dot(n, q_pose))
    # the voxel: floor((q - lo) / voxel) in float32 may be a neighbour near a face
    e_cell = (q_pose + q_x) / field.voxel + 4 * U * np.abs(cell)
    where = (q - field.lo) / field.voxel
    for axis in range(3):
        edge = np.round(where[:, axis])
        unsure = inside & (np.abs(where[:, axis] - edge) <= e_cell[:, axis]) & (edge >= 1) \
            & (edge <= cells[axis] - 1)
        if unsure.any():
            other = i.copy()
            other[:, axis] = np.where(unsure, np.where(where[:, axis] >= edge, edge - 1, edge),
                                      i[:, axis])
            d_other, n_other, _ = _sample(field, q, other, decoded)
            e_d = e_d + np.where(unsure, np.abs(d_other - d), 0)
            e_n = e_n + np.where(unsure[:, None], np.abs(n_other - n), 0)
    e_depth = _dot(n, q_x) + e_d
    moved = q - q_before
    mn = np.sum(moved * n, axis=1)
    e_moved = _dot(n, e_before) + _dot(moved, e_n) + 3 * U * _norm(moved) + _dot(n, q_pose)
    e_mn = _dot(n, q_x) + e_moved
    # the surface where it came from: the normal of q_before's voxel (a neighbour's where
    # q_before's error reaches a face of it), against this one
    _, came_from = field.sample(q_before, decoded)
    facing = np.sum(came_from * n, axis=1)
    e_facing = _dot(came_from, e_n) + _dot(n, NORMALIZE * np.abs(came_from) + 4 * U) \
        + 3 * U * np.abs(facing)
    cell_before = np.floor((q_before - field.lo) / field.voxel)
    where_before = (q_before - field.lo) / field.voxel
    e_cell_before = e_before / field.voxel + 4 * U * np.abs(cell_before)
    i_before = np.clip(cell_before, 0, cells - 1).astype(int)
    for axis in range(3):
        edge = np.round(where_before[:, axis])
        unsure = (np.abs(where_before[:, axis] - edge) <= e_cell_before[:, axis]) \
            & (edge >= 1) & (edge <= cells[axis] - 1)
        if unsure.any():
            other = i_before.copy()
            other[:, axis] = np.where(unsure, np.where(where_before[:, axis] >= edge, edge - 1,
                                                       edge), i_before[:, axis])
            _, n_other, _ = _sample(field, q_before, other, decoded)
            e_facing = e_facing + np.where(unsure, np.abs(np.sum(n_other * n, axis=1) - facing),
                                           0)
    voxel = field.voxel
    contact = d < 0
    back = contact & (mn > 0) & (facing < 0) & (d > -2 * voxel) & (d < -0.25 * voxel)
    may_contact = d < e_depth
    may_back = may_contact & (mn > -e_mn) & (facing < e_facing) \
        & (d > -2 * voxel - e_depth) & (d < -0.25 * voxel + e_depth)
    may_plain = may_contact & ((mn <= e_mn) | (facing >= -e_facing)
                               | (d <= -2 * voxel + e_depth) | (d >= -0.25 * voxel - e_depth))
    # in the world: the depth times the scale, the normal turned by the pose (its rotation's
    # error), the relative velocity against the surface's (the pose's velocity and spin)
    scale = p.scale
    world = n @ rot.T
    e_world = (np.abs(rot) @ e_n.T).T + (e_angle + 3 * TRIG_ERROR + 12 * U)
    arm = x - centre
    surface = velocity + np.cross(p.spin_axis * p.spin_rate, arm)
    spin = abs(p.spin_rate) * (_norm(ex + e_centre) + 3 * U * _norm(arm))
    e_surface = e_velocity + spin[:, None] + U * np.abs(surface)
    relative = v - surface
    e_relative = ev + e_surface + U * np.abs(relative)
    moving = (x, relative, ex, e_relative)
    e_mn_world = e_mn * scale + 2 * U * np.abs(mn * scale)
    plain = _respond_where(may_contact, moving, a, ea, d * scale,
                           e_d * scale + U * np.abs(d * scale), world, e_world, p, turn,
                           mn * scale, e_mn_world)
    flipped = _respond_where(may_contact, moving, a, ea, -mn * scale,
                             e_moved * scale + U * np.abs(mn * scale), -world, e_world, p, turn,
                             -mn * scale, e_mn_world)
    outcomes = []
    for xo, ro, exo, ero in (plain, flipped):
        vo = ro + surface
        outcomes.append((xo, vo, exo, ero + e_surface + U * np.abs(vo)))
    apart = (x, relative + surface, ex, ev)  # the twin's v - surface + surface, as it is
    state = _pick([apart, *outcomes], [~contact, contact & ~back, back],
                  [d >= -e_depth, may_plain, may_back])
    # the floor, y = 0: an exact plane
    x, v, ex, ev = state
    up = np.tile([0.0, 1.0, 0.0], (len(x), 1))
    near = x[:, 1] < ex[:, 1]
    rise = x[:, 1] - x_before[:, 1]
    floor = _respond_where(near, state, a, ea, x[:, 1], np.zeros(len(x)), up, np.zeros_like(x),
                           p, turn, rise, ex[:, 1] + ex_before[:, 1] + U * np.abs(rise))
    return _pick([state, floor], [x[:, 1] >= 0, x[:, 1] < 0], [x[:, 1] >= -ex[:, 1], near])


def step_with_bound(x, v, field, p, step, substep, surface_speed, random, decoded,
                    max_substeps, counts=None):
    """step_reference's float64 step (rgba32f state: read exactly) with each particle's bound
    (n, 3) on the float32 GPU's distance from it; ``counts``: sub-step counts to use instead of
    the particles' own. Returns (x, v, ex, ev, unsure count, the other count)."""
    x, v = np.array(x, np.float64), np.array(v, np.float64)
    r = np.asarray(random, np.float64)
    ex, ev = np.zeros_like(x), np.zeros_like(v)
    if p.jitter:  # the kick's hash is within HASH_ERROR of numpy's
        v = v + p.jitter * np.sqrt(p.dt) * (2 * r[:, 1:] - 1)
        ev = ev + p.jitter * np.sqrt(p.dt) * 2 * HASH_ERROR + 4 * U * np.abs(v)
    a = p.acceleration
    ea = U * np.abs(a)
    reach = (np.linalg.norm(v, axis=1) + np.linalg.norm(a) * p.dt + surface_speed) * p.dt
    q_count = reach / substep
    n = np.clip(np.ceil(q_count), 1, max_substeps)
    e_count = ((_norm(ev) + 3 * U * (_norm(v) + _norm(a) * p.dt + surface_speed)) * p.dt
               + 2 * U * reach) / substep + 3 * U * q_count
    whole = np.round(q_count)
    unsure = (np.abs(q_count - whole) <= e_count) & (whole >= 1) & (whole < max_substeps)
    other = np.where(np.ceil(q_count) == whole, whole + 1, whole)
    if counts is not None:
        n = counts
    h = p.dt / n
    decay, gain = exact_drag(p.drag, h)
    k, kh = p.drag, p.drag * h
    e_h = (1 + 2 * DIVISION_ULPS) * U * h
    e_kh = 3 * U * kh + k * e_h
    e_decay = decay * e_kh + 2 * (EXP_ULPS + 2 * kh) * U * decay
    e_small = e_h + 0.5 * h * e_kh + 3 * U * h
    with np.errstate(divide="ignore"):
        e_large = (e_decay / k if k > 0 else np.inf) + (2 + 2 * DIVISION_ULPS) * U * gain
    e_gain = np.where(kh < 1e-3, e_small, e_large)
    e_gain = np.where(np.abs(kh - 1e-3) <= e_kh, np.maximum(e_small, e_large) + h * kh ** 2 / 6,
                      e_gain)
    obj = Object(field, p)
    t0 = step * p.dt
    pose, e_pose = _pose_bound(p, field, t0, 2 * U * t0)
    q_before, q_pose, q_x = _to_object(obj, x, ex, pose, e_pose)
    e_before = q_pose + q_x
    for i in range(int(n.max()) if len(n) else 0):
        active = np.flatnonzero(i < n)
        pose_t = t0 + (i + 1) * h[active]
        for t in np.unique(pose_t):  # particles of one sub-step length share the pose
            j = active[pose_t == t]  # (each group reads and writes its own particles only)
            pose, e_pose = _pose_bound(p, field, t, 4 * U * t + (i + 1) * e_h[j[0]])
            dm, gm = decay[j][:, None], gain[j][:, None]
            vm = np.clip(v[j] * dm + a * gm, -p.max_speed, p.max_speed)
            evm = (ev[j] * dm + np.abs(v[j]) * e_decay[j][:, None] + U * np.abs(v[j]) * dm
                   + np.abs(a) * e_gain[j][:, None] + gm * ea + U * np.abs(a) * gm
                   + U * np.abs(vm))
            xm = x[j] + vm * h[j][:, None]
            exm = ex[j] + evm * h[j][:, None] + np.abs(vm) * e_h[j][:, None] \
                + U * (np.abs(vm) * h[j][:, None] + np.abs(xm))
            xm, vm, exm, evm = _collide((xm, vm, exm, evm), a, ea, q_before[j], e_before[j],
                                        obj, pose, e_pose, p, r[j, 0], decoded, x[j], ex[j])
            x[j], v[j], ex[j], ev[j] = xm, np.clip(vm, -p.max_speed, p.max_speed), exm, evm
            q_before[j], q_pose, q_x = _to_object(obj, xm, exm, pose, e_pose)
            e_before[j] = q_pose + q_x
    return x, v, ex, ev, unsure, other


def _ratio(error, bound):
    """error / bound, 0 where both are 0 (a component float32 computes exactly)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(bound > 0, error / bound, np.where(error > 0, np.inf, 0.0))


@pytest.mark.parametrize("shape, changes, field_format", [
    ("sphere:0,1,0,1", {}, "rgba8"),
    ("box:0,1,0,0.8,0.3,0.5", {"spin": (60.0, 0.3, 0.2, 1.0)}, "rgba32f"),
    ("torus:0,1,0,0.8,0.25", {"sway": (0.3, 0.2, 0.0, 2.0)}, "rgba8"),
    ("capsule:-0.6,1,0,0.6,1.2,0,0.4", {}, "rgba16f")])
def test_gpu_step_matches_the_float64_twin(gl, shape, changes, field_format):
    """Step by step from the GPU's own state (rgba32f: read exactly): the same particle under
    float32 and float64, every particle's every component within its own bound (step_with_bound);
    where the float32 sub-step count may be the other whole number, within the bound of either.
    The kick in flight is left out (jitter 0); the head-on contacts' random tangent turns by the
    hash's GPU-against-twin difference, HASH_ERROR."""
    p = Collision3DParams(**{"jitter": 0.0, "lifetime": (400.0, 400.0), **changes})
    scene = Collision3D(p.changed(shape=shape, field_format=field_format))
    sim = Simulation(gl, scene.graph(), 4096, fmt="rgba32f")
    worst = 0.0
    try:
        _scatter(sim, np.random.default_rng(3))
        uv, size = _uv(sim)
        decoded = scene.field.decoded({"rgba32f": "float", "rgba16f": "half"}.get(field_format,
                                                                                  "packed"))
        for step in range(25):
            x0, v0 = sim.download("position"), sim.download("velocity")
            sim.step()
            x1, v1 = sim.download("position"), sim.download("velocity")
            random = flight_random(uv, step, size)
            fixed = (scene.substep, scene.surface_speed)
            xr, vr, ex, ev, unsure, other = step_with_bound(
                x0, v0, scene.field, p, step, *fixed, random, decoded, scene.max_substeps)
            if step == 0:  # the same float64 step as the twin's, to the bit
                twin_x, twin_v = step_reference(x0, v0, scene.field, p, step, *fixed, random,
                                                decoded, scene.max_substeps)
                assert np.array_equal(twin_x, xr) and np.array_equal(twin_v, vr)
            error_x, error_v = np.abs(x1 - xr), np.abs(v1 - vr)
            ratio = np.maximum(_ratio(error_x, ex), _ratio(error_v, ev)).max(axis=1)
            if unsure.any():  # the other sub-step count's step, where it is the nearer
                i = np.flatnonzero(unsure)
                ax, av, aex, aev, _, _ = step_with_bound(
                    x0[i], v0[i], scene.field, p, step, *fixed, random[i], decoded,
                    scene.max_substeps, counts=other[i])
                other_ratio = np.maximum(_ratio(np.abs(x1[i] - ax), aex),
                                         _ratio(np.abs(v1[i] - av), aev))
                ratio[i] = np.minimum(ratio[i], other_ratio.max(axis=1))
            k = np.argmax(ratio)
            assert ratio[k] <= 1, (
                f"step {step}: particle {k} errs by {error_x[k]} m, {error_v[k]} m/s > its bound "
                f"{ex[k]} m, {ev[k]} m/s (float32 through the sub-steps and contacts)")
            worst = max(worst, ratio.max())
    finally:
        sim.release()
    print(f"{shape}: largest error/bound over 25 steps {worst:.3f}")


def test_flight_randomness_is_a_uniform_kick(gl):
    """Free particles (no gravity, friction or object near) get a kick uniform in
    +-jitter sqrt(dt) per component: mean 0, variance (jitter^2 dt) / 3, independent axes."""
    p = Collision3DParams(jitter=2.0, gravity=(0.0, 0.0, 0.0), viscosity=0.0, lifetime=(400.0, 400.0))
    scene = Collision3D(p.changed(shape="sphere:0,1,0,0.3"))
    sim = Simulation(gl, scene.graph(), 2 ** 14, fmt="rgba32f")
    try:
        n = sim.count
        sim.upload("position", np.tile([2.5, 5.0, 2.5], (n, 1)))
        sim.upload("velocity", np.zeros((n, 3)))
        sim.upload("life", np.tile([1.0, 300.0], (n, 1)))
        sim.step()
        kick = sim.download("velocity") / (p.jitter * np.sqrt(p.dt))
    finally:
        sim.release()
    assert np.all(np.abs(kick) <= 1 + 1e-5)
    sigma = np.sqrt(1 / 3 / n)  # of a mean of n uniform(-1, 1) numbers
    assert np.all(np.abs(kick.mean(axis=0)) < 5 * sigma)
    assert np.allclose(kick.var(axis=0), 1 / 3, atol=0.02)
    assert np.abs(np.corrcoef(kick.T) - np.eye(3)).max() < 0.05


# --- guarantees ---------------------------------------------------------------------------

def _depths(scene, x, step):
    """Depth inside the exact shapes (positive inside) of world points after ``step`` steps."""
    obj = Object(scene.field, scene.params)
    q = obj.to_object(x, obj.at(step * scene.params.dt))
    return -scene.field.exact(q)[0] * scene.params.scale


@pytest.mark.parametrize("shape, changes", [
    ("sphere:0,1,0,1", {}),
    ("box:0,1.2,0,1.2,0.3,0.6", {"spin": (90.0, 0.0, 0.0, 1.0)}),
    ("capsule:-1,1.2,0,1,1.6,0,0.35+sphere:0,0.8,0,0.5", {"sway": (0.4, 0.3, 0.0, 1.5),
                                                         "spin": (40.0, 0.0, 1.0, 0.0)})])
def test_no_particle_deeper_than_a_voxel(gl, shape, changes):
    """The default RGBA8 state, emission and all: after every step, no living particle lies
    deeper than one voxel inside the object, still or moving."""
    scene = Collision3D(Collision3DParams(shape=shape, **changes))
    sim = Simulation(gl, scene.graph(), 4096, fmt="rgba8", rounding="dither")
    try:
        scene.initialise(sim, np.random.default_rng(0))
        deepest = 0.0
        for step in range(240):
            sim.step()
            if step % 4 == 3:
                life = sim.download("life")
                alive = (life[:, 0] >= 0) & (life[:, 0] < life[:, 1])
                depth = _depths(scene, sim.download("position")[alive], step + 1)
                deepest = max(deepest, depth.max() / (scene.field.voxel * scene.params.scale))
        assert deepest < 1.0, deepest
    finally:
        sim.release()


FASTEST_SPIN = Collision3DParams.declarations()["spin"].hi[0]  # the largest --spin accepted


@pytest.mark.parametrize("shape, axis", [
    ("box:0,1.2,0,0.8,0.3,0.5", (0.0, 1.0, 0.0)),
    ("box:0,1.2,0,0.8,0.3,0.5", (1.0, 0.0, 0.0)),
    ("box:0,2.5,0,1.5,0.06,1.5", (0.3, 0.2, 1.0)),
    ("sphere:0,1.5,0,1+box:0,1.5,0,1.2,0.2,0.2", (0.0, 1.0, 0.0))])
def test_no_particle_deeper_than_a_voxel_at_the_fastest_spin(gl, shape, axis):
    """The object at the largest spin the command accepts, with particles at the velocity
    range's bound aimed at it from every side, arriving over the run: after every step, no
    particle lies deeper than one voxel inside the exact shapes (float64, not the field). The
    face leading the spin pushes particles round its edges, where they once took the turned-round
    rule for a thin wall's and were put deeper (the issue's box about y: 433-597
    particle-steps)."""
    p = Collision3DParams(shape=shape, spin=(FASTEST_SPIN, *axis), jitter=0.0,
                          lifetime=(400.0, 400.0))
    scene = Collision3D(p)
    sim = Simulation(gl, scene.graph(), 4096, fmt="rgba8", rounding="dither")
    field, p = scene.field, scene.params
    lo, hi = field.bounds
    centre, reach = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2 * p.scale
    try:
        rng = np.random.default_rng(11)
        n = sim.count
        way = rng.normal(size=(n, 3))
        way /= np.linalg.norm(way, axis=1, keepdims=True)
        # From just outside the turning object's sphere to 2 m further: arrivals over 12 steps.
        x = centre + way * (reach + rng.uniform(0.05, 2.0, n))[:, None]
        x[:, 1] = np.maximum(x[:, 1], 0.05)
        sim.upload("position", x)
        sim.upload("velocity", np.clip(-way * p.max_speed, -p.max_speed, p.max_speed))
        sim.upload("life", np.tile([1.0, 300.0], (n, 1)))
        deep, deepest = 0, 0.0
        for step in range(16):
            sim.step()
            depth = _depths(scene, sim.download("position"), step + 1) / (field.voxel * p.scale)
            deep += int(np.count_nonzero(depth > 1.0))
            deepest = max(deepest, float(depth.max()))
        assert deep == 0, f"{deep} particle-steps deeper than a voxel, the deepest {deepest:.2f}"
    finally:
        sim.release()


def _on_the_sphere(gl, shape, seed, count=2 ** 14, steps=240):
    """(on it, within a voxel of its top, at rest on it, median speed on it) after ``steps`` of
    the scene's stream onto ``shape`` (a unit sphere at 0,1,0, analytic or a mesh of it)."""
    scene = Collision3D(shape=shape)
    with Simulation(gl, scene.graph(), count, fmt="rgba8", rounding="dither") as sim:
        scene.initialise(sim, np.random.default_rng(seed))
        sim.run(steps)
        x, v = sim.download("position"), sim.download("velocity")
    voxel = scene.field.voxel
    on = np.abs(np.linalg.norm(x - [0.0, 1.0, 0.0], axis=1) - 1) < 2 * voxel
    speed = np.linalg.norm(v[on], axis=1)
    return (int(on.sum()), int(np.count_nonzero(on & (x[:, 1] > 2 - voxel))),
            int(np.count_nonzero(speed < 1e-3)), float(np.median(speed)))


@pytest.mark.slow
def test_a_mesh_of_the_sphere_behaves_as_the_sphere(gl, tmp_path):
    """The stream onto a fine icosphere mesh (5,120 facets, written here by trimesh) and onto the
    analytic sphere, two seeds each: the particles on it, those within a voxel of its top and
    their median speed differ between the shapes by no more than between the seeds of one shape.
    Measured: sphere 5964/5889 on, 823/777 on top, 0.30/0.23 m/s; the mesh 5998/5923, 837/796,
    0.29/0.26. Through the voxel mask alone the tests' coarser icosphere (320 facets) held 9,120
    on it, 2,281 on top, 11% at rest and a median of 0.06 m/s; with its triangles, 6,234, 978,
    0.4% and 0.62 m/s, the rest its facets' (the finer mesh is the sphere)."""
    trimesh = needs("trimesh", "mesh")
    mesh = tmp_path / "icosphere4.obj"
    trimesh.creation.icosphere(subdivisions=4, radius=1.0).export(mesh)
    runs = {name: [_on_the_sphere(gl, shape, seed) for seed in (1, 2)]
            for name, shape in (("sphere", "sphere:0,1,0,1"), ("mesh", str(mesh)))}
    print(runs)
    for k, what in ((0, "on it"), (1, "on its top"), (3, "median speed")):
        a, b = (np.array([run[k] for run in runs[name]], float) for name in ("sphere", "mesh"))
        spread = max(np.ptp(a), np.ptp(b))
        assert abs(a.mean() - b.mean()) <= spread, \
            f"{what}: sphere {a}, mesh {b}, more apart than two seeds ({spread:g})"
    resting = [run[2] / run[0] for run in runs["mesh"]]
    assert max(resting) < 0.02, f"the mesh holds {resting} of its particles at rest"


def test_thin_shell_does_not_leak(gl):
    """An open dome (a mesh one voxel thick in the field) under the stream: no particle gets from
    outside the shell to inside its cavity within a step."""
    needs("trimesh", "mesh")
    scene = Collision3D(shape=str(DATA / "dome.obj"), jitter=0.5, field_resolution=40)
    sim = Simulation(gl, scene.graph(), 4096, fmt="rgba8", rounding="dither")
    centre = np.array([0.0, 0.5, 0.0])  # the dome's sphere: radius 1, rim at y = 0.5
    try:
        scene.initialise(sim, np.random.default_rng(0))
        before = None
        crossed = 0
        for _ in range(200):
            sim.step()
            x = sim.download("position")
            r = np.linalg.norm(x - centre, axis=1)
            inside = (r < 1 - 2 * scene.field.voxel) & (x[:, 1] > 0.6)
            outside = (r > 1 + scene.field.voxel) & (x[:, 1] > 0.6)
            if before is not None:
                crossed += int(np.count_nonzero(before & inside))
            before = outside
        assert crossed == 0
    finally:
        sim.release()


def test_throws_at_a_one_voxel_shell_stay_out_by_the_side_of_entry(gl):
    """Particles thrown at the open dome (one voxel thick in the field) from a voxel outside it,
    at 3 to 8 m/s (a step of 0.8 to 2.1 voxels, in sub-steps of at most half a voxel): inside a
    wall that thin a sub-step can end nearer the far face, whose normal points on into the
    cavity; the side-of-entry rule turns such a particle back the way it came. 1 throw in 16384
    got through here (the field is irregular at some of the mesh's facets); without the rule, 59.
    The bound: 1 in 1000."""
    needs("trimesh", "mesh")
    p = Collision3DParams(gravity=(0.0, 0.0, 0.0), jitter=0.0, viscosity=0.0, bounce=1.0,
                          lifetime=(400.0, 400.0))
    scene = Collision3D(p.changed(shape=str(DATA / "dome.obj"), field_resolution=40))
    voxel, centre = scene.field.voxel, np.array([0.0, 0.5, 0.0])  # rim at y = 0.5
    sim = Simulation(gl, scene.graph(), 4096, fmt="rgba32f")
    try:
        n = sim.count
        toward = np.random.default_rng(1).normal(size=(n, 3))
        toward[:, 1] = np.abs(toward[:, 1]) + 0.8  # the cap, above the rim
        toward /= np.linalg.norm(toward, axis=1)[:, None]
        through = 0
        for speed in (3.0, 4.0, 6.0, 8.0):
            sim.upload("position", centre + toward * (1 + voxel))
            sim.upload("velocity", -toward * speed)
            sim.upload("life", np.tile([1.0, 300.0], (n, 1)))
            sim.step()
            r = np.linalg.norm(sim.download("position") - centre, axis=1)
            through += int(np.count_nonzero(r < 1 - voxel))
        assert through <= 4 * n // 1000, f"{through} of {4 * n} throws got into the cavity"
    finally:
        sim.release()


def test_no_tunnelling_at_the_largest_speed(gl):
    """Particles at the largest speed the velocity range holds, in steps far longer than the
    plate is thick (0.6 m a step against 2 voxels), all stay on their side of it."""
    p = Collision3DParams(dt=0.05, gravity=(0.0, 0.0, 0.0), jitter=0.0, viscosity=0.0, bounce=1.0,
                  lifetime=(400.0, 400.0))
    scene = Collision3D(p.changed(shape="box:0,1,0,1.5,0.06,1.5", field_resolution=64))
    assert 2 * 0.06 < 0.6 * scene.params.dt * 20
    sim = Simulation(gl, scene.graph(), 4096, fmt="rgba32f")
    try:
        rng = np.random.default_rng(5)
        n = sim.count
        x = np.column_stack([rng.uniform(-1, 1, n), rng.uniform(1.3, 1.9, n), rng.uniform(-1, 1, n)])
        v = np.column_stack([rng.choice([-12.0, 0.0, 12.0], n), np.full(n, -12.0),
                             rng.choice([-12.0, 0.0, 12.0], n)])
        sim.upload("position", x)
        sim.upload("velocity", v)
        sim.upload("life", np.tile([1.0, 300.0], (n, 1)))
        sim.step()
        x1 = sim.download("position")
        over_plate = (np.abs(x1[:, 0]) < 1.5) & (np.abs(x1[:, 2]) < 1.5)
        assert np.all(x1[over_plate, 1] > 1.0), np.sort(x1[over_plate, 1])[:5]
    finally:
        sim.release()


def test_contact_gives_no_energy(gl):
    """Dropped at rest on the sphere and the floor, with no friction or randomness: no
    particle's energy v^2 / 2 + g y ever exceeds its start."""
    p = Collision3DParams(jitter=0.0, viscosity=0.0, bounce=0.9, sliding=0.3, lifetime=(400.0, 400.0))
    scene = Collision3D(p.changed(shape="sphere:0,1,0,1"))
    sim = Simulation(gl, scene.graph(), 4096, fmt="rgba32f")
    try:
        rng = np.random.default_rng(7)
        n = sim.count
        x = np.column_stack([rng.uniform(-1.2, 1.2, n), rng.uniform(2.1, 3.0, n),
                             rng.uniform(-1.2, 1.2, n)])
        sim.upload("position", x)
        sim.upload("velocity", np.zeros((n, 3)))
        sim.upload("life", np.tile([1.0, 300.0], (n, 1)))
        g = -p.gravity[1]
        start = g * x[:, 1]
        worst, kept = -np.inf, np.ones(n, bool)
        for step in range(150):
            sim.step()
            x, v = sim.download("position"), sim.download("velocity")
            # One that slid off the floor's edge was emitted anew (its age restarted): not the
            # same particle any more.
            kept &= sim.download("life")[:, 0] > 1.0 + step * p.dt
            energy = 0.5 * np.sum(v * v, axis=1) + g * x[:, 1]
            worst = max(worst, np.max((energy - start)[kept]))
        assert kept.mean() > 0.5
        # float32 state: a few 1e-6 of the 30 J/kg at the top.
        assert worst < 1e-4, worst
    finally:
        sim.release()


def test_stokes_friction_is_six_pi_eta_r_over_m():
    p = Collision3DParams(viscosity=1e-3, radius=0.01, mass=2e-3)
    assert p.drag == pytest.approx(6 * np.pi * 1e-3 * 0.01 / 2e-3, rel=1e-12)
    p = Collision3DParams(force=(0.0, 0.0, 2e-4), mass=1e-4, gravity=(0.0, -9.81, 0.0))
    assert np.allclose(p.acceleration, (0.0, -9.81, 2.0))


def test_model_matrix_carries_the_rest_pose_as_the_shader_does():
    """The drawn object and the field agree: the model matrix maps a rest-pose point to where
    the twin's pose (the shader's) puts the object point that was there."""
    scene = Collision3D(shape="box:0,1.2,0,0.8,0.3,0.5", spin=(70.0, 0.2, 1.0, 0.1),
                        sway=(0.3, 0.1, 0.2, 1.7), scale=1.2)
    rest = np.array([[0.5, 1.4, 0.3], [-0.7, 1.0, 0.1]])
    obj = Object(scene.field, scene.params)
    for step in (0, 37, 200):
        m = scene.model_at(step)
        world = rest @ m[:3, :3].T + m[:3, 3]
        q = obj.to_object(world, obj.at(step * scene.params.dt))
        assert np.allclose(q + scene.field.pivot, rest, atol=1e-12)


# --- compression ------------------------------------------------------------------------------

def test_memory_rows_count_blocks_and_padding():
    rows = {name: (bits, sizes) for name, bits, sizes in memory_rows((64, 128))}
    assert rows["rgba8"][1][64] == 64 ** 3 * 4  # 8 x 8 tiles of 64^2, no padding
    # 128 slices of 128^2 in 12 columns and 11 rows: 4 unused tiles are counted.
    assert rows["rgba8"][1][128] == 12 * 11 * 128 ** 2 * 4
    bits, sizes = rows["astc 6x6 (atlas)"]
    assert bits == pytest.approx(128 / 36)
    # 64 texels are 11 blocks of 6 (66, padded); 8 x 8 tiles of 66^2.
    assert sizes[64] == (8 * 66 // 6) ** 2 * 16
    assert rows["astc 10x5 (atlas)"][1][64] == (8 * 70 // 10) * (8 * 65 // 5) * 16
    assert rows["astc 4x4x4 (seed, 3D)"][0] == 2.0
    assert rows["astc 3x3x3 (seed, 3D)"][0] == pytest.approx(4.74, abs=0.01)  # Table 2.1


def test_compressed_field_collides_within_its_measured_error(gl):
    reason = astc.unavailable(gl)
    if reason:
        from conftest import missing

        missing(reason)  # under CI a failure
    base = Collision3D()
    still = dataclasses.replace(base.params, jitter=0.0)
    rows = collision_errors(gl, lambda fmt: Collision3D(still.changed(field_format=fmt),
                                                        field=base.field),
                            base.field, count=1024, steps=60, blocks=((4, 4), (8, 8)))
    found = {fmt: (depth, median) for fmt, depth, median, _ in rows}
    print(found)
    assert found["rgba32f"] == (0.0, 0.0) and found["rgba8-smooth"][0] < 0.5
    # The blocks are drawn compressed: their trajectories part from the uncompressed field's (a
    # plan made without the context's capabilities once ran them uncompressed, unnoticed).
    assert found["astc4x4"] != found["rgba8-smooth"] and found["astc8x8"] != found["astc4x4"]
    assert found["rgba8"][0] < 0.1 and found["rgba8"][1] < 0.2
    # Lossy blocks cost depth: a fraction of a voxel at 4x4, under a voxel and a half at 8x8.
    assert found["astc4x4"][0] < 0.8 and found["astc8x8"][0] < 1.5
    assert found["astc4x4"][1] < found["astc8x8"][1] + 0.2


# --- the command line ----------------------------------------------------------------------

SMALL = ["--particles", "1024", "--size", "96x96", "--steps", "30"]


@pytest.mark.parametrize("args, message", [
    (["--shape", "sphere:1,2"], "sphere:CX,CY,CZ,R"), (["--spin", "fast"], "--spin must be"),
    (["--field-format", "astc7x7"], "--field-format must be"),
    (["--emitter", "0,9,0"], "--emitter Y must be in [-4, 7], got 9"), (["--sway", "1,0,0,0"], "sway needs a period"),
    (["--shape", "torus:0,1,0,0.8,0.01"], "thinner than two voxels")])
def test_bad_options_are_one_line(tmp_path, capsys, args, message):
    assert main(["run", "collision3d", *SMALL, *args, "--out", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.gl
def test_run_draws_the_object_and_the_particles(tmp_path):
    out = tmp_path / "c.png"
    assert main(["run", "collision3d", *SMALL, "--spin", "45", "--out", str(out)]) == 0
    with Image.open(out) as image:
        pixels = np.asarray(image.convert("RGB"), dtype=int)
    assert pixels.shape == (96, 96, 3)
    # The object (orange-brown, lit) at the middle of the picture, particles (pale blue) above.
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    assert np.count_nonzero((r > g + 30) & (r > b + 40)) > 200
    assert np.count_nonzero((b > 150) & (b > r + 10)) > 5


@pytest.mark.gl
def test_plan_prints_the_compression_table(capsys):
    assert main(["plan", "collision3d", "--particles", "1024", "--field-resolution", "24"]) == 0
    text = capsys.readouterr().out
    assert "24x24x24 voxels" in text and "astc 6x6 (atlas)" in text
    assert "astc 3x3x3 (seed, 3D)" in text and "penetration" in text


def _slide_on_sphere(theta0, g, seconds, steps=100_000):
    """Float64: the polar angle from the top of a frictionless sphere of radius 1 after
    ``seconds``, released at rest at ``theta0`` (theta'' = g sin(theta) / R, RK4 in fine steps),
    and whether it is still on the surface (it leaves where cos(theta) = 2/3 cos(theta0))."""
    h = seconds / steps
    theta, omega = theta0, 0.0
    for _ in range(steps):
        def f(t, w):
            return w, g * np.sin(t)
        k1 = f(theta, omega)
        k2 = f(theta + h / 2 * k1[0], omega + h / 2 * k1[1])
        k3 = f(theta + h / 2 * k2[0], omega + h / 2 * k2[1])
        k4 = f(theta + h * k3[0], omega + h * k3[1])
        theta += h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        omega += h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    return theta, np.cos(theta) > 2 / 3 * np.cos(theta0)


def _released_on_sphere(gl, p, tilt, seconds):
    """Particles released at rest on the analytic sphere of radius 1 at ``tilt`` degrees from
    its top, all round it: their polar angles and speeds after ``seconds``."""
    scene = Collision3D(p.changed(shape="sphere:0,1,0,1"))
    sim = Simulation(gl, scene.graph(), 1024, fmt="rgba32f")
    try:
        n = sim.count
        azimuth = np.linspace(0, 2 * np.pi, n, endpoint=False)
        theta0 = np.radians(tilt)
        x = np.column_stack([np.sin(theta0) * np.cos(azimuth), 1 + np.cos(theta0) + 0 * azimuth,
                             np.sin(theta0) * np.sin(azimuth)])
        sim.upload("position", x)
        sim.upload("velocity", np.zeros((n, 3)))
        sim.upload("life", np.tile([1.0, 300.0], (n, 1)))
        sim.run(int(round(seconds / p.dt)))
        x, v = sim.download("position"), sim.download("velocity")
    finally:
        sim.release()
    r = x - np.array([0.0, 1.0, 0.0])
    theta = np.arccos(np.clip(r[:, 1] / np.linalg.norm(r, axis=1), -1, 1))
    return theta, np.linalg.norm(v, axis=1)


@pytest.mark.parametrize("tilt", [25.0, 40.0, 55.0])
def test_with_the_chapter_s_factors_nothing_holds_a_particle_on_a_slope(gl, tilt):
    """Issue 45, item 2: with the chapter's factors (s = 0.5, r = 0.5), no air and no kick,
    particles released at rest on the sphere keep creeping downhill, each contact a small hop
    along the normal and a quarter of the speed along the surface, as the chapter's response
    says: after 0.5 s fewer than 1% are at speed 0 (measured: 4, 0 and 0 of 1,024 at 25, 40 and
    55 degrees; before, the push-out's energy rule had stopped all 1,024 after 2 to 4 degrees),
    and each has turned downhill (3.1, 4.3 and 5.2 degrees; the frictionless bead 35 to 62)."""
    p = Collision3DParams(jitter=0.0, viscosity=0.0, lifetime=(400.0, 400.0))
    assert (p.sliding, p.bounce) == (0.5, 0.5)
    theta, speed = _released_on_sphere(gl, p, tilt, 0.5)
    want, _ = _slide_on_sphere(np.radians(tilt), -p.gravity[1], 0.5)
    turned = theta - np.radians(tilt)
    print(f"tilt {tilt:g}: turned {np.degrees(np.median(turned)):.2f} degrees (frictionless "
          f"{np.degrees(want - np.radians(tilt)):.2f}), {np.sum(speed == 0)} at speed 0")
    assert np.mean(speed == 0) < 0.01
    assert np.all(turned > 0.04 * (want - np.radians(tilt)))


@pytest.mark.parametrize("tilt", [10.0, 25.0, 40.0])
def test_released_at_rest_on_a_frictionless_sphere_a_particle_slides(gl, tilt):
    """Issue 45, item 2: with the sliding factor at its frictionless end (s = 0, r = 1), no air
    and no kick, particles released at rest on the analytic sphere slide as a bead on a
    frictionless sphere does (theta'' = g sin(theta) / R, integrated here in float64): after
    0.3 s their median has turned through the model's angle within 5% (measured: -3.2, +3.2 and
    +3.8% at 10, 25 and 40 degrees), each within that and what the field's normals, 1.9 degrees
    off at worst, do to g sin(theta). The push-out's energy rule held them still before
    (a few centimetres, then speed 0 at any tilt from 5 to 65 degrees): it took the push-out's
    work from the speed the response had already turned along the surface; now, over the depth
    a sub-step's own move explains, it takes at most the normal speed's share that came in."""
    p = Collision3DParams(jitter=0.0, viscosity=0.0, bounce=1.0, sliding=0.0,
                          lifetime=(400.0, 400.0))
    seconds = round(0.3 / p.dt) * p.dt
    theta0 = np.radians(tilt)
    theta, _ = _released_on_sphere(gl, p, tilt, seconds)
    want, on = _slide_on_sphere(theta0, -p.gravity[1], seconds)
    assert on
    turned = theta - theta0
    print(f"tilt {tilt:g}: turned {np.degrees(np.median(turned)):.2f} degrees (model "
          f"{np.degrees(want - theta0):.2f}), spread {np.degrees(np.ptp(turned)):.2f}")
    model = want - theta0
    # The median within 5% (the step's discretisation); each particle within that and what
    # its normal's error (1.9 degrees at worst) does to g sin(theta): a share cot(theta) as
    # large, relative
    assert abs(np.median(turned) - model) < 0.05 * model
    assert np.all(np.abs(turned - model) < (0.06 + np.radians(1.9) / np.tan(theta0)) * model)
