"""The boids scene (es2particles/scenes/boids.py): one GPU step against the rules written here in
float64 over every pair (no grid), the flock ordering itself from random starts, and its options'
refusals."""

import numpy as np
import pytest

from es2particles.errors import ParameterError
from es2particles.frame.simulation import Simulation
from es2particles.scenes.boids import Boids, order_parameter


def step_all_pairs(x, v, radii, weights, speed, box, dt):
    """Reynolds' three rules as boids.py states them, over every pair, in float64."""
    rs, ra, rc = radii
    ws, wa, wc = weights
    lo, hi = speed
    d = x[None, :, :] - x[:, None, :]  # d[i, j]: from boid i to boid j
    r = np.linalg.norm(d, axis=2)
    np.fill_diagonal(r, np.inf)  # a boid is not its own neighbour
    near = (r < rs)[..., None]
    away = -(np.where(near, d / np.where(r > 0, r * r, 1.0)[..., None], 0.0)).sum(axis=1)
    aligned = r < ra
    count_a = aligned.sum(axis=1)[:, None]
    heading = aligned.astype(float) @ v
    cohere = (r < rc)[..., None]
    count_c = cohere.sum(axis=1)  # (n, 1)
    centre = np.where(cohere, d, 0.0).sum(axis=1)
    steer = ws * away * rs
    steer += np.where(count_a > 0, wa * (heading / np.maximum(count_a, 1) - v), 0.0)
    steer += np.where(count_c > 0, wc * centre / np.maximum(count_c, 1) / rc * hi, 0.0)
    box = np.asarray(box, float)
    wall = (x <= rc).astype(float) - (x >= box - rc).astype(float)
    v = v + dt * (steer + wall * hi / max(rc, dt * hi))
    s = np.linalg.norm(v, axis=1, keepdims=True)
    v = v / s * np.clip(s, lo, hi)
    return np.clip(x + dt * v, 0.0, box), v


def step_against_all_pairs(gl, scene, start):
    """(x0, v0, x1, v1, want_x, want_v): one GPU step from ``start`` in float state, and the
    all-pairs float64 step from the same state."""
    p = scene.params
    with Simulation(gl, scene.graph(gl.caps), len(start["position"]), fmt="rgba32f") as sim:
        for name, value in start.items():
            sim.upload(name, value)
        x0, v0 = sim.download("position"), sim.download("velocity")
        sim.run(1)
        x1, v1 = sim.download("position"), sim.download("velocity")
    return (x0, v0, x1, v1,
            *step_all_pairs(x0, v0, p.radii, p.weights, p.speed, p.extent, p.dt))


def test_a_step_is_the_three_rules_over_every_pair(gl):
    """2048 boids crowded into a quarter of the box (about 20 within a radius each), one step in
    float state: velocity and position equal the all-pairs float64 step to float32 rounding."""
    scene = Boids(box=(1.0, 1.0))
    p = scene.params
    rng = np.random.default_rng(4)
    start = scene.start(2048, rng)
    start["position"] = 0.25 + 0.5 * start["position"] / np.asarray(p.extent)
    x0, v0, x1, v1, want_x, want_v = step_against_all_pairs(gl, scene, start)
    d = np.sqrt(((x0[:, None] - x0[None]) ** 2).sum(-1))
    assert (d < p.radii[1]).sum(1).mean() > 10  # they do see each other
    assert np.abs(v1 - want_v).max() < 1e-5 * p.speed[1]
    assert np.abs(x1 - want_x).max() < 1e-6


def test_a_3d_step_is_the_three_rules_over_every_pair(gl):
    """The same in 3D (the grid's 3 x 3 x 3 cells): 2048 boids crowded into the middle eighth
    of a unit cube (about 20 within the alignment radius each), one step in float state,
    against the all-pairs float64 step."""
    scene = Boids(dimensions=3)
    p = scene.params
    assert p.extent == (1.0, 1.0, 1.0)
    rng = np.random.default_rng(9)
    start = scene.start(2048, rng)
    assert start["position"].shape == (2048, 3)
    start["position"] = 0.375 + 0.25 * start["position"]
    x0, v0, x1, v1, want_x, want_v = step_against_all_pairs(gl, scene, start)
    d = np.sqrt(((x0[:, None] - x0[None]) ** 2).sum(-1))
    assert (d < p.radii[1]).sum(1).mean() > 10
    assert np.abs(v1 - want_v).max() < 1e-5 * p.speed[1]
    assert np.abs(x1 - want_x).max() < 1e-6


@pytest.mark.slow
def test_random_headings_order_into_flocks(gl):
    """From random headings (order parameter ~0) the flock aligns: above 0.3 after 400 steps,
    4096 boids at the default density."""
    scene = Boids(box=(2.0, 2.0))
    with Simulation(gl, scene.graph(gl.caps), 4096) as sim:
        scene.initialise(sim, np.random.default_rng(1))
        first = order_parameter(sim.download("velocity"))
        sim.run(400)
        last = order_parameter(sim.download("velocity"))
    assert first < 0.05 and last > 0.3, (first, last)


@pytest.mark.slow
def test_3d_random_headings_order_into_flocks(gl):
    """In 3D from random headings over the sphere (order parameter about 1 / sqrt(2048) =
    0.022): 2048 boids at the 3D default's density (a cube of 0.5) order above 0.3 in 600
    steps. The order comes in bursts, chaotic in the arithmetic: seeds 1, 2 and 3 measured
    0.23, 0.16, 0.13 at 400 steps and 0.61, 0.48, 0.50 at 600 on llvmpipe; 0.13, 0.13, 0.14
    and 0.45, 0.51, 0.39 on NVIDIA's driver (which fuses a * b + c)."""
    scene = Boids(dimensions=3, box=(0.5, 0.5, 0.5))
    with Simulation(gl, scene.graph(gl.caps), 2048) as sim:
        scene.initialise(sim, np.random.default_rng(1))
        first = order_parameter(sim.download("velocity"))
        sim.run(600)
        last = order_parameter(sim.download("velocity"))
    assert first < 0.06 and last > 0.3, (first, last)


@pytest.mark.parametrize("given, words", [
    ({"box": (1.0, 1.0, 1.0)}, "--box has a depth \\(1\\) but --dimensions is 2"),
    ({"dimensions": 3, "box": (1.0, 0.05)}, "--radii: the largest, 0.05, must be at most half"),
    ({"radii": (0.1, 0.1, 3.0)}, "--radii: the largest, 3, must be at most half the --box"),
    ({"speed": (0.5, 0.2)}, "--speed must be MIN,MAX with 0 <= MIN <= MAX"),
])
def test_bad_options_are_one_line_naming_them(given, words):
    with pytest.raises(ParameterError, match=words):
        Boids(**given)
