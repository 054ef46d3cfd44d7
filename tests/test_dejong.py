"""The de Jong scene against an independent float64 numpy run of the same map.

Each bound is derived, per particle, from the format and float32 (tests/bounds.py): the written
position's half code, the codec's rounding, and float32 error in the map (the trig error that
test_numerics.py measures, the roundings of each product and sum) carried through the map's local
derivatives along the particle's float64 path. A systematic bias of half a code in every write
fails every one of them (the mutation suite, python -m tests.mutations, checks that it does).
"""

import numpy as np
import pytest

from bounds import U, half_code, rounding_error, trig_map_error
from conftest import run_scene
from es2particles import Simulation
from es2particles.scenes.dejong import ARTICLE_COEFFICIENTS, DeJong, dejong_map

LO, HI = -2.0, 2.0  # the position's packed range
HALF_CODE = half_code(LO, HI)


def map_terms(coefficients):
    """x' = sin(a y) - cos(b x), y' = sin(c x) - cos(d y) as trig_map_error's terms."""
    a, b, c, d = coefficients
    return [[(1, a, 1, "sin"), (-1, b, 0, "cos")], [(1, c, 0, "sin"), (-1, d, 1, "cos")]]


def one_step_bound(coefficients, start, iterations, start_error=None):
    """Each particle's largest |GPU - float64| after one step of ``iterations`` map iterations from
    ``start`` (its decoded position, which the shader decodes again in float32: the same operations,
    but a driver may fuse them, so allow one rounding of each of the decode's two steps): the
    float32 map's carried error plus the written position's rounding."""
    start_error = 2 * U * HI if start_error is None else start_error
    _, carried = trig_map_error(map_terms(coefficients), start, start_error, iterations)
    return carried + rounding_error("rgba8", LO, HI)


def check_one_step(label, got, exact, bound):
    """Every particle within its own bound (printed with the worst particle's error)."""
    error = np.abs(got - exact).max(axis=1)
    worst = np.argmax(error - bound)
    print(f"{label}: max |error| {error.max():.3e}, half code {HALF_CODE:.3e}; nearest to its "
          f"bound: particle {worst}, {error[worst]:.3e} of {bound[worst]:.3e}")
    assert error[worst] <= bound[worst], (f"{label}: particle {worst} errs by {error[worst]:.3e}, "
                                          f"above its bound {bound[worst]:.3e} (half code "
                                          f"{HALF_CODE:.3e} + its carried float32 error)")


def reference(start, coefficients, iterations):
    return np.clip(dejong_map(start.astype(np.float64), coefficients, iterations), -2, 2)


def histogram(points, bins):
    h, _, _ = np.histogram2d(points[:, 0], points[:, 1], bins=bins, range=[[-2, 2], [-2, 2]])
    return h.ravel()


@pytest.mark.parametrize("coefficients", [ARTICLE_COEFFICIENTS, (2.01, -2.53, 1.61, -0.33)])
def test_one_step_matches_float64_within_the_packing_and_trig_bound(gl, coefficients):
    start, got = run_scene(gl, DeJong(coefficients=coefficients, iterations=3), 2 ** 16, 1, seed=5,
                           rounding="nearest")
    check_one_step(f"de Jong one step {coefficients}", got, reference(start, coefficients, 3),
                   one_step_bound(coefficients, start, 3))


def test_density_after_20_stateful_steps_correlates_with_float64(gl):
    """20 stateful steps: each step within its one-step bound of float64 from the step before
    (the map is chaotic, so 20 steps are compared step by step), and the 64x64 density of the
    end against 20 float64 steps from the same start."""
    steps = 20
    scene = DeJong(coefficients=ARTICLE_COEFFICIENTS)
    with Simulation(gl, scene.graph(), 2 ** 18, rounding="nearest") as sim:
        scene.initialise(sim, np.random.default_rng(7))
        start = before = sim.download("position")
        for step in range(steps):
            sim.step()
            got = sim.download("position")
            check_one_step(f"de Jong stateful step {step + 1}", got,
                           reference(before, ARTICLE_COEFFICIENTS, 3),
                           one_step_bound(ARTICLE_COEFFICIENTS, before, 3))
            before = got
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
    # The rasteriser interpolates v_uv in float32: a few ulps of uv (4 ulps of 1, times the span),
    # then lo + uv * span rounds once more.
    start_error = 4 * 2.0 ** -23 * (HI - LO) + 2 * U * HI
    check_one_step("reseed 2^20", got, exact,
                   one_step_bound(ARTICLE_COEFFICIENTS, start, 3, start_error))
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
    check_one_step("the top of the range", got, expected, one_step_bound(scene.coefficients, start, 1))
