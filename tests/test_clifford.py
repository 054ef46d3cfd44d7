"""The Clifford attractor against an independent float64 numpy run of its map, as de Jong's: each
particle within a bound derived from the format and float32 (tests/bounds.py)."""

import numpy as np
import pytest

from bounds import U, half_code, read_jitter, rounding_error, trig_map_error
from conftest import run_scene
from es2particles import Simulation
from es2particles.cli import main
from es2particles.gl.bindings import READ_SALTS
from es2particles.scenes import Clifford
from es2particles.scenes.clifford import clifford_map


class Clifford16(Clifford):
    """Clifford with its state in 16-bit codes, where rounding acts (the scene's own is 32-bit)."""
    state_bits = 16

ISSUE_COEFFICIENTS = (-1.4, 1.6, 1.0, 0.7)


def reference(scene, start, iterations):
    """float64: the map, then the clamp into the range that a write does."""
    x0, y0, x1, y1 = scene.range
    return np.clip(clifford_map(start.astype(np.float64), scene.coefficients, iterations),
                   (x0, y0), (x1, y1))


def map_terms(coefficients):
    """x' = sin(a y) + c cos(a x), y' = sin(b x) + d cos(b y) as trig_map_error's terms."""
    a, b, c, d = coefficients
    return [[(1, a, 1, "sin"), (c, a, 0, "cos")], [(1, b, 0, "sin"), (d, b, 1, "cos")]]


def one_step_bound(scene, start, iterations, dithered=False, start_error=None):
    """Each particle's largest |GPU - float64| after one step from ``start``: the float32 map's
    error carried along its float64 path (the start decoded again by the shader: one rounding of
    each of the decode's two steps), plus the written position's rounding on the wider axis."""
    x0, y0, x1, y1 = scene.range
    reach = max(abs(x0), abs(y0), x1, y1)
    start_error = 2 * U * reach if start_error is None else start_error
    _, carried = trig_map_error(map_terms(scene.coefficients), start, start_error, iterations)
    widest = (x0, x1) if x1 - x0 >= y1 - y0 else (y0, y1)
    return carried + rounding_error("rgba8", *widest, dithered=dithered)


def check_one_step(label, scene, got, exact, bound):
    """Every particle within its own bound (printed with the worst particle's error)."""
    error = np.abs(got - exact).max(axis=1)
    worst = np.argmax(error - bound)
    x0, _, x1, _ = scene.range
    print(f"{label}: max |error| {error.max():.3e}, half code {half_code(x0, x1):.3e}; nearest "
          f"to its bound: particle {worst}, {error[worst]:.3e} of {bound[worst]:.3e}")
    assert error[worst] <= bound[worst], (f"{label}: particle {worst} errs by {error[worst]:.3e}, "
                                          f"above its bound {bound[worst]:.3e}")


def histogram(scene, points, bins):
    x0, y0, x1, y1 = scene.range
    h, _, _ = np.histogram2d(points[:, 0], points[:, 1], bins=bins, range=[[x0, x1], [y0, y1]])
    return h.ravel()


def test_view_and_range_come_from_the_coefficients():
    scene = Clifford(coefficients=ISSUE_COEFFICIENTS)
    assert scene.range == (-2.0, -1.7, 2.0, 1.7)
    assert np.allclose(scene.view, (-2.2, -1.87, 2.2, 1.87))  # 5% margin each side
    points = clifford_map(np.random.default_rng(0).uniform(-50, 50, (10 ** 5, 2)),
                          ISSUE_COEFFICIENTS)
    assert np.all(np.abs(points) <= (2.0, 1.7))  # the map's image lies in the range


def test_one_step_matches_float64(gl):
    scene = Clifford(coefficients=ISSUE_COEFFICIENTS)
    start, got = run_scene(gl, scene, 2 ** 16, 1, seed=5, rounding="nearest")
    check_one_step("Clifford one step", scene, got, reference(scene, start, 3),
                   one_step_bound(scene, start, 3))


@pytest.mark.parametrize("rounding", ["jitter", "dither"])
def test_stateful_density_correlates_with_float64(gl, rounding):
    """Stateful in 16-bit codes, with jittered reads or dithered writes. Under jitter each
    step starts from the stored positions plus each read's offset within its code
    (bounds.read_jitter); dithered, from the stored positions, and the write errs by a code."""
    scene = Clifford16(coefficients=ISSUE_COEFFICIENTS)
    steps = 20
    x0, y0, x1, y1 = scene.range
    with Simulation(gl, scene.graph(), 2 ** 18, rounding=rounding) as sim:
        scene.initialise(sim, np.random.default_rng(7))
        texels = np.floor(sim.layout.texel_uv() * sim.layout.size)
        start = before = sim.download("position")
        for step in range(steps):  # step by step: the map is chaotic
            if rounding == "jitter":
                offsets, start_error = read_jitter(texels, sim.steps_done, READ_SALTS["pass"],
                                                   (x1 - x0, y1 - y0))
                seen, start_error = before + offsets, start_error.max(axis=1)
            else:
                seen, start_error = before, None
            sim.step()
            got = sim.download("position")
            check_one_step(f"Clifford stateful step {step + 1} ({rounding})", scene, got,
                           reference(scene, seen, 3),
                           one_step_bound(scene, seen, 3, dithered=rounding == "dither",
                                          start_error=start_error))
            before = got
    exact = start.copy()
    for _ in range(steps):
        exact = reference(scene, exact, 3)
    r = np.corrcoef(histogram(scene, got, 64), histogram(scene, exact, 64))[0, 1]
    print(f"Clifford 64x64 density correlation after {steps} steps of 2^18 particles: {r:.5f}")
    assert r >= 0.99


def test_reseeded_clifford_matches_float64_per_particle(gl):
    scene = Clifford(coefficients=ISSUE_COEFFICIENTS, reseed=True)
    with Simulation(gl, scene.graph(), 2 ** 16) as sim:
        sim.step()
        got = sim.download("position")
        x0, y0, x1, y1 = scene.range
        start = (x0, y0) + sim.layout.texel_uv().astype(np.float64) * (x1 - x0, y1 - y0)
    # the rasteriser interpolates v_uv in float32: 4 ulps of uv times the span, then one rounding
    start_error = 4 * 2.0 ** -23 * max(x1 - x0, y1 - y0) + 2 * U * max(x1, y1)
    check_one_step("reseeded Clifford", scene, got, reference(scene, start, 3),
                   one_step_bound(scene, start, 3, start_error=start_error))


@pytest.mark.gl
def test_cli_runs_clifford(tmp_path, capsys):
    out = tmp_path / "c.png"
    assert main(["run", "clifford", "--a", "-1.4", "--b", "1.6", "--c", "1.0", "--d", "0.7",
                 "--particles", "65536", "--size", "256x256", "--out", str(out)]) == 0
    from PIL import Image

    with Image.open(out) as image:
        pixels = np.asarray(image)
    assert pixels.shape == (256, 256, 3)
    lit = (pixels.max(axis=2) > 16).mean()
    assert 0.05 < lit < 0.9, lit  # an attractor, not a blank or a flood
    assert main(["plan", "clifford", "--particles", "4096", "--size", "64x64"]) == 0
    assert "clifford: attractors/clifford.frag writes position" in capsys.readouterr().out
