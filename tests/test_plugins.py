"""Scenes as plug-ins: a tiny package registers a scene under the entry-point group
``es2particles.scenes``; pip installs it (a real wheel, into a folder of its own) and the
command line lists and runs it with no change to es2particles."""

import base64
import hashlib
import os
import subprocess
import sys
import zipfile

import numpy as np
import pytest
from PIL import Image

pytestmark = [pytest.mark.gl, pytest.mark.slow]

SCENE = '''"""A tiny plug-in scene: particles spiral towards the centre."""
from importlib.resources import files

from es2particles import PassGraph
from es2particles.scenes import Fill, Scene


class Spiral(Scene):
    """Particles spiral towards the centre (a plug-in scene)."""

    name = "spiral"

    def graph(self):
        g = PassGraph()
        g.quantity("position", -1, 1)
        g.add("spiral", str(files(__package__) / "spiral.frag"), writes="position",
              reads=["position"], uniforms={"u_turn": 0.05})
        return g

    def start(self, count, rng):
        return {"position": Fill((-1, -1), (1, 1))}
'''

SHADER = """#version 100
// Turn each particle a little and pull it in.
void main()
{
    vec2 p = read_position(v_uv);
    float c = cos(u_turn), s = sin(u_turn);
    write_position(0.99 * vec2(c * p.x - s * p.y, s * p.x + c * p.y));
}
"""


def build_wheel(folder):
    """A wheel of package ``tinyscene`` with its entry point, written by hand (the format is a
    zip with a dist-info folder; no build back-end needed, so no network)."""
    files = {
        "tinyscene/__init__.py": SCENE,
        "tinyscene/spiral.frag": SHADER,
        "tinyscene-1.0.dist-info/METADATA": "Metadata-Version: 2.1\nName: tinyscene\nVersion: 1.0\n",
        "tinyscene-1.0.dist-info/WHEEL": "Wheel-Version: 1.0\nGenerator: test\nRoot-Is-Purelib: "
                                         "true\nTag: py3-none-any\n",
        "tinyscene-1.0.dist-info/entry_points.txt": "[es2particles.scenes]\n"
                                                    "spiral = tinyscene:Spiral\n",
    }
    record = []
    for name, text in files.items():
        digest = base64.urlsafe_b64encode(hashlib.sha256(text.encode()).digest()).rstrip(b"=")
        record.append(f"{name},sha256={digest.decode()},{len(text.encode())}")
    record.append("tinyscene-1.0.dist-info/RECORD,,")
    files["tinyscene-1.0.dist-info/RECORD"] = "\n".join(record) + "\n"
    wheel = folder / "tinyscene-1.0-py3-none-any.whl"
    with zipfile.ZipFile(wheel, "w") as archive:
        for name, text in files.items():
            archive.writestr(name, text)
    return wheel


def check_spiral_picture(path, steps):
    """The picture the plug-in scene draws: its particles start uniform over the view [-1, 1]^2
    and each step turns them by u_turn = 0.05 radians and pulls them in by 0.99, so after
    ``steps`` they fill that square turned by 0.05 steps and shrunk by 0.99^steps (float64 here).
    16 particles a pixel on average: every pixel well inside is lit, every pixel well outside
    is the background (the picture's y up: the square turned the other way, or not pulled in,
    lights pixels of the outside)."""
    with Image.open(path) as image:
        assert image.size == (64, 64), image.size
        grey = np.asarray(image.convert("RGB")).max(axis=2)
    h, w = grey.shape
    rows, columns = np.mgrid[0:h, 0:w]
    x, y = (columns + 0.5) / w * 2 - 1, 1 - (rows + 0.5) / h * 2  # pixel centres in the view
    turn, scale = 0.05 * steps, 0.99 ** steps
    # Each pixel centre carried back to the start: inside the square where |u|, |v| <= 1.
    u = (np.cos(turn) * x + np.sin(turn) * y) / scale
    v = (-np.sin(turn) * x + np.cos(turn) * y) / scale
    reach = np.maximum(np.abs(u), np.abs(v))
    margin = 1.5 * (2 / w) / scale  # a pixel and a half, carried back
    inside, outside = reach <= 1 - margin, reach >= 1 + margin
    assert inside.sum() > 0.6 * h * w and outside.sum() > 0.1 * h * w  # both are tested
    print(f"inside: {inside.sum()} pixels, darkest {grey[inside].min()}; outside: "
          f"{outside.sum()} pixels, brightest {grey[outside].max()}")
    assert grey[inside].min() >= 40, f"{np.count_nonzero(grey[inside] < 40)} pixels inside dark"
    assert grey[outside].max() <= 16, f"{np.count_nonzero(grey[outside] > 16)} pixels outside lit"


def with_path(folder):
    """The environment with ``folder`` first on PYTHONPATH, what was there kept (where the
    package runs from a checkout on PYTHONPATH, as on the GPU machine, not installed)."""
    kept = os.environ.get("PYTHONPATH")
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(folder)] + ([kept] if kept else [])))


def test_an_installed_plug_in_scene_is_listed_and_runs(tmp_path):
    wheel = build_wheel(tmp_path)
    target = tmp_path / "site"
    install = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                              "--no-index", "--target", str(target), str(wheel)],
                             capture_output=True, text=True)
    assert install.returncode == 0, install.stderr
    env = with_path(target)
    cli = [sys.executable, "-c", "import sys; from es2particles.cli import main; "
                                 "sys.exit(main(sys.argv[1:]))"]
    listed = subprocess.run(cli + ["run", "--help"], capture_output=True, text=True, env=env,
                            cwd=tmp_path)
    assert listed.returncode == 0, listed.stderr
    assert "spiral" in listed.stdout and "dejong" in listed.stdout
    out = tmp_path / "spiral.png"
    run = subprocess.run(cli + ["run", "spiral", "--particles", str(2 ** 16), "--size", "64x64",
                                "--steps", "10", "--out", str(out)],
                         capture_output=True, text=True, env=env, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    check_spiral_picture(out, steps=10)
    plan = subprocess.run(cli + ["plan", "spiral", "--particles", "4096", "--size", "64x64"],
                          capture_output=True, text=True, env=env, cwd=tmp_path)
    assert "spiral: " in plan.stdout and "tinyscene/spiral.frag writes position" in plan.stdout


def test_a_broken_plug_in_is_named_and_left_out(tmp_path):
    dist = tmp_path / "broken-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: broken\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[es2particles.scenes]\nbroken = no_such_module:X\n")
    env = with_path(tmp_path)
    result = subprocess.run([sys.executable, "-c", "from es2particles.scenes import "
                             "installed_scenes; print(sorted(installed_scenes()))"],
                            capture_output=True, text=True, env=env, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "['boids', 'clifford', 'collision', 'collision3d', 'confetti', 'dejong', " \
           "'flame', 'fountain', 'liquid', 'smoke', 'sph', 'wind']" in result.stdout
    assert "scene 'broken' (no_such_module:X) could not be loaded: ModuleNotFoundError" in \
        result.stderr
