"""Scenes as plug-ins: a tiny package registers a scene under the entry-point group
``es2particles.scenes``; pip installs it (a real wheel, into a folder of its own) and the
command line lists and runs it with no change to es2particles."""

import base64
import hashlib
import os
import subprocess
import sys
import zipfile

import pytest

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


def test_an_installed_plug_in_scene_is_listed_and_runs(tmp_path):
    wheel = build_wheel(tmp_path)
    target = tmp_path / "site"
    install = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                              "--no-index", "--target", str(target), str(wheel)],
                             capture_output=True, text=True)
    assert install.returncode == 0, install.stderr
    env = dict(os.environ, PYTHONPATH=str(target))
    cli = [sys.executable, "-c", "import sys; from es2particles.cli import main; "
                                 "sys.exit(main(sys.argv[1:]))"]
    listed = subprocess.run(cli + ["run", "--help"], capture_output=True, text=True, env=env,
                            cwd=tmp_path)
    assert listed.returncode == 0, listed.stderr
    assert "spiral" in listed.stdout and "dejong" in listed.stdout
    out = tmp_path / "spiral.png"
    run = subprocess.run(cli + ["run", "spiral", "--particles", "4096", "--size", "64x64",
                                "--steps", "10", "--out", str(out)],
                         capture_output=True, text=True, env=env, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert out.stat().st_size > 0
    plan = subprocess.run(cli + ["plan", "spiral", "--particles", "4096", "--size", "64x64"],
                          capture_output=True, text=True, env=env, cwd=tmp_path)
    assert "spiral: " in plan.stdout and "tinyscene/spiral.frag writes position" in plan.stdout


def test_a_broken_plug_in_is_named_and_left_out(tmp_path):
    dist = tmp_path / "broken-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: broken\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[es2particles.scenes]\nbroken = no_such_module:X\n")
    env = dict(os.environ, PYTHONPATH=str(tmp_path))
    result = subprocess.run([sys.executable, "-c", "from es2particles.scenes import "
                             "installed_scenes; print(sorted(installed_scenes()))"],
                            capture_output=True, text=True, env=env, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "['clifford', 'collision', 'collision3d', 'confetti', 'dejong', 'fountain', " \
           "'smoke']" in result.stdout
    assert "scene 'broken' (no_such_module:X) could not be loaded: ModuleNotFoundError" in \
        result.stderr
