"""What keys and the mouse do to the live camera and grip, against float64 written here from the
geometry (spherical coordinates, rotations about the vertical, a ray through a pixel, a ray and a
sphere), and the seams of ``es2particles view`` that need no display or GL: key bindings files,
options out of range, no display."""

import math

import numpy as np
import pytest

from es2particles.cli import main
from es2particles.errors import ParameterError
from es2particles.live.controls import Bindings, ViewCamera, dragged_centre, hit_sphere
from es2particles.render.camera import Camera
from es2particles.scenes.base import Grip

START = Camera(eye=(1.0, 2.6, 7.8), target=(0.0, 2.4, 0.0), fov=45.0)


def spherical(eye, target):
    """(radius, azimuth from +z towards +x, elevation) of the eye about the target, y up."""
    d = np.subtract(eye, target)
    r = np.linalg.norm(d)
    return r, math.atan2(d[0], d[2]), math.asin(d[1] / r)


def test_a_drag_orbits_the_eye_about_the_vertical_through_the_target():
    r0, a0, e0 = spherical(START.eye, START.target)
    view = ViewCamera(START)
    view.orbit(120, 0)
    view.orbit(0, 30)
    r, a, e = spherical(view.eye, view.target)
    assert np.allclose(view.target, START.target)
    assert r == pytest.approx(r0, rel=1e-12)
    assert a == pytest.approx(a0 - 1.2, abs=1e-12)  # 0.01 radian a pixel, right turns clockwise
    assert e == pytest.approx(e0 + 0.3, abs=1e-12)
    view.orbit(0, 10 ** 4)  # the elevation stops at 1.45 radians
    assert spherical(view.eye, view.target)[2] == pytest.approx(1.45, abs=1e-12)


def test_the_wheel_scales_the_distance_and_keeps_it_within_limits():
    r0 = spherical(START.eye, START.target)[0]
    view = ViewCamera(START)
    view.zoom(3)
    assert np.linalg.norm(view.eye - view.target) == pytest.approx(r0 * math.exp(-0.3), rel=1e-12)
    view.zoom(-1000)
    assert np.linalg.norm(view.eye - view.target) == pytest.approx(50.0, rel=1e-12)
    view.zoom(1000)
    assert np.linalg.norm(view.eye - view.target) == pytest.approx(0.5, rel=1e-12)
    ortho = ViewCamera(Camera(eye=(0.0, 0.0, 4.0), target=(0.0, 0.0, 0.0), ortho=2.0))
    ortho.zoom(-2)
    assert ortho.camera().ortho == pytest.approx(2.0 * math.exp(0.2), rel=1e-12)


def test_keys_turn_walk_and_rise_as_the_jogl_key_camera():
    view = ViewCamera(START)
    view.turn(3)  # left arrow three times: 15 degrees counter-clockwise seen from above
    look = np.subtract(START.target, START.eye)
    c, s = math.cos(math.radians(15)), math.sin(math.radians(15))
    turned = np.array([c * look[0] + s * look[2], look[1], -s * look[0] + c * look[2]])
    assert np.allclose(view.eye, START.eye, atol=1e-12)
    assert np.allclose(view.target - view.eye, turned, atol=1e-12)
    eye, target = view.eye.copy(), view.target.copy()
    view.move(2)  # two steps forward: half a metre along the floor, the height kept
    level = np.array([turned[0], 0.0, turned[2]])
    step = 0.5 * level / np.linalg.norm(level)
    assert np.allclose(view.eye, eye + step, atol=1e-12)
    assert np.allclose(view.target, target + step, atol=1e-12)
    view.rise(-3)
    assert np.allclose(view.eye, eye + step - [0, 0.3, 0], atol=1e-12)


def test_a_ray_through_a_pixel_leaves_the_eye_at_the_pixels_angle():
    view = ViewCamera(START)
    size = (640, 360)
    origin, direction = view.ray((320, 180), size)  # the picture's centre: straight ahead
    forward = np.subtract(START.target, START.eye) / np.linalg.norm(np.subtract(START.target,
                                                                                START.eye))
    assert np.allclose(origin, START.eye) and np.allclose(direction, forward, atol=1e-12)
    _, top = view.ray((320, 0), size)  # the top edge: half the vertical field of view
    assert math.degrees(math.acos(np.dot(top, forward))) == pytest.approx(22.5, abs=1e-9)
    _, right = view.ray((640, 180), size)  # the right edge: atan(aspect tan(fov / 2))
    want = math.degrees(math.atan(640 / 360 * math.tan(math.radians(22.5))))
    assert math.degrees(math.acos(np.dot(right, forward))) == pytest.approx(want, abs=1e-9)
    # and on the pixel's side: up the screen for the top row, right for the right edge (the
    # camera's own right and up, from its forward and the world's up, written here)
    side = np.cross(forward, (0.0, 1.0, 0.0))
    side /= np.linalg.norm(side)
    up = np.cross(side, forward)
    assert np.dot(top - forward, up) > 0.3 and abs(np.dot(top, side)) < 1e-12
    assert np.dot(right - forward, side) > 0.5 and abs(np.dot(right, up)) < 1e-12
    _, corner = view.ray((0, 360), size)  # the bottom left: down and left
    assert np.dot(corner, up) < 0 and np.dot(corner, side) < 0


def test_a_ray_meets_a_sphere_at_its_near_surface():
    hit = hit_sphere((0.0, 0.0, 10.0), (0.0, 0.0, -1.0), (0.0, 0.0, 0.0), 2.0)
    assert np.allclose(hit, (0, 0, 2))
    assert hit_sphere((0.0, 3.0, 10.0), (0.0, 0.0, -1.0), (0.0, 0.0, 0.0), 2.0) is None
    assert hit_sphere((0.0, 0.0, 10.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), 2.0) is None


GRIP = Grip("u_sphere", "u_sphere_drift", (0.0, 2.4, 0.0), 0.7, (-2.2, 2.2), (-3.0, 3.0))


def test_a_drag_moves_the_grip_over_the_level_plane_and_stops_at_its_range():
    grabbed = np.array([0.1, 2.7, 0.6])
    # A ray from above meeting the plane y = 2.7 at (1.1, 2.7, -0.4): the centre moves by (1, 0, -1)
    target = np.array([1.1, 2.7, -0.4])
    origin = target + np.array([0.3, 2.0, 1.0])
    direction = (target - origin) / np.linalg.norm(target - origin)
    centre = dragged_centre(GRIP, GRIP.centre, grabbed, origin, direction)
    assert np.allclose(centre, (1.0, 2.4, -1.0), atol=1e-12)
    far = np.array([9.0, 2.7, 0.6])
    origin = far + np.array([0.0, 1.0, 1.0])
    centre = dragged_centre(GRIP, GRIP.centre, grabbed, origin, (far - origin) / math.sqrt(2))
    assert np.allclose(centre, (2.2, 2.4, 0.0), atol=1e-12)  # x stops at its range
    level = dragged_centre(GRIP, GRIP.centre, grabbed, (0.0, 2.7, 5.0), (1.0, 0.0, 0.0))
    assert np.allclose(level, GRIP.centre)  # a level ray never meets the plane: no move


def test_bindings_take_changes_and_refuse_unknown_actions_and_keys():
    b = Bindings({"pause": "p", "screenshot": ["shift+p", "f"]})
    assert b.action("p") == "pause" and b.action("space") is None
    assert b.action("p", shift=True) == "screenshot" and b.action("f") == "screenshot"
    assert b.action("s", shift=True) == "back"  # shift+s lost its action: s's own holds
    with pytest.raises(ParameterError, match="unknown action 'jump'"):
        Bindings({"jump": "j"})
    with pytest.raises(ParameterError, match="'F13' is not a key name"):
        Bindings({"pause": "F13"})
    with pytest.raises(ParameterError, match="must be a key name or a list"):
        Bindings({"pause": 3})


def one_line_error(capsys, argv):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("content, message", [
    ("[keys]\njump = \"j\"\n", "unknown action 'jump'"),
    ("[keys]\npause = \"F13\"\n", "'F13' is not a key name"),
    ("pause = \"p\"\n", "a bindings file holds one [keys] table"),
    ("[keys\n", "is not a TOML bindings file"),
])
def test_a_bad_bindings_file_is_one_line_naming_it(tmp_path, capsys, content, message):
    path = tmp_path / "keys.toml"
    path.write_text(content)
    err = one_line_error(capsys, ["view", "smoke", "--keys", str(path)])
    assert message in err and "--keys" in err


@pytest.mark.parametrize("argv, message", [
    (["view", "smoke", "--keys", "missing.toml"], "--keys 'missing.toml' does not exist"),
    (["view", "dejong", "--exit-after", "0"], "--exit-after must be in [1, 1000000000]"),
    (["view", "dejong", "--screenshot", "shot.jpg"], "--screenshot must end in .png"),
    (["view", "smoke", "--opacity", "2"], "--opacity must be in [0, 1]"),
    (["view", "dejong", "--frames", "3"], "unrecognized arguments: --frames"),
])
def test_view_options_out_of_range_are_one_line(tmp_path, monkeypatch, capsys, argv, message):
    monkeypatch.chdir(tmp_path)
    assert message in one_line_error(capsys, argv)
    assert list(tmp_path.iterdir()) == []


def test_no_display_is_one_line_that_names_run(monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    err = one_line_error(capsys, ["view", "dejong"])
    assert "no display to open a window on" in err and "es2particles run" in err
