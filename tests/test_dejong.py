"""The de Jong scene against an independent float64 numpy run of the same map."""

import numpy as np
import pytest

from conftest import run_scene
from es2particles import Simulation
from es2particles.scenes.dejong import ARTICLE_COEFFICIENTS, DeJong, dejong_map

HALF_STEP = 2 / 65024  # half a code of the packed range [-2, 2]
TRIG_EPS = 2.0 ** -20  # a generous float32 sin/cos error on arguments of a few units


def one_step_bound(coefficients, iterations, start_error=0.0):
    """Max world error of one GPU step: the output's half code, plus float32 trig error (and any
    start error) carried through the iterations by the map's Lipschitz constant L."""
    a, b, c, d = (abs(k) for k in coefficients)
    lipschitz = max(a + b, c + d, 1.0)
    carried = sum(lipschitz ** i for i in range(iterations)) * 2 * TRIG_EPS
    return HALF_STEP + carried + lipschitz ** iterations * start_error


def reference(start, coefficients, iterations):
    return np.clip(dejong_map(start.astype(np.float64), coefficients, iterations), -2, 2)


def histogram(points, bins):
    h, _, _ = np.histogram2d(points[:, 0], points[:, 1], bins=bins, range=[[-2, 2], [-2, 2]])
    return h.ravel()


@pytest.mark.parametrize("coefficients", [ARTICLE_COEFFICIENTS, (2.01, -2.53, 1.61, -0.33)])
def test_one_step_matches_float64_within_the_packing_and_trig_bound(gl, coefficients):
    start, got = run_scene(gl, DeJong(coefficients=coefficients, iterations=3), 2 ** 16, 1, seed=5,
                           rounding="nearest")
    error = np.abs(got - reference(start, coefficients, 3)).max()
    bound = one_step_bound(coefficients, 3)
    print(f"de Jong one step {coefficients}: max |error| = {error:.3e} world units "
          f"(bound {bound:.3e}; half code {HALF_STEP:.3e})")
    assert error <= bound


def test_density_after_20_stateful_steps_correlates_with_float64(gl):
    steps = 20
    start, got = run_scene(gl, DeJong(coefficients=ARTICLE_COEFFICIENTS), 2 ** 18, steps, seed=7,
                           rounding="nearest")
    exact = start.copy()
    for _ in range(steps):
        exact = reference(exact, ARTICLE_COEFFICIENTS, 3)
    r = np.corrcoef(histogram(got, 64), histogram(exact, 64))[0, 1]
    print(f"64x64 density correlation after {steps} steps of 2^18 particles: {r:.5f}")
    assert r >= 0.99


def test_reseed_mode_matches_float64_per_particle_and_in_density(gl):
    scene = DeJong(coefficients=ARTICLE_COEFFICIENTS, reseed=True)
    n = 2 ** 20
    with Simulation(gl, scene.graph(), n) as sim:
        assert sim.plan.buffers == {"position": 1}  # nothing reads last step's position
        sim.step()
        got = sim.download("position")
        start = -2 + 4 * sim.layout.texel_uv().astype(np.float64)  # the texel grid
    exact = reference(start, ARTICLE_COEFFICIENTS, 3)
    error = np.abs(got - exact)
    # The rasteriser interpolates v_uv in float32: allow a few ulps of start error.
    bound = one_step_bound(ARTICLE_COEFFICIENTS, 3, start_error=4 * 2.0 ** -23 * 2)
    print(f"reseed 2^20: max |error| = {error.max():.3e}, RMS {np.sqrt((error ** 2).mean()):.3e} "
          f"(bound {bound:.3e})")
    assert error.max() <= bound
    r = np.corrcoef(histogram(got, 512), histogram(exact, 512))[0, 1]
    print(f"reseed 2^20: 512x512 density correlation {r:.6f}")
    assert r >= 0.999


def test_top_of_the_range_stays_at_plus_two(gl):
    # With a = c = pi/2 and b = d = pi, the particle at (1, 1) maps to sin(pi/2) - cos(pi) = 2 on
    # both axes: the top of the packed range. It must decode as +2, never wrap to -2.
    scene = DeJong(coefficients=(np.pi / 2, np.pi, np.pi / 2, np.pi), iterations=1)
    with Simulation(gl, scene.graph(), 3) as sim:
        sim.upload("position", np.array([[1, 1], [2, 2], [2.5, -7]]))
        start = sim.download("position")
        assert np.array_equal(start[1:], [[2, 2], [2, -2]]), "uploads clamp, never wrap"
        sim.step()
        got = sim.download("position")
    assert np.array_equal(got[0], [2.0, 2.0]), got[0]
    expected = reference(start, scene.coefficients, 1)
    assert np.abs(got - expected).max() <= one_step_bound(scene.coefficients, 1)
