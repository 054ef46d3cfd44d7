"""The liquid scene (es2particles/scenes/liquid.py): one GPU step against the gather form written
here in float64 over every pair, the settled liquid, the saved state's densities against every
pair, and the refusals. The GPU form against the paper's own sequential loop is measured in
docs/scenes/liquid.md (tests/clavet_reference.py makes the reference)."""

import numpy as np
import pytest

from es2particles.errors import ParameterError
from es2particles.frame.simulation import Simulation
from es2particles.scenes.liquid import GATHER_SHARE, Liquid


def all_pairs(x):
    d = x[None, :, :] - x[:, None, :]  # d[i, j]: from i to j
    r = np.linalg.norm(d, axis=2)
    np.fill_diagonal(r, np.inf)
    return d, r


def gather_step(x, v, p, h, dt):
    """The scene's step as its docstring states it, every pair, float64."""
    k, k_near = p.stiffness * h, p.near_stiffness * h
    sigma, beta = p.viscosity
    d, r = all_pairs(x)
    near = (r < h) & (r > 0)  # two particles at one place (a corner's clamp) push nothing
    n = np.where(near[..., None], d / np.where(near, r, 1.0)[..., None], 0.0)
    u = ((v[:, None, :] - v[None, :, :]) * n).sum(axis=2)
    q = np.where(near, r / h, 1.0)
    strength = np.where(near & (u > 0), dt * (1 - q) * (sigma * u + beta * u * u), 0.0)
    v1 = v + dt * np.asarray(p.gravity) - 0.5 * (strength[..., None] * n).sum(axis=1)
    xs = x + dt * v1
    d, r = all_pairs(xs)
    a = np.where(r < h, 1 - r / h, 0.0)  # the densities count them
    rho, rho_near = (a ** 2).sum(axis=1), (a ** 3).sum(axis=1)
    near = (r < h) & (r > 0)
    pressure = k * (rho[:, None] + rho[None, :] - 2 * p.rest_density) * a \
        + k_near * (rho_near[:, None] + rho_near[None, :]) * a * a
    unit = d / np.where(near, r, 1.0)[..., None]
    x2 = xs - GATHER_SHARE * 0.5 * dt * dt * (np.where(near, pressure, 0.0)[..., None]
                                              * unit).sum(axis=1)
    ox, oy, radius = p.obstacle
    c = x2 - (ox, oy)
    rc = np.linalg.norm(c, axis=1)
    inside = rc < radius
    x2[inside] = (ox, oy) + c[inside] / rc[inside, None] * radius
    x2 = np.clip(x2, 0.0, p.box)
    return x2, v1 + (x2 - xs) / dt, np.stack([rho, rho_near], 1)


def test_a_step_is_the_gather_form_over_every_pair(gl):
    """900 particles (the author's largest scene) 30 steps into the dam break, then one step in
    float state: positions, velocities and the densities equal the float64 all-pairs step."""
    scene, n = Liquid(), 900
    h, dt = scene.radius_for(n), scene.dt_for(n)
    with Simulation(gl, scene.graph(gl.caps, count=n), n, fmt="rgba32f") as sim:
        scene.initialise(sim, np.random.default_rng(2))
        sim.run(30)
        x0, v0 = sim.download("position"), sim.download("velocity")
        sim.run(1)
        x1, v1, rho = sim.download("position"), sim.download("velocity"), sim.download("rho")
    want_x, want_v, want_rho = gather_step(x0, v0, scene.params, h, dt)
    assert np.abs(v0).max() > 0.3  # in motion
    assert np.abs(rho - want_rho).max() < 1e-4
    assert np.abs(x1 - want_x).max() < 1e-6
    assert np.abs(v1 - want_v).max() < 1e-4


@pytest.mark.slow
def test_the_dam_break_settles_near_the_rest_density(gl):
    """900 particles, 600 steps (10 s): the liquid comes to rest (mean speed under 0.05 box/s),
    its surface flat within 0.05 box, its deep density within 20% of rho0."""
    from clavet_reference import measures

    scene, n = Liquid(), 900
    with Simulation(gl, scene.graph(gl.caps, count=n), n, fmt="rgba32f") as sim:
        scene.initialise(sim, np.random.default_rng(1))
        sim.run(600)
        x, v = sim.download("position"), sim.download("velocity")
    density, height, spread = measures(x, scene.radius_for(n), scene.params)
    assert np.linalg.norm(v, axis=1).mean() < 0.05
    assert spread < 0.05 and 0.8 < density < 1.2 and 0.2 < height < 0.5, (density, height, spread)


def test_a_saved_state_s_densities_are_every_pair_s():
    """``density`` and ``near_density`` of a saved state, from its positions, against the sums
    over every pair written here."""
    scene = Liquid()
    x = np.random.default_rng(3).random((1500, 2))
    h = scene.radius_for(1500)
    saved = scene.derived({"position": x}, 1500)
    _, r = all_pairs(x)
    a = np.where(r < h, 1 - r / h, 0.0)
    assert np.allclose(saved["density"][:, 0], (a ** 2).sum(axis=1), rtol=0, atol=1e-12)
    assert np.allclose(saved["near_density"][:, 0], (a ** 3).sum(axis=1), rtol=0, atol=1e-12)


@pytest.mark.parametrize("given, count, words", [
    ({"radius": 0.6}, 900, "--radius 0.6 is more than half the --box's shorter side"),
    ({"radius": 0.001}, 900, "gives 900 particles fewer than one neighbour each"),
    ({"fill": (0.5, 0.0, 0.2, 1.0)}, 900, "--fill must be X0,Y0,X1,Y1 with X1 > X0"),
])
def test_bad_options_are_one_line_naming_them(given, count, words):
    with pytest.raises(ParameterError, match=words):
        Liquid(**given).graph(None, count=count)


def test_a_drag_in_the_live_view_carries_the_obstacle(gl):
    """The window's and the widget's drag: while the button is down the obstacle circle sits
    under the pointer (no particle stays inside it), and the declared one is free again once
    it comes up."""
    from es2particles.frame.pipeline import Pipeline
    from es2particles.live.view import LiveView

    times = iter(np.arange(0, 100, 0.05))
    scene = Liquid(obstacle=(0.5, 0.8, 0.1), fill=(0.0, 0.0, 1.0, 0.4))
    with Pipeline(gl, scene, particles=2048, size=(128, 128), steps=0) as pipeline:
        view = LiveView(pipeline, clock=lambda: float(next(times)))
        view.start()
        view.press(32, 112, (128, 128))  # world (0.25, 0.125): in the liquid
        view.move(33, 112, (128, 128))
        view.run_steps(3)
        held = pipeline.sim.download("position")
        view.release()
        view.run_steps(1)
    r = np.hypot(held[:, 0] - 33.5 / 128, held[:, 1] - (1 - 112.5 / 128))  # the pixel's centre
    assert r.min() >= 0.1 * (1 - 1e-3), r.min()  # pushed out of the carried circle
    assert np.count_nonzero(r < 0.2) > 10  # and piled round it


def test_gravity_tilts_live_by_its_keys(gl):
    """The live view's keys tilt gravity (its two components are the scene's controls, the
    page's sliders): tab picks gravity x, + raises it by 1/800 of its range, and set to +4
    box/s^2, 40 steps (0.625 s) carry the liquid's mean x right by more than a quarter of a
    free fall's 1/2 g t^2 (walls and pressure hold the rest back) beyond what the same steps
    untilted do (the default column spreads too)."""
    from es2particles.frame.pipeline import Pipeline
    from es2particles.live.view import LiveView

    scene = Liquid()
    assert [c.label for c in scene.controls()][-2:] == ["gravity x", "gravity y"]
    moved = []
    for tilt in (None, 4.0):
        with Pipeline(gl, scene, particles=1024, size=(64, 64), steps=0) as pipeline:
            view = LiveView(pipeline, clock=lambda: 0.0)
            view.start()
            before = pipeline.sim.download("position")[:, 0].mean()
            if tilt is not None:
                view.key("tab")  # from any other control to the gravity's x
                while view.controls[view.selected].label != "gravity x":
                    view.key("tab")
                view.key("equal")
                assert view.values["u_gravity"][0] == 16.0 / 800
                view.set_control("gravity x", tilt)
                assert view.values["u_gravity"][0] == tilt
            view.run_steps(40)
            moved.append(pipeline.sim.download("position")[:, 0].mean() - before)
    t = 40 * scene.dt_for(1024)
    assert moved[1] - moved[0] > 0.25 * 0.5 * 4.0 * t * t, (moved, t)
