"""The Clifford attractor against an independent float64 numpy run of its map, as de Jong's."""

import numpy as np
import pytest

from conftest import run_scene
from es2particles import Simulation
from es2particles.cli import main
from es2particles.scenes import Clifford
from es2particles.scenes.clifford import clifford_map

ISSUE_COEFFICIENTS = (-1.4, 1.6, 1.0, 0.7)
TRIG_EPS = 2.0 ** -20


def reference(scene, start, iterations):
    """float64: the map, then the clamp into the range that a write does."""
    x0, y0, x1, y1 = scene.range
    return np.clip(clifford_map(start.astype(np.float64), scene.coefficients, iterations),
                   (x0, y0), (x1, y1))


def one_step_bound(scene, iterations):
    """Half a code of each axis's range, plus float32 trig error carried by the map's Lipschitz
    constant L = max(|a| (1 + |c|), |b| (1 + |d|))."""
    a, b, c, d = (abs(k) for k in scene.coefficients)
    lipschitz = max(a * (1 + c), b * (1 + d), 1.0)
    x0, y0, x1, y1 = scene.range
    half_code = max(x1 - x0, y1 - y0) / 65024 / 2
    return half_code + sum(lipschitz ** i for i in range(iterations)) * 2 * TRIG_EPS * (1 + max(c, d))


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
    error = np.abs(got - reference(scene, start, 3)).max()
    bound = one_step_bound(scene, 3)
    print(f"Clifford one step: max |error| {error:.3e} (bound {bound:.3e})")
    assert error <= bound


def test_stateful_density_correlates_with_float64(gl):
    scene = Clifford(coefficients=ISSUE_COEFFICIENTS)  # stateful, dithered: the scene's defaults
    steps = 20
    start, got = run_scene(gl, scene, 2 ** 18, steps, seed=7)
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
    error = np.abs(got - reference(scene, start, 3)).max()
    # the rasteriser interpolates v_uv in float32: a few ulps of start error, carried by L^3
    bound = one_step_bound(scene, 3) + 4 * 2.0 ** -23 * 4 * 2.24 ** 3
    assert error <= bound, (error, bound)


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
