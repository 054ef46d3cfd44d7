"""Every code block of README.md and docs/ runs.

A fenced block says what it is in its info string, and each kind is carried out:

- ``python``: run as ``python -c`` in the page's temporary folder (a new process, the installed
  package), after the blocks before it on the page;
- ``sh``: each line run by bash in that folder, with this interpreter's ``bin`` first on the
  PATH; an ``es2particles run`` or ``export`` line gets ``--size 96x96 --particles 2048`` added
  at its end (``run sph``, whose count follows its spacing: ``--size 96x96 --spacing 0.1 --steps
  100``), so a page's commands stay quick here (the options are checked all the same). The
  README's first two ``sh`` blocks are the set-up commands, which CI runs as written (.ci/run);
- ``glsl file=NAME``, ``toml file=NAME``: written to NAME in the folder for the blocks after it
  (a shader a Python block loads, a run file a command reads); a ``toml`` block without a file
  is parsed;
- ``text``: what a program prints; not code.

Any other info string, or none, fails: every block is one of these.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import needs

ROOT = Path(__file__).resolve().parent.parent
FENCE = re.compile(r"^```([^\n]*)\n(.*?)^```$", re.M | re.S)
KINDS = ("python", "sh", "glsl", "toml", "text")
SMALL = ["--size", "96x96", "--particles", "2048"]


def pages():
    found = [ROOT / "README.md"] + sorted((ROOT / "docs").rglob("*.md"))
    return [p for p in found if "api" not in p.relative_to(ROOT).parts]


def blocks(page):
    """(kind, file or None, text) of each fenced block of ``page``."""
    out = []
    for info, text in FENCE.findall(page.read_text(encoding="utf-8")):
        words = info.split()
        kind = words[0] if words else ""
        named = [w[5:] for w in words[1:] if w.startswith("file=")]
        out.append((kind, named[0] if named else None, text))
    return out


PAGES = pages()
IDS = [str(p.relative_to(ROOT)) for p in PAGES]


@pytest.mark.parametrize("page", PAGES, ids=IDS)
def test_every_block_says_what_it_is(page):
    bad = [(kind, text[:40]) for kind, _, text in blocks(page) if kind not in KINDS]
    assert not bad, f"{page.name}: blocks of no known kind (one of {KINDS}): {bad}"
    for kind, name, text in blocks(page):
        if kind == "glsl":
            assert name, f"{page.name}: a glsl block names its file (```glsl file=NAME)"


def _small(line):
    words = line.split()
    if len(words) >= 3 and words[:3] == ["es2particles", "run", "sph"]:  # count from spacing
        return line + " --size 96x96 --spacing 0.1 --steps 100"
    if len(words) >= 3 and words[2] == "flame" and "smoke" not in words:  # no particles
        return line + " " + " ".join(SMALL[:2])
    if len(words) >= 2 and words[0] == "es2particles" and words[1] in ("run", "export") \
            and "--config" not in words:
        return line + " " + " ".join(SMALL)
    return line


def carry_out(page, folder):
    """Run ``page``'s blocks in order in ``folder``; returns what each printed."""
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}"
                                 f"{os.environ.get('PATH', '')}"}
    printed = []
    sh_seen = 0
    for kind, name, text in blocks(page):
        if name:
            (folder / name).write_text(text, encoding="utf-8")
            continue
        if kind == "toml":
            try:
                import tomllib
            except ImportError:  # Python < 3.11
                import tomli as tomllib
            tomllib.loads(text)
        elif kind == "python":
            result = subprocess.run([sys.executable, "-c", text], cwd=folder, env=env,
                                    capture_output=True, text=True, timeout=600)
            assert result.returncode == 0, f"{page.name}: python block failed:\n{text}\n" \
                                           f"{result.stderr}"
            printed.append(result.stdout)
        elif kind == "sh":
            sh_seen += 1
            if page.name == "README.md" and sh_seen <= 2:
                continue  # the set-up commands: CI runs them as written
            for line in text.splitlines():
                if not line.strip() or line.lstrip().startswith("#"):
                    continue
                command = _small(line.split(" #")[0].strip())
                result = subprocess.run(["bash", "-c", command], cwd=folder, env=env,
                                        capture_output=True, text=True, timeout=600)
                assert result.returncode == 0, f"{page.name}: `{command}` failed:\n" \
                                               f"{result.stderr}"
                printed.append(result.stdout)
    return printed


# What a page's blocks need beyond the package's own dependencies, by a sign in the page: the
# extra's module, and the extra.
PAGE_EXTRAS = {".mp4": ("imageio_ffmpeg", "video"), "LiveWidget": ("jupyter_rfb", "notebook")}


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.parametrize("page", PAGES, ids=IDS)
def test_every_block_runs(page, tmp_path):
    text = page.read_text()
    for sign, (module, extra) in PAGE_EXTRAS.items():
        if sign in text:
            needs(module, extra)
    carry_out(page, tmp_path)


def pinhole(points, eye, target, up, fov, size):
    """Pixel (column, row from the top) of world ``points`` seen by a pinhole camera: an
    independent float64 projection (not the package's camera)."""
    eye, target, up = (np.asarray(v, float) for v in (eye, target, up))
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    d = points - eye
    depth = d @ forward
    focal = size[1] / 2 / np.tan(np.radians(fov) / 2)
    return (size[0] / 2 + focal * (d @ right) / depth,
            size[1] / 2 - focal * (d @ true_up) / depth)


@pytest.mark.gl
def test_the_lorenz_example_draws_its_butterfly(tmp_path):
    """The page's Lorenz scene against the same system in float64: 2^15 points from the same
    box, 2000 midpoint steps, projected by a pinhole camera. The lit pixels agree in 20x20
    blocks, and the two fixed points' eyes are darker than the wings around them."""
    from PIL import Image

    carry_out(ROOT / "docs" / "writing-a-scene.md", tmp_path)
    image = np.asarray(Image.open(tmp_path / "lorenz.png")).astype(float)
    h, w = image.shape[:2]
    lit = image.max(axis=2) > image[0, 0].max() + 12

    rng = np.random.default_rng(1)
    p = rng.uniform((-15, -15, 5), (15, 15, 40), (2 ** 15, 3))
    rho, beta, dt = 28.0, 8 / 3, 0.005

    def f(q):
        return np.stack([10 * (q[:, 1] - q[:, 0]), q[:, 0] * (rho - q[:, 2]) - q[:, 1],
                         q[:, 0] * q[:, 1] - beta * q[:, 2]], axis=1)

    for _ in range(2000):
        p = p + dt * f(p + 0.5 * dt * f(p))
    camera = dict(eye=(60, -60, 25), target=(0, 0, 25), up=(0, 0, 1), fov=45.0, size=(w, h))
    u, v = pinhole(p, **camera)
    inside = (u >= 0) & (u < w) & (v >= 0) & (v < h)
    reference = np.zeros((h, w))
    np.add.at(reference, (v[inside].astype(int), u[inside].astype(int)), 1)

    def blocks(a):
        return a[:h // 20 * 20, :w // 20 * 20].reshape(h // 20, 20, w // 20, 20).mean(axis=(1, 3))

    r = np.corrcoef(blocks(lit).ravel(), blocks(reference > 0).ravel())[0, 1]
    print(f"lit pixels {lit.mean():.3f}, block correlation with float64 {r:.3f}")
    assert 0.02 < lit.mean() < 0.5 and r > 0.9
    brightness = image.max(axis=2)
    yy, xx = np.mgrid[0:h, 0:w]
    s = np.sqrt(beta * (rho - 1))
    for fixed in ((s, s, rho - 1), (-s, -s, rho - 1)):
        cu, cv = pinhole(np.array([fixed], float), **camera)
        r2 = (xx - cu[0]) ** 2 + (yy - cv[0]) ** 2
        eye_mean = brightness[r2 < 6 ** 2].mean()
        wing_mean = brightness[(r2 > 25 ** 2) & (r2 < 45 ** 2)].mean()
        print(f"fixed point {fixed}: eye {eye_mean:.1f}, wing around it {wing_mean:.1f}")
        assert eye_mean < wing_mean
