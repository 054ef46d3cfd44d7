"""The live view as a person uses it: ``es2particles view`` in a real window on an Xvfb screen,
driven by xdotool's keys and mouse, seen through screenshots of the screen; the sphere dragged
through the smoke on EGL; the notebook widget on a real kernel.

Expected cameras and places are float64 written here from the geometry (spherical coordinates
about the target, rotations about the vertical, a ray through a pixel); pictures are compared with
what ``es2particles run`` writes for the same arguments."""

import math
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

from conftest import missing, needs
from live_display import TOOLS, Display, Viewer, leftovers, printed

pytestmark = [pytest.mark.gl, pytest.mark.slow]

SMOKE = ["smoke", "--particles", "4096", "--size", "320x240"]
DEJONG = ["dejong", "--particles", "16384", "--size", "256x256"]


@pytest.fixture(scope="module")
def display():
    lacking = [tool for tool in TOOLS if shutil.which(tool) is None]
    if lacking:
        missing(f"the live tests need {', '.join(lacking)} (sh setup.sh test installs them)")
    screen = Display()
    yield screen
    screen.close()


def run_still(args, tmp_path, name):
    """``run``'s still, on desktop GL as the window draws (on ES, a sprite past the picture's
    edge is drawn in part: docs/backends.md)."""
    out = tmp_path / name
    subprocess.run([sys.executable, "-m", "es2particles", "run", *args, "--backend", "gl",
                    "--out", str(out)], check=True, capture_output=True, timeout=300)
    return np.asarray(Image.open(out).convert("RGB"))


def closing_line(viewer):
    status, out, err = viewer.finish()
    assert status == 0 and err == "", (status, err)
    return out.strip().splitlines()[-1]


def test_the_window_shows_the_scene_as_run_draws_it_and_keys_turn_the_camera(
        display, tmp_path):
    """Started paused, the window shows byte for byte the picture ``run`` writes; three presses
    of the left arrow turn the camera 15 degrees on the spot (the target swings about the eye),
    two of W walk it half a metre along the floor, page up raises it a tenth: the screen
    changes, and the closing line's camera is that float64 camera."""
    viewer = Viewer(display, [*SMOKE, "--paused"], tmp_path)
    first = viewer.settled()
    assert np.array_equal(first, run_still(SMOKE, tmp_path, "run.png")), \
        "the window's first frame is not run's still"
    viewer.keys("Left", "Left", "Left")
    turned = viewer.changed_from(first)
    viewer.keys("w", "w", "Prior")
    viewer.changed_from(turned)
    viewer.keys("Escape")
    line = closing_line(viewer)
    eye0, target0 = np.array([0.0, 2.6, 7.8]), np.array([0.0, 2.4, 0.0])  # smoke's camera
    look = target0 - eye0
    c, s = math.cos(math.radians(15)), math.sin(math.radians(15))
    look = np.array([c * look[0] + s * look[2], look[1], -s * look[0] + c * look[2]])
    walk = 0.5 * np.array([look[0], 0, look[2]]) / math.hypot(look[0], look[2])
    eye = eye0 + walk + [0, 0.1, 0]
    assert np.allclose(printed(line, "eye"), eye, atol=2e-6), line
    assert np.allclose(printed(line, "target"), eye + look, atol=2e-6), line
    assert leftovers(tmp_path) == ["run.png"]


def test_a_drag_orbits_and_the_wheel_zooms(display, tmp_path):
    """A drag of 96 pixels right and 24 down on empty sky turns the eye -0.96 radians about the
    vertical through the target and raises it 0.24 radians; two wheel notches towards the
    scene bring it to exp(-0.2) of its distance; shift+S writes what the window shows."""
    viewer = Viewer(display, [*SMOKE, "--paused"], tmp_path)
    first = viewer.settled()
    viewer.drag((8, 8), (104, 32))
    orbited = viewer.changed_from(first)
    viewer.wheel(2)
    zoomed = viewer.changed_from(orbited)
    viewer.keys("shift+s")  # a screenshot: SMOKE-001.png, what the window shows
    shot = tmp_path / "smoke-001.png"
    deadline = time.monotonic() + 30
    while not shot.exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    viewer.close_button()
    line = closing_line(viewer)
    assert np.array_equal(np.asarray(Image.open(shot).convert("RGB")), zoomed)
    target = np.array([0.0, 2.4, 0.0])
    d = np.array([0.0, 2.6, 7.8]) - target
    r, a, e = np.linalg.norm(d), math.atan2(d[0], d[2]), math.asin(d[1] / np.linalg.norm(d))
    a, e, r = a - 0.96, e + 0.24, r * math.exp(-0.2)
    eye = target + r * np.array([math.cos(e) * math.sin(a), math.sin(e), math.cos(e) * math.cos(a)])
    assert np.allclose(printed(line, "eye"), eye, atol=2e-6), line
    assert leftovers(tmp_path) == ["smoke-001.png"]


def pixel_of(point, eye, target, fov, size):
    """Where a world point lands in a picture of ``size`` seen from a camera at ``eye``."""
    f = np.subtract(target, eye) / np.linalg.norm(np.subtract(target, eye))
    s = np.cross(f, [0, 1, 0])
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    d = np.subtract(point, eye)
    t = math.tan(math.radians(fov) / 2)
    x, y = d @ s / (d @ f) / t / (size[0] / size[1]), d @ u / (d @ f) / t
    return (x + 1) / 2 * size[0], (1 - y) / 2 * size[1]


def test_dragging_the_sphere_moves_it_over_the_floor(display, tmp_path):
    """A drag that starts on the smoke's sphere moves it: the point grabbed on its surface
    follows the pointer over the level plane through it, 60 pixels to the right; the rest
    centre moves by as much. The screen changes, and a step (.) runs the air around it from
    there."""
    viewer = Viewer(display, [*SMOKE, "--paused"], tmp_path)
    first = viewer.settled()
    eye, target, size = (0.0, 2.6, 7.8), (0.0, 2.4, 0.0), (320, 240)
    # After the 180 steps of 1/30 s before the first frame, the sphere (rest centre (0, 2.4, 0))
    # has swayed by (1.1, 0, 0.3) sin(2 pi t / 7).
    sway = math.sin(2 * math.pi * 180 / 30 / 7)
    drawn = np.array([1.1 * sway, 2.4, 0.3 * sway])
    x, y = pixel_of(drawn, eye, target, 45.0, size)
    viewer.drag((round(x), round(y)), (round(x) + 60, round(y)))
    moved = viewer.changed_from(first)
    viewer.keys("period")
    viewer.changed_from(moved)
    viewer.keys("q")
    line = closing_line(viewer)
    centre = printed(line, "grip")
    # The ray through the pressed pixel meets the sphere at a point p; the drag moves p over the
    # plane y = p_y to where the ray through the released pixel meets it.
    f = np.subtract(target, eye) / np.linalg.norm(np.subtract(target, eye))
    s = np.cross(f, [0, 1, 0]) / np.linalg.norm(np.cross(f, [0, 1, 0]))
    u = np.cross(s, f)
    t = math.tan(math.radians(22.5))

    def ray(px, py):
        d = f + t * ((2 * px / 320 - 1) * 320 / 240 * s + (1 - 2 * py / 240) * u)
        return d / np.linalg.norm(d)

    d0 = ray(round(x), round(y))
    oc = np.subtract(eye, drawn)
    b = oc @ d0
    p = np.add(eye, (-b - math.sqrt(b * b - (oc @ oc - 0.7 ** 2))) * d0)
    d1 = ray(round(x) + 60, round(y))
    q = np.add(eye, (p[1] - eye[1]) / d1[1] * d1)
    assert np.allclose(centre, [q[0] - p[0], 2.4, q[2] - p[2]], atol=2e-6), line
    assert centre[0] > 0.5, line  # the rest centre moved right


def test_attractor_keys_change_the_coefficients_live(display, tmp_path):
    """Tab selects the next coefficient (b), = raises it by a 800th of its slider's range
    (0.01), and the paused picture takes a step to show it, as the page's sliders do."""
    viewer = Viewer(display, [*DEJONG, "--paused"], tmp_path)
    first = viewer.settled()
    viewer.keys("Tab", *["equal"] * 5)
    viewer.changed_from(first)
    viewer.keys("Escape")
    line = closing_line(viewer)
    assert printed(line, "a") == pytest.approx(1.4, abs=1e-9)
    assert printed(line, "b") == pytest.approx(-2.3 + 0.05, abs=1e-9), line


def test_closing_mid_run_exits_0_and_leaves_nothing(display, tmp_path):
    """Playing (steps by the clock), the close button ends it: status 0, no file, nothing on
    standard error; --screenshot writes the last frame shown."""
    viewer = Viewer(display, [*SMOKE, "--screenshot", "last.png"], tmp_path)
    time.sleep(1.0)  # a second of frames
    viewer.close_button()
    line = closing_line(viewer)
    assert "wrote last.png" in line and leftovers(tmp_path) == ["last.png"]
    assert Image.open(tmp_path / "last.png").size == (320, 240)


def test_a_window_larger_than_the_screen_is_one_line(display, tmp_path):
    result = subprocess.run([sys.executable, "-m", "es2particles", "view", "dejong", "--size",
                             "4000x300"], env=display.env, cwd=tmp_path, capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 2 and result.stderr.count("\n") == 1, result.stderr
    assert "--size 4000x300 is larger than the screen (1280x800)" in result.stderr
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("args", [["smoke"], ["dejong", "--size", "512x512"]],
                         ids=["smoke", "dejong"])
def test_frames_a_second_on_this_machine(display, tmp_path, args, record_property):
    """The scenes at their default particle counts, playing for 40 frames: the closing line
    gives frames a second and milliseconds a step (reported, not judged: tests check
    correctness only)."""
    viewer = Viewer(display, [*args, "--exit-after", "40"], tmp_path)
    line = closing_line(viewer)
    fps = float(line.split(" fps")[0].split()[-1])
    record_property("fps", fps)
    print(line)
    assert fps > 0


def test_the_air_follows_the_dragged_sphere(gl):
    """On EGL, no window: the smoke's sphere dragged 1.5 m along x over 6 steps. Each step's
    passes take the sphere where the hand has it and its velocity (u_sphere_drift): after the
    steps no living particle is inside the sphere where it now is (distances in float64 from the
    decoded positions; the smoke's dithered rounding stores a position within a code of its 8 m
    range), and the particles
    that were in the swept path were pushed out of it."""
    from es2particles.frame.pipeline import Pipeline
    from es2particles.live.view import LiveView
    from es2particles.scenes import Smoke

    with Pipeline(gl, Smoke(), particles=8192, size=(160, 120)) as pipeline:
        view = LiveView(pipeline, paused=True)
        view.start()
        before = pipeline.sim.download("position")
        start = view.grip_centre()
        view.centre = view.centre + [1.5, 0.0, 0.0]
        view.run_steps(6)
        centre = view.grip_centre()
        after = pipeline.sim.download("position")
    assert np.allclose(centre - start, [1.5, 0, 0], atol=0.25)  # plus the sway over 6 steps
    code = 8.0 / 65535 * math.sqrt(3)  # dithered rounding: within a code of 8 m per component
    inside = np.linalg.norm(after - centre, axis=1) < 0.7 - code
    assert not inside.any(), f"{inside.sum()} particles inside the dragged sphere"
    swept = np.linalg.norm(before - centre, axis=1) < 0.6  # where the sphere came to
    assert swept.sum() > 20, swept.sum()
    moved = np.linalg.norm(after[swept] - before[swept], axis=1)
    assert np.all(moved > 0.1 - code), moved.min()


def test_the_notebook_widget_draws_the_scene_and_orbits_with_the_mouse(tmp_path):
    """A notebook run headless on a real kernel: the widget shows itself as a widget view, its
    first frame is the picture ``run`` writes, and pointer events dragged 60 pixels across it
    give a frame from the orbited camera."""
    nbclient = needs("nbclient", "test")
    nbformat = needs("nbformat", "test")
    needs("jupyter_rfb", "notebook")

    cells = [
        "import numpy as np\n"
        "from es2particles.gl.egl import open_context\n"
        "from es2particles.frame.pipeline import Pipeline\n"
        "from es2particles.scenes import Smoke\n"
        "from es2particles.live.widget import LiveWidget\n"
        "ctx = open_context()\n"
        "widget = LiveWidget(Pipeline(ctx, Smoke(), particles=4096, size=(320, 240)))\n"
        "widget",
        "first = widget.get_frame()\n"
        "for kind, x in (('pointer_down', 20), ('pointer_move', 50), ('pointer_move', 80),\n"
        "                ('pointer_up', 80)):\n"
        "    widget.handle_event({'event_type': kind, 'x': x, 'y': 20, 'button': 1,\n"
        "                         'buttons': [1], 'modifiers': [], 'time_stamp': 0})\n"
        "second = widget.get_frame()\n"
        "np.save('first.npy', first)\n"
        "np.save('second.npy', second)\n"
        "print(','.join(map(str, widget.view.view.camera().eye)))",
    ]
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in cells])
    nbclient.NotebookClient(notebook, timeout=300, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    shown = notebook.cells[0].outputs[-1]
    assert "application/vnd.jupyter.widget-view+json" in shown["data"], shown
    first, second = np.load(tmp_path / "first.npy"), np.load(tmp_path / "second.npy")
    assert np.array_equal(first, run_still(SMOKE, tmp_path, "run.png"))
    assert np.abs(second.astype(int) - first).mean() > 5, "the drag changed nothing"
    eye = np.array([float(v) for v in notebook.cells[1].outputs[-1]["text"].split(",")])
    target = np.array([0.0, 2.4, 0.0])
    d = np.array([0.0, 2.6, 7.8]) - target
    a = math.atan2(d[0], d[2]) - 0.6
    r, e = np.linalg.norm(d), math.asin(d[1] / np.linalg.norm(d))
    want = target + r * np.array([math.cos(e) * math.sin(a), math.sin(e),
                                  math.cos(e) * math.cos(a)])
    assert np.allclose(eye, want, atol=1e-9)
