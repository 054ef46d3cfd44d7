"""Meshes of the 3D scenes: capsule, torus and indexed triangle meshes against their analytic
surfaces in float64 numpy, and moving meshes drawn by the sprite renderer on real GL, their
pixels where the camera's float64 projection puts the moved shape."""

from dataclasses import replace

import numpy as np
import pytest

from conftest import needs
from es2particles import Simulation
from es2particles.render.camera import Camera
from es2particles.errors import ParameterError
from es2particles.scenes import Fountain
from es2particles.scenes.fountain import FountainParams
from es2particles.frame.pipeline import Renderer
from es2particles.frame.motion import Motion
from es2particles.render.meshes import box, capsule, from_triangles, sphere, torus
from es2particles.render.sprites import Sprites

ON_SURFACE = 1e-9  # float64 rounding of points a few units from the origin
NORMAL = 1e-6


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def check_normals(mesh, gradient):
    """Normals unit and along the analytic outward ``gradient`` (a function of points)."""
    p, n = mesh.triangles.reshape(-1, 3), mesh.normals.reshape(-1, 3)
    length = np.abs(np.linalg.norm(n, axis=1) - 1).max()
    direction = np.abs(n - unit(gradient(p))).max()
    print(f"normals: max |length - 1| {length:.1e}, max distance from the gradient {direction:.1e}")
    assert length <= NORMAL and direction <= NORMAL


def check_closed_and_outward(mesh):
    """Welded at 1e-9, the mesh (less its zero-area pole triangles) is closed and consistently
    wound: each directed edge once, its reverse once; each winding agrees with the normals."""
    t, n = mesh.triangles, mesh.normals
    _, index = np.unique(np.round(t.reshape(-1, 3), 9) + 0.0, axis=0, return_inverse=True)
    index = index.reshape(-1, 3)
    kept = np.all(index != np.roll(index, 1, axis=1), axis=1)
    cross = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    facing = np.einsum("ij,ij->i", cross, n.mean(axis=1))
    print(f"{kept.sum()} triangles ({(~kept).sum()} zero-area at the poles), min winding . "
          f"normal {facing[kept].min():.2e}")
    assert np.all(facing[kept] > 0), "counter-clockwise seen from outside, like box and floor"
    edges = np.concatenate([index[kept][:, [0, 1]], index[kept][:, [1, 2]],
                            index[kept][:, [2, 0]]])
    forward = {tuple(e) for e in edges}
    assert len(forward) == len(edges), "each directed edge once"
    assert forward == {(b, a) for a, b in forward}, "closed: every edge has its reverse"


def segment_distance(p, a, b):
    """Distance from points p (N, 3) to segment a-b, and the closest points."""
    d = b - a
    s = np.clip((p - a) @ d / d.dot(d), 0, 1) if d.dot(d) > 0 else np.zeros(len(p))
    closest = a + s[:, None] * d
    return np.linalg.norm(p - closest, axis=1), closest


@pytest.mark.parametrize("a, b", [((0, 0, 0), (0, 2, 0)), ((1, 2, 3), (1, -1, 3)),
                                  ((0.5, 1, 0), (2, 1, 0)), ((-1, 0.3, 2), (0.7, 1.9, -0.4)),
                                  ((1, 1, 1), (1, 1, 1))])
def test_capsule_lies_on_its_surface_with_outward_normals(a, b):
    a, b, radius = np.array(a, float), np.array(b, float), 0.4
    mesh = capsule(a, b, radius, rings=6, segments=20)
    distance, _ = segment_distance(mesh.triangles.reshape(-1, 3), a, b)
    error = np.abs(distance - radius).max()
    print(f"capsule {a} -> {b}: max |distance to the segment - radius| {error:.1e}")
    assert error <= ON_SURFACE
    check_normals(mesh, lambda p: p - segment_distance(p, a, b)[1])
    check_closed_and_outward(mesh)


@pytest.mark.parametrize("axis", [(0, 1, 0), (0, -1, 0), (1, 0, 0), (1, 2, -0.5)])
def test_torus_lies_on_its_surface_with_outward_normals(axis):
    centre, major, minor = np.array([0.5, 1.0, -2.0]), 1.5, 0.35
    w = unit(np.array(axis, float))
    mesh = torus(centre, major, minor, axis, rings=24, segments=10)

    def core(p):  # the nearest point of the circle of radius major about the axis
        q = p - centre
        across = q - np.outer(q @ w, w)
        return centre + major * unit(across)

    p = mesh.triangles.reshape(-1, 3)
    q = p - centre
    height, across = q @ w, np.linalg.norm(q - np.outer(q @ w, w), axis=1)
    implicit = np.abs((across - major) ** 2 + height**2 - minor**2).max()
    print(f"torus about {axis}: max |(rho - R)^2 + h^2 - r^2| {implicit:.1e}")
    assert implicit <= ON_SURFACE
    check_normals(mesh, lambda p: p - core(p))
    check_closed_and_outward(mesh)


def test_sphere_is_wound_outward_like_box_and_floor():
    mesh = sphere((0.0, 1.0, 0.0), 0.5, rings=8, segments=12)
    check_normals(mesh, lambda p: p - (0.0, 1.0, 0.0))
    check_closed_and_outward(mesh)


@pytest.mark.parametrize("shape", ["icosahedron", "cube"])
def test_from_triangles_has_unit_outward_normals(shape):
    trimesh = needs("trimesh", "mesh")
    source = {"icosahedron": trimesh.creation.icosahedron(),
              "cube": trimesh.creation.box(extents=(1.0, 2.0, 0.5))}[shape]
    vertices, faces = np.array(source.vertices), np.array(source.faces)
    mesh = from_triangles(vertices, faces)
    assert np.array_equal(mesh.triangles, vertices[faces]), "the faces as given, windings kept"
    n, p = mesh.normals.reshape(-1, 3), mesh.triangles.reshape(-1, 3)
    assert np.abs(np.linalg.norm(n, axis=1) - 1).max() <= NORMAL
    assert np.einsum("ij,ij->i", n, p).min() > 0.3, "outward"
    if shape == "icosahedron":  # by symmetry the area-weighted average is radial
        assert np.abs(n - unit(p)).max() <= NORMAL
    check_closed_and_outward(mesh)


def test_from_triangles_keeps_the_face_normal_where_the_average_vanishes():
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1]], float)
    faces = np.array([[0, 1, 2], [0, 2, 1], [1, 3, 2]])  # a two-sided sheet and one more face
    mesh = from_triangles(vertices, faces)
    # vertex 0: the sheet's two sides cancel, each corner keeps its face's normal
    assert np.allclose(mesh.normals[0, 0], [0, 0, 1])
    assert np.allclose(mesh.normals[1, 0], [0, 0, -1])
    # vertices 1 and 2 also touch the third face, which is all that is left of their average
    third = np.full(3, 1 / np.sqrt(3)) * [-1, -1, 1]
    assert np.allclose(mesh.normals[:2, 1:], third) and np.allclose(mesh.normals[2], third)


@pytest.mark.parametrize("vertices, faces", [
    (np.zeros((3, 3)), [[0, 1, 3]]),
    (np.zeros((3, 3)), [[0.0, 1.0, 2.0]]),
    (np.zeros((3, 2)), [[0, 1, 2]]),
    ([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]], [[0, 1, 2]]),
    (np.zeros((3, 3)), np.zeros((0, 3), int)),
])
def test_from_triangles_refuses_bad_input(vertices, faces):
    with pytest.raises(ParameterError):
        from_triangles(vertices, faces)


def test_shapes_refuse_bad_parameters():
    for call in (lambda: capsule((0, 0, 0), (0, 1, 0), 0.0),
                 lambda: capsule((0, 0), (0, 1, 0), 0.5),
                 lambda: torus((0, 0, 0), 1.0, 1.5),
                 lambda: torus((0, 0, 0), 1.0, 0.2, axis=(0, 0, 0)),
                 lambda: torus((0, 0, 0), 1.0, 0.2, rings=2)):
        with pytest.raises(ParameterError):
            call()


def translation(x, y, z):
    m = np.eye(4)
    m[:3, 3] = x, y, z
    return m


def rotation(axis, degrees):
    """A rotation about coordinate axis 0, 1 or 2 (x, y, z), 4x4."""
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    i, j = [k for k in range(3) if k != axis]
    m = np.eye(4)
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def test_a_motions_matrix_is_its_sway_turn_and_scale_about_the_pivot():
    """The float64 twin of lib/motion.glsl against the matrices written here: at t = 1 s, a
    quarter turn about z, twice the size, swayed by its full amplitude, about pivot (1, 0, 0)."""
    motion = Motion(0.5, pivot=(1.0, 0.0, 0.0), offset=(0.0, 2.0, 0.0), axis=(0.0, 0.0, 1.0),
                    rate=np.pi / 2, sway=(0.3, 0.0, 0.0), period=4.0, scale=2.0)
    want = (translation(1.0 + 0.3, 2.0, 0.0) @ rotation(2, 90) @ np.diag([2.0, 2.0, 2.0, 1.0])
            @ translation(-1.0, 0.0, 0.0))
    assert np.allclose(motion.matrix(2), want, rtol=0, atol=1e-12)
    values = motion.uniforms(drag=(0.5, 0.0, -1.0))
    assert values["u_motion_offset"] == (0.5, 2.0, -1.0)
    assert values["u_motion_pivot"] == (1.0, 0.0, 0.0, 2.0)


SIZE = (256, 256)
CAMERA = Camera(eye=(0.0, 2.0, 6.0), target=(0.0, 1.0, 0.0), fov=50)


def mesh_frame(gl, meshes, motion, light=(0.0, 3.0, 6.0)):
    """Only the meshes (the particle is invisible), the moving ones placed by ``motion`` after
    one step: the (h, w, 3) image."""
    scene = Fountain(FountainParams(gravity=(0.0, 0.0, 0.0)))
    with Simulation(gl, scene.graph(), 1, fmt="rgba32f") as sim:
        sim.upload("position", np.array([[0.0, 1.0, 0.0]]))
        sim.upload("life", np.array([[2.4, 2.4]]))
        sim.step()
        sprites = Sprites(meshes=meshes, opacity=0.0, light=light, background=(0, 0, 0))
        with Renderer(gl, sprites, sim, size=SIZE, point_size=24.0, motion=motion) as renderer:
            renderer.draw(CAMERA)
            return renderer.read()


def lit_centre(channel):
    lit = np.argwhere(channel > 40)  # ambient light alone gives 0.35 * 255
    return lit.mean(axis=0)[::-1] + 0.5  # (x, y) pixel centres, top row first


def test_a_moving_sphere_is_drawn_where_the_model_puts_it_a_still_one_where_it_is(gl):
    moving = replace(sphere((0.0, 0.0, 0.0), 0.3, colour=(1, 0, 0)), moves=True)
    still = sphere((-1.0, 1.0, 0.0), 0.3, colour=(0, 1, 0))
    for place in ((1.0, 1.3, -0.5), (0.6, 0.4, 1.0)):
        image = mesh_frame(gl, [moving, still], Motion(1.0, offset=place))
        expected = CAMERA.project(np.array([place, (-1.0, 1.0, 0.0)]), SIZE)[0]
        got = np.array([lit_centre(image[..., 0]), lit_centre(image[..., 1])])
        print(f"moving sphere at {place}: centre {got[0]} vs {expected[0]}; still one {got[1]} "
              f"vs {expected[1]}")
        assert np.abs(got - expected).max() <= 2.0


def test_a_rotated_box_covers_its_projected_corners_and_its_normals_turn(gl):
    bar = replace(box((0.0, 0.0, 0.0), (0.6, 0.1, 0.1), colour=(1, 1, 1)), moves=True)
    model = translation(0.3, 1.1, 0.0) @ rotation(2, 90)  # the bar stands up
    image = mesh_frame(gl, [bar], Motion(1.0, offset=(0.3, 1.1, 0.0), rate=np.pi / 2))
    corners = np.array([[x, y, z] for x in (-0.6, 0.6) for y in (-0.1, 0.1) for z in (-0.1, 0.1)])
    world = corners @ model[:3, :3].T + model[:3, 3]
    pixels = CAMERA.project(world, SIZE)[0]
    lit = np.argwhere(image[..., 0] > 40)
    got = np.array([lit[:, 1].min(), lit[:, 0].min(), lit[:, 1].max() + 1, lit[:, 0].max() + 1])
    expected = np.concatenate([pixels.min(0), pixels.max(0)])
    print(f"rotated bar: lit box {got} vs projected corners {np.round(expected, 1)}")
    assert np.abs(got - expected).max() <= 2.0

    # A plate facing up, turned and scaled to face the camera and the light at the eye: lit fully
    # only if its normal turned with it (unturned, it would be edge-on to the light: ambient).
    plate = replace(box((0.0, 0.0, 0.0), (0.5, 0.02, 0.5), colour=(0.8, 0.8, 0.8)), moves=True)
    image = mesh_frame(gl, [plate], Motion(1.0, offset=(0.0, 1.0, 0.0), axis=(1.0, 0.0, 0.0),
                                           rate=np.pi / 2, scale=1.5), light=CAMERA.eye)
    centre = CAMERA.project(np.array([[0.0, 1.0, 0.0]]), SIZE)[0][0].astype(int)
    front = np.array([0.0, 1.0, 0.03])  # the plate's front face, scaled 0.02 * 1.5
    cosine = unit(np.array(CAMERA.eye) - front).dot([0.0, 0.0, 1.0])
    expected = 255 * 0.8 * (0.35 + 0.65 * cosine)
    value = image[centre[1], centre[0]].astype(int)
    print(f"turned plate: centre pixel {value}, expected {expected:.1f}")
    assert np.abs(value - expected).max() <= 2.0
