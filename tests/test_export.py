"""The WebGL 1 page of `es2particles export`, opened in headless Chromium (a real browser and its
own OpenGL ES 2.0 implementation, ANGLE over SwiftShader without a GPU) and compared with the EGL
run of the same plan: packed state bytes, density, picture. Chromium is Debian's ``chromium``,
driven by playwright's Python package; in CI its absence is a failure, elsewhere a skip."""

import base64
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import glslang
from es2particles.export.page import page_plan, write_page
from es2particles.frame.pipeline import Pipeline
from es2particles.scenes.clifford import Clifford
from es2particles.scenes.collision import Collision
from es2particles.scenes.dejong import DeJong

SHOTS = Path(__file__).resolve().parent.parent / "out" / "webgl"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--no-first-run", "--disable-sync",
                  "--disable-background-networking", "--disable-component-update"]
PATHS = ("float", "half", "bytes")


def chromium():
    tool = shutil.which("chromium") or shutil.which("chromium-browser")
    missing = []
    if tool is None:
        missing.append("Chromium (Debian package chromium)")
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        missing.append("playwright (the test extra)")
    if missing:
        if os.environ.get("CI"):
            pytest.fail(f"{' and '.join(missing)} not installed; CI must install them")
        pytest.skip(f"{' and '.join(missing)} not installed")
    return tool


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright

    tool = chromium()
    with sync_playwright() as driver:
        launched = driver.chromium.launch(executable_path=tool, args=CHROMIUM_FLAGS)
        yield launched
        launched.close()


class Page:
    """One exported page open in the browser; every request it makes is recorded and refused
    unless it is the page's own file."""

    def __init__(self, browser, path, query=""):
        self.requests = []
        self.page = browser.new_page()
        self.errors = []
        self.page.on("pageerror", lambda error: self.errors.append(str(error)))

        def route(request_route):
            self.requests.append(request_route.request.url)
            if request_route.request.url.startswith(path.as_uri()):
                request_route.continue_()
            else:
                request_route.abort()

        self.page.route("**/*", route)
        self.page.goto(path.as_uri() + "?paused" + query)
        self.page.wait_for_function("window.es2particles !== undefined", timeout=120000)

    def call(self, expression):
        return self.page.evaluate(f"window.es2particles.{expression}")

    def close(self):
        self.page.close()


def egl_run(gl, scene, steps, **settings):
    """State texels of the position (count, 4), density (h, w) and picture (h, w, 3) after
    ``steps`` steps on EGL."""
    with Pipeline(gl, scene, steps=0, bloom=None, **settings) as pipeline:
        pipeline.step(steps)
        texels = pipeline.sim.buffers["position"].read_texels()[:, 0]
        density = pipeline.density()
        w, h = pipeline.size
        counts = np.frombuffer(density.read(), np.float32).reshape(h, w, -1)[..., 0].copy()
        pipeline.final = pipeline.post.apply(density)
        return texels, counts, pipeline.image()


def web_run(browser, tmp_path, scene, steps, path=None, **settings):
    page_path = tmp_path / f"{scene.name}.html"
    write_page(page_plan(scene, steps=0, **settings), page_path)
    page = Page(browser, page_path, f"&density={path}" if path else "")
    try:
        assert not page.errors and not page.call("error"), (page.errors, page.call("error"))
        page.call(f"step({steps})")
        facts = page.call("facts")
        w, h = settings["size"]
        texels = np.frombuffer(base64.b64decode(page.call("state('position')")), np.uint8)
        density = page.call("density()")
        counts = np.frombuffer(base64.b64decode(density["values"]), np.float32).reshape(h, w)
        image = np.frombuffer(base64.b64decode(page.call("image()")), np.uint8).reshape(h, w, 4)
        SHOTS.mkdir(parents=True, exist_ok=True)
        # out/webgl/dejong-auto-default.png is the README's picture of the page
        shot = f"{scene.name}-{path or 'auto'}-{settings.get('rounding', 'default')}.png"
        page.page.screenshot(path=str(SHOTS / shot))
        outside = [url for url in page.requests if not url.startswith(page_path.as_uri())]
        return {"texels": texels.reshape(-1, 4), "density": counts, "flagged":
                density["flagged"], "image": image[::-1, :, :3], "facts": facts,
                "outside": outside, "path": page.call("path")}
    finally:
        page.close()


@pytest.mark.parametrize("path", PATHS)
def test_reseeded_dejong_page_matches_egl_byte_for_byte(gl, browser, tmp_path, path):
    """The article's mode: the packed state bytes are identical, and so is the density (every
    pixel's count), on each of the three density paths."""
    scene, n, size, steps = DeJong(reseed=True), 2 ** 18, (512, 512), 2
    texels, counts, image = egl_run(gl, scene, steps, particles=n, size=size)
    web = web_run(browser, tmp_path, scene, steps, path, particles=n, size=size)
    assert web["path"] == path
    assert web["outside"] == [], f"the page asked the network for {web['outside']}"
    same = np.all(web["texels"][:n] == texels, axis=1)
    assert same.all(), (f"{path}: {np.count_nonzero(~same)} of {n} position texels differ from "
                        f"EGL's, first at particle {np.argmin(same)}")
    assert web["flagged"] == 0
    r = np.corrcoef(web["density"].ravel(), counts.ravel())[0, 1]
    exact = np.mean(web["density"] == counts)
    assert r >= 0.999 and exact == 1.0, f"{path}: density correlation {r:.6f}, {exact:.2%} exact"
    assert counts.sum() == n  # every particle inside the view, counted once
    # The post passes are the same shaders on another driver: identical here; another driver's
    # linear filtering may round a channel the other way, by one code.
    diff = np.abs(web["image"].astype(int) - image.astype(int))
    print(f"{path}: {n} texels identical, density exact on {exact:.2%} of the pixels (r {r:.6f}); "
          f"picture mean difference {diff.mean():.3f} codes, largest {diff.max()}")
    assert diff.max() <= 1, (diff.mean(), diff.max())


def test_stateful_dejong_page_draws_the_same_attractor(gl, browser, tmp_path):
    """Stateful runs round stochastically from a hash whose float arithmetic drivers may fuse
    differently, and the map is chaotic: the particles part ways within a few steps, but the
    picture is the same attractor. Compared in 8x8-pixel blocks, which average out which
    particle lit which pixel."""
    scene, n, size, steps = DeJong(), 2 ** 18, (512, 512), 20
    _, counts, _ = egl_run(gl, scene, steps, particles=n, size=size)
    web = web_run(browser, tmp_path, scene, steps, particles=n, size=size)

    def blocks(d):
        return d.reshape(64, 8, 64, 8).sum(axis=(1, 3)).ravel()

    r = np.corrcoef(blocks(web["density"]), blocks(counts))[0, 1]
    print(f"stateful, dithered: block density correlation {r:.5f} after {steps} steps")
    assert r >= 0.999, f"block density correlation {r:.5f}"


def test_stateful_dejong_with_nearest_rounding_stays_identical(gl, browser, tmp_path):
    """Without dither nothing but + - * floor and the page's own sin and cos enter the state:
    the same bytes after several steps of the chaotic map."""
    scene, n, size, steps = DeJong(), 2 ** 16, (256, 256), 5
    texels, _, _ = egl_run(gl, scene, steps, particles=n, size=size, rounding="nearest")
    web = web_run(browser, tmp_path, scene, steps, particles=n, size=size, rounding="nearest")
    same = np.all(web["texels"][:n] == texels, axis=1)
    assert same.all(), f"{np.count_nonzero(~same)} of {n} texels differ after {steps} steps"


def test_collision_page_runs_with_life_and_scene_textures(gl, browser, tmp_path):
    """The 2D collision fountain: two quantities, a field texture, points that fade with age
    (counted in 1/8 steps on the bytes path). Emission and dither part ways between drivers, so
    the picture is compared in blocks."""
    scene, size, steps = Collision(), (256, 256), 120
    for path in ("float", "bytes"):
        _, counts, _ = egl_run(gl, scene, steps, particles=2 ** 15, size=size)
        web = web_run(browser, tmp_path, scene, steps, path, particles=2 ** 15, size=size)
        d = web["density"]
        assert np.isfinite(d).all() and d.sum() > 0

        def blocks(x):
            return x.reshape(32, 8, 32, 8).sum(axis=(1, 3)).ravel()

        r = np.corrcoef(blocks(d), blocks(counts))[0, 1]
        print(f"collision, {path}: block density correlation {r:.4f}, {web['flagged']} flagged")
        assert r >= 0.99, f"{path}: block density correlation {r:.4f}"


def test_page_names_a_density_path_it_does_not_have(browser, tmp_path):
    page_path = tmp_path / "page.html"
    write_page(page_plan(Clifford(), particles=4096, size=(64, 64)), page_path)
    page = Page(browser, page_path, "&density=tiles")
    try:
        assert "density=tiles: the paths are float, half, bytes" in page.call("error")
        assert "density=tiles" in page.page.inner_text("#problems")
    finally:
        page.close()


def test_every_program_of_a_page_is_valid_glsl_es_100(tmp_path):
    """What the page compiles, checked by the Khronos reference compiler (the same text EGL
    compiles: sources come from the one expander, interface included)."""
    tool = glslang()
    for scene in (DeJong(), DeJong(reseed=True), Clifford(), Collision()):
        plan = page_plan(scene, particles=1024, size=(64, 64))
        for program in plan["programs"]:
            for text, suffix in ((program["vertex"], ".vert"), (program["fragment"], ".frag")):
                target = tmp_path / f"shader{suffix}"
                target.write_text(text)
                result = subprocess.run([tool, str(target)], capture_output=True, text=True)
                assert result.returncode == 0, f"{scene.name} {program['name']}:\n{result.stdout}"


def cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "es2particles", *args], capture_output=True,
                          text=True, cwd=cwd)


@pytest.mark.parametrize("args, message", [
    (["export", "fountain", "--out", "p.html"], "'fountain' draws 3D sprites"),
    (["export", "dejong", "--format", "rgba16f", "--out", "p.html"], "--format rgba16f"),
    (["export", "dejong", "--accumulate", "4", "--out", "p.html"], "--accumulate"),
    (["export", "dejong", "--out", "p.htm"], "--out must end in .html"),
    (["export", "dejong", "--animate-to", "1,2,3,4", "--out", "p.html"], "--animate-to"),
    (["export", "dejong", "--size", "5000x5000", "--out", "p.html"], "size width"),
])
def test_export_refuses_in_one_line(tmp_path, args, message):
    result = cli(*args, cwd=tmp_path)
    assert result.returncode == 2 and message in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and "Traceback" not in result.stderr
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_export_writes_one_self_contained_page(tmp_path):
    result = cli("export", "dejong", "--particles", "4096", "--size", "64x64", "--out",
                 "page.html", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    text = (tmp_path / "page.html").read_text()
    assert text.count("<script") == 2 and "src=" not in text and "http" not in text.lower()
    assert "{{" not in text
