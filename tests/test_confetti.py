"""The confetti (scenes/confetti.py, render/quads.py): quads that lie flat on the surface they
rest on, checked against the analytic shapes' normals in float64; and quads drawn where an
independent pinhole puts them, at the area their shape and tilt give."""

import numpy as np
import pytest

from es2particles import PassGraph, Simulation
from es2particles.cli import main
from es2particles.errors import ParameterError
from es2particles.fields.field3d import octahedral_decode, octahedral_encode
from es2particles.frame.pipeline import Renderer
from es2particles.render.camera import Camera
from es2particles.render.quads import Quads
from es2particles.scenes import Confetti

pytestmark = pytest.mark.gl


@pytest.mark.parametrize("shape", ["sphere:0,1,0,1", "box:0,0.8,0,0.9,0.3,0.6"])
def test_resting_confetti_lie_flat_on_the_surface_they_touched(gl, shape):
    """Dropped from rest above the object with no randomness in flight: after 4 s the pieces at
    rest on the floor face (0, 1, 0) and those at rest on the object its analytic normal where
    they lie, within what the nearest voxel's normal allows (its centre is at most 0.87 voxel
    from the piece: on a sphere of radius 1 that turns the normal by 0.87 voxel / 1), plus the
    8-bit field normal's rounding (0.5 degree). The box's top holds hundreds; the sphere only a
    few at its top: nothing holds a piece on its slopes (issue 45), and the rest slide off."""
    scene = Confetti(shape=shape, jitter=0.0, lifetime=(400.0, 400.0))
    rng = np.random.default_rng(5)
    n = 4096
    with Simulation(gl, scene.graph(gl.caps), n, fmt="rgba32f") as sim:
        sim.upload("position", np.column_stack([rng.uniform(-1.6, 1.6, n),
                                                rng.uniform(2.3, 3.5, n),
                                                rng.uniform(-1.6, 1.6, n)]))
        sim.upload("velocity", np.zeros((n, 3)))
        sim.upload("life", np.tile([1.0, 300.0], (n, 1)))
        sim.upload("normal", octahedral_encode(rng.normal(size=(n, 3))))
        sim.run(240)
        x, v = sim.download("position"), sim.download("velocity")
        facing = octahedral_decode(sim.download("normal")).astype(float)
    d, normal = scene.field.exact(x - scene.field.pivot)
    voxel = scene.field.voxel
    resting = np.linalg.norm(v, axis=1) < 0.05
    on_floor = resting & (x[:, 1] < 0.01) & (d > voxel)
    on_object = resting & (np.abs(d) < 0.5 * voxel) & (x[:, 1] > 0.05)
    curved = 1.0 if "sphere" in shape else np.inf
    tolerance = np.degrees(0.87 * voxel / curved) + 0.5 + 0.5

    def angles(expected, mask):
        cos = np.clip(np.sum(facing[mask] * expected, axis=1), -1, 1)
        return np.degrees(np.arccos(cos))

    floor_angle = angles(np.array([0.0, 1.0, 0.0]), on_floor)
    object_angle = angles(normal[on_object], on_object)
    print(f"{shape}: {on_floor.sum()} resting on the floor, worst {floor_angle.max():.3f} deg; "
          f"{on_object.sum()} on the object, worst {object_angle.max():.3f} deg, median "
          f"{np.median(object_angle):.3f} (allowed {tolerance:.2f})")
    assert on_floor.sum() > 200
    if curved < np.inf:  # nothing holds a piece on the sphere's slopes (issue 45): a few at its
        assert 0 < on_object.sum() <= 0.01 * n  # top (2 measured; 110 before the fix)
    else:
        assert on_object.sum() > 50
    assert floor_angle.max() < 0.5 and object_angle.max() < tolerance


CAMERA = Camera(eye=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0), fov=40.0)
SIZE = (200, 200)


def draw_quads(gl, tmp_path, positions, normals, shape, half_size=0.3, lift=0.0):
    g = PassGraph()
    for name, lo, hi, k in (("position", -2, 2, 3), ("normal", -1, 1, 2), ("life", 0, 10, 2)):
        g.quantity(name, lo, hi, components=k)
        frag = tmp_path / f"hold_{name}.frag"
        frag.write_text(f"#version 100\nvoid main()\n{{\n    write_{name}(read_{name}(v_uv));\n}}\n")
        g.add(name, str(frag), writes=name, reads=[name])
    count = len(positions)
    with Simulation(gl, g, count, fmt="rgba32f") as sim:
        sim.upload("position", np.asarray(positions, float))
        sim.upload("normal", octahedral_encode(np.asarray(normals, float)))
        sim.upload("life", np.tile([1.0, 5.0], (count, 1)))
        quads = Quads(half_size=half_size, shapes=(shape,), lift=lift, light=(0.0, 0.0, 4.0),
                      background=(0, 0, 0))
        with Renderer(gl, quads, sim, size=SIZE) as renderer:
            renderer.draw(CAMERA)
            return renderer.read().astype(float)


@pytest.mark.parametrize("shape, area", [("square", 1.6 ** 2), ("disc", np.pi),
                                         ("star", None)])
@pytest.mark.parametrize("tilt", [0.0, 50.0])
def test_a_quad_covers_the_area_of_its_shape_where_the_camera_sees_it(gl, tmp_path, shape, area,
                                                                      tilt):
    """A quad of half size 0.3 at the origin, facing the camera or tilted about x: its lit
    pixels' centre is the pinhole's projection of the origin, and their count the shape's area
    (in units of the half size squared: a square of side 1.6, a disc of radius 1) scaled by the
    projection at distance 4 and by cos(tilt); the star is checked against its own polar
    formula, integrated here."""
    t = np.radians(tilt)
    image = draw_quads(gl, tmp_path, [[0.0, 0.0, 0.0]], [[0.0, np.sin(t), np.cos(t)]], shape)
    lit = image.max(axis=2) > 4
    rows, cols = np.nonzero(lit)
    focal = SIZE[1] / 2 / np.tan(np.radians(CAMERA.fov) / 2)
    scale = (0.3 * focal / 4.0) ** 2
    if area is None:  # the star of quads/confetti.frag: r(a) = mix(0.42, 1, swing^2)
        a = np.linspace(0, 2 * np.pi, 200001)
        swing = 0.5 + 0.5 * np.cos(5 * a - np.pi / 2)
        r = 0.42 + 0.58 * swing ** 2
        area = 0.5 * np.mean(r * r) * 2 * np.pi
    expected = area * scale * np.cos(t)
    edge = 0.5 * 4 * np.sqrt(expected)  # half a pixel all round an outline of a square's length
    print(f"{shape} tilted {tilt:g}: {lit.sum()} pixels, expected {expected:.0f} +- {edge:.0f}")
    assert abs(lit.sum() - expected) < edge
    assert abs(cols.mean() + 0.5 - SIZE[0] / 2) < 1 and abs(rows.mean() + 0.5 - SIZE[1] / 2) < 1


def _shape_area(shape):
    """A shape's area in units of the half size squared: a square of side 1.6, a disc of radius
    1, the star of quads/confetti.frag by its polar formula r(a) = mix(0.42, 1, swing^2)."""
    if shape != "star":
        return {"square": 1.6 ** 2, "disc": np.pi}[shape]
    a = np.linspace(0, 2 * np.pi, 200001)
    r = 0.42 + 0.58 * (0.5 + 0.5 * np.cos(5 * a - np.pi / 2)) ** 2
    return 0.5 * np.mean(r * r) * 2 * np.pi


@pytest.mark.parametrize("shape", ["square", "disc", "star"])
def test_quads_cover_their_area_at_every_turn(gl, tmp_path, shape):
    """Sixteen pieces facing the camera in a 4 x 4 grid, each at its own turn about its normal
    (a hash of its index, as in the scene): each covers its shape's area to within half a pixel
    all round its outline, and their mean to within 1% (rasterising is unbiased over turns and
    places; one piece at one turn is not: an unturned square of 32.97 pixels a side lit 32 x 32)."""
    from scipy import ndimage

    grid = (np.arange(4) - 1.5) * 0.7  # 48 pixels apart: a turned square is 47 across
    positions = [[x, y, 0.0] for y in grid for x in grid]
    image = draw_quads(gl, tmp_path, positions, [[0.0, 0.0, 1.0]] * 16, shape)
    labels, found = ndimage.label(image.max(axis=2) > 4)
    assert found == 16
    counts = np.bincount(labels.ravel())[1:]
    focal = SIZE[1] / 2 / np.tan(np.radians(CAMERA.fov) / 2)
    expected = _shape_area(shape) * (0.3 * focal / 4.0) ** 2
    edge = 0.5 * 4 * np.sqrt(expected)
    print(f"{shape} at 16 turns: {counts.min()} to {counts.max()} pixels, mean {counts.mean():.1f}"
          f", expected {expected:.1f} ({100 * (counts.mean() / expected - 1):+.2f}%)")
    assert np.all(np.abs(counts - expected) < edge)
    assert abs(counts.mean() / expected - 1) < 0.01


def test_a_piece_in_flight_turns_at_the_tumble_rate(gl):
    """Pieces high above everything, at rest, one step: each facing turns by --tumble dt about
    an axis across it (540 degrees/s over 1/60 s: 9 degrees), so the angle between a piece's
    facings before and after is that, in float state to float32's rounding."""
    scene = Confetti(jitter=0.0, lifetime=(400.0, 400.0), gravity=(0.0, 0.0, 0.0))
    rng = np.random.default_rng(3)
    n = 512
    with Simulation(gl, scene.graph(gl.caps), n, fmt="rgba32f") as sim:
        sim.upload("position", np.column_stack([rng.uniform(-1.5, 1.5, n), rng.uniform(5, 6, n),
                                                rng.uniform(-1.5, 1.5, n)]))
        sim.upload("velocity", np.zeros((n, 3)))
        sim.upload("life", np.tile([1.0, 300.0], (n, 1)))
        before = rng.normal(size=(n, 3))
        sim.upload("normal", octahedral_encode(before))
        before = octahedral_decode(sim.download("normal")).astype(float)
        sim.run(1)
        after = octahedral_decode(sim.download("normal")).astype(float)
    turned = np.degrees(np.arccos(np.clip(np.sum(before * after, axis=1), -1, 1)))
    want = scene.params.tumble * scene.params.dt
    print(f"turned {turned.min():.4f} to {turned.max():.4f} degrees a step; {want:g} asked")
    assert np.all(np.abs(turned - want) < 0.01)


def test_a_quad_s_back_is_lit_as_its_front(gl, tmp_path):
    """Paper is lit on both sides: a piece facing away from the light (and the camera) is as
    bright as one facing it."""
    front, back = (image[image.max(axis=2) > 4] for image in (
        draw_quads(gl, tmp_path, [[0.0, 0.0, 0.0]], [facing], "square")
        for facing in ([0.0, 0.0, 1.0], [0.0, 0.0, -1.0])))
    assert len(front) > 500 and abs(len(front) - len(back)) < 0.05 * len(front)
    assert np.abs(front.mean(axis=0) - back.mean(axis=0)).max() < 1.0


def test_a_lifted_quad_stands_off_its_surface_towards_its_facing(gl, tmp_path):
    """--lift moves a piece off the surface it lies on along its facing, by 0.5 to 1.5 of the
    lift (a hash of the piece): a piece facing the camera 4 m away, lifted by 0.5, is 0.25 to
    0.75 nearer, so it covers (4 / (4 - l))^2 of its area unlifted, more than 1.13 of it."""
    flat = draw_quads(gl, tmp_path, [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], "square")
    lifted = draw_quads(gl, tmp_path, [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], "square", lift=0.5)
    ratio = (lifted.max(axis=2) > 4).sum() / (flat.max(axis=2) > 4).sum()
    print(f"lifted by 0.5: {ratio:.3f} of the unlifted area (1.13 to 1.51 allowed)")
    assert 1.12 < ratio < 1.52


def test_the_command_line_makes_tumbling_confetti(tmp_path, capsys):
    out = tmp_path / "c.gif"
    assert main(["run", "confetti", "--particles", "1024", "--size", "96x72", "--frames", "4",
                 "--steps-per-frame", "5", "--out", str(out)]) == 0
    assert out.stat().st_size > 0
    assert main(["run", "confetti", "--shapes", "disc,heart", "--out", str(tmp_path / "x.png")]) \
        == 2
    err = capsys.readouterr().err
    assert "confetti shapes are one to three of disc, square, star" in err
    assert main(["run", "confetti", "--point-size", "4", "--out", str(tmp_path / "x.png")]) == 2
    assert "--point-size: scene 'confetti' does not use this setting" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.gif"]


def test_confetti_shapes_are_checked_when_the_scene_is_made():
    with pytest.raises(ParameterError, match="confetti shapes are one to three"):
        Confetti(shapes="disc,disc")
