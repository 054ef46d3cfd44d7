"""The smoke scene: its graph with and without the acceleration pass, the passes against the
float64 twin (inertial and tracers, stiff and loose), the opacity shadow map against a numpy
splat, shading through it, why "over" needs back to front, and the scene end to end."""

import numpy as np
import pytest

from es2particles import ParameterError, PassGraph, Simulation
from es2particles.camera import Camera
from es2particles.scenes.smoke import Smoke, SmokePhysics
from es2particles.shadow import RGBA8_UNIT, OpacityShadow, ShadowMap, light_through, opacity_map
from es2particles.sprites import SpriteRenderer, smoke_texture
from es2particles.twins import smoke as twin

ALIVE = (0.0, 1000.0)  # (age, lifetime): alive through every test run, never re-emitted


# -- the graph ---------------------------------------------------------------------------------

def test_inertial_plan_runs_acceleration_then_velocity_and_position():
    plan = Smoke().graph().plan(Smoke.render_reads)
    names = [p.name for p in plan.passes]
    assert set(names) == {"life", "acceleration", "velocity", "position"}
    assert names.index("acceleration") < names.index("velocity")
    assert names.index("acceleration") < names.index("position")
    assert plan.buffers["acceleration"] == 1  # read only in the step that writes it
    assert plan.buffers["velocity"] == 2 and not plan.left_out_passes


def test_tracers_leave_acceleration_and_velocity_out():
    plan = Smoke(SmokePhysics(tau=0.0)).graph().plan(Smoke.render_reads)
    assert [p.name for p in plan.passes] == ["life", "position"]
    assert {p.name for p in plan.left_out_passes} == {"acceleration", "velocity"}
    assert set(plan.left_out_quantities) == {"acceleration", "velocity"}
    text = "\n".join(plan.describe())
    assert "left out: pass acceleration, pass velocity, quantity velocity, quantity " \
           "acceleration" in text


# -- the exact step, against an ODE solver (numpy only) -----------------------------------------

@pytest.mark.parametrize("tau", [1e-4, 0.01, 0.3, 30.0])
def test_the_step_solves_stokes_relaxation_exactly_for_the_air_it_sees(tau):
    """v' = (u - v) / tau + g with u frozen over the step: the passes' closed form against a fine
    classical Runge-Kutta integration (stiff to loose: dt / tau from 333 to 0.001)."""
    dt, u, g = 1 / 30, np.array([0.4, 0.9, -0.2]), np.array([0.0, 0.3, 0.0])
    x0, v0 = np.array([1.0, 2.0, 3.0]), np.array([-1.0, 0.5, 2.0])
    a = (u - v0) / tau + g
    phi = tau * -np.expm1(-dt / tau)
    v1, x1 = v0 + a * phi, x0 + v0 * dt + a * (tau * (dt - phi))

    n = max(2000, int(20 * dt / tau))
    h, x, v = dt / n, x0.copy(), v0.copy()
    f = lambda v: (u - v) / tau + g  # noqa: E731
    for _ in range(n):
        k1 = f(v); k2 = f(v + h / 2 * k1); k3 = f(v + h / 2 * k2); k4 = f(v + h * k3)  # noqa: E702
        x = x + h / 6 * (v + 2 * (v + h / 2 * k1) + 2 * (v + h / 2 * k2) + (v + h * k3))
        v = v + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert np.allclose(v1, v, rtol=0, atol=1e-9), (v1, v)
    assert np.allclose(x1, x, rtol=0, atol=1e-9), (x1, x)


# -- the passes on the GPU against the twin ------------------------------------------------------

def cloud(count, rng, physics):
    """Points around the sphere's path, outside it."""
    centre = np.asarray(physics.sphere[:3])
    x = centre + rng.uniform(-2.0, 2.0, (count, 3))
    r = np.linalg.norm(x - centre, axis=1)
    keep = r > physics.sphere[3] * 1.05
    return x[keep]


def touching(physics, x, t):
    """Distance of points to the sphere's surface at time ``t``, in radii."""
    centre, _ = twin.sphere(physics, t)
    return np.linalg.norm(x - centre, axis=1) / physics.sphere[3] - 1


def run_passes(gl, physics, x, v, steps, fmt="rgba32f"):
    scene = Smoke(physics)
    with Simulation(gl, scene.graph(), len(x), outputs=("position", "life"), fmt=fmt) as sim:
        sim.upload("position", x)
        sim.upload("life", np.tile(ALIVE, (len(x), 1)))
        if physics.tau > 0:
            sim.upload("velocity", v)
        sim.run(steps)
        return sim.download("position"), (sim.download("velocity") if physics.tau > 0 else None)


@pytest.mark.parametrize("tau", [0.3, 0.02, 1e-4])
def test_inertial_passes_follow_the_twin(gl, tau):
    p = SmokePhysics(tau=tau)
    rng = np.random.default_rng(1)
    x = cloud(3000, rng, p)
    v = np.asarray(p.wind) + rng.normal(0, 0.3, x.shape)
    steps = 12
    gx, gv = run_passes(gl, p, x, v, steps)
    tx, tv = x.copy(), v.copy()
    clear = np.ones(len(x), bool)
    for k in range(steps):
        last = tx
        _, tv, tx = twin.inertial_step(p, tx, tv, k * p.dt)
        clear &= touching(p, tx, (k + 1) * p.dt) > 0.02
    # float32 through a smooth flow: ~1e-7 m per step. Particles that touched the sphere were put
    # back on its surface, where the step is not smooth and float32 and float64 part (by up to
    # 6 cm over 12 steps): they are checked apart, only for being outside it.
    err_x = np.linalg.norm(gx - tx, axis=1)[clear]
    err_v = np.linalg.norm(gv - tv, axis=1)[clear]
    assert np.all(np.isfinite(gx)) and np.all(np.isfinite(gv))
    assert clear.mean() > 0.9
    # (positions of ~3 m hold 2.4e-7 m in float32; the noise's gradients amplify differences)
    assert err_x.max() < 1e-4, f"position error {err_x.max():.3g} m"
    assert err_v.max() < 2e-4 + 1e-6 / tau, f"velocity error {err_v.max():.3g} m/s"
    assert touching(p, gx, steps * p.dt).min() > -1e-5
    if tau < 1e-3:  # stiff: the particles move with the air they saw (plus the settling g tau)
        air = twin.air(p, last, (steps - 1) * p.dt)[clear]
        slip = np.linalg.norm(gv[clear] - air - np.asarray(p.gravity) * tau, axis=1)
        assert slip.max() < 1e-3, f"stiff particles leave the air by {slip.max():.3g} m/s"


def test_tracer_pass_follows_the_twin(gl):
    p = SmokePhysics(tau=0.0)
    rng = np.random.default_rng(2)
    x = cloud(3000, rng, p)
    steps = 12
    gx, _ = run_passes(gl, p, x, None, steps)
    tx = x.copy()
    clear = np.ones(len(x), bool)
    for k in range(steps):
        tx = twin.tracer_step(p, tx, k * p.dt)
        clear &= touching(p, tx, (k + 1) * p.dt) > 0.02
    err = np.linalg.norm(gx - tx, axis=1)[clear]
    assert clear.mean() > 0.9
    assert err.max() < 1e-4, f"tracer position error {err.max():.3g} m"
    assert touching(p, gx, steps * p.dt).min() > -1e-5


def test_packed_state_stays_within_its_quantisation(gl):
    """RGBA8: 16-bit position and velocity; the acceleration's range grows as 1 / tau, and its
    code times phi ~ tau stays a small velocity error."""
    p = SmokePhysics(tau=0.05)
    rng = np.random.default_rng(3)
    x = cloud(2000, rng, p)
    v = np.tile(np.asarray(p.wind), (len(x), 1))
    gx, gv = run_passes(gl, p, x, v, 6, fmt="rgba8")
    tx, tv = x.copy(), v.copy()
    for k in range(6):
        _, tv, tx = twin.inertial_step(p, tx, tv, k * p.dt)
    position_code = 8.0 / 65535
    err = np.abs(gx - tx).max(axis=1)
    assert np.quantile(err, 0.99) < 20 * position_code, f"{np.quantile(err, 0.99):.3g} m"


# -- the opacity shadow map ----------------------------------------------------------------------

SETTINGS = OpacityShadow(light=(0.0, 8.0, 0.0), centre=(0.0, 2.0, 0.0), radius=3.0, size=64)


def shadow_map(gl, settings, points, opacity=1.0, fmt="rgba32f"):
    """The GPU map of one-pixel sprites (a white 1x1 sprite: each adds exactly its opacity)."""
    from dataclasses import replace

    g = PassGraph()
    g.quantity("position", -5.0, 9.0, components=3)
    g.quantity("life", (-10.0, 0.0), (10.0, 2000.0))
    g.add("position", _keep("position"), writes="position", reads="position")
    g.add("life", _keep("life"), writes="life", reads="life")
    with Simulation(gl, g, len(points), fmt="rgba32f") as sim:
        sim.upload("position", points)
        sim.upload("life", np.tile(ALIVE, (len(points), 1)))
        quantities = {q: sim.plan.quantities[q] for q in ("position", "life")}
        white = np.full((1, 1, 4), 255, np.uint8)
        shadow = ShadowMap(gl, replace(settings, format=fmt), quantities, sim.layout, sim.fmt,
                           white, opacity, 0.0, gl.caps.point_size_range)
        try:
            shadow.draw(sim.buffers, world_size=1e-6)  # below a pixel: clamped to one pixel
            return shadow.read()
        finally:
            shadow.release()


def _keep(name):
    from conftest import shader

    return shader({"position": "keep_position.frag", "life": "keep_life.frag"}[name])


def test_shadow_map_sums_opacity_per_layer_as_numpy(gl):
    rng = np.random.default_rng(4)
    points = rng.uniform((-1.5, -0.5, -1.5), (1.5, 4.5, 1.5), (5000, 3))
    got = shadow_map(gl, SETTINGS, points, opacity=0.25)
    want = opacity_map(points, 0.25, SETTINGS)
    # llvmpipe snaps a point's centre to 1/256 pixel, so points that close to a pixel edge may
    # fall either side (~0.8% of them): the per-layer totals must agree exactly, and all pixels
    # but those few.
    assert np.allclose(got.sum(axis=(0, 1)), want.sum(axis=(0, 1)), rtol=1e-6)
    differ = np.count_nonzero(np.abs(got - want) > 1e-6)
    assert differ <= 2 * 0.015 * len(points), f"{differ} pixel channels differ"
    assert np.all(want.sum(axis=(0, 1)) > 0)  # every layer holds particles


def test_rgba8_shadow_map_rounds_each_addition_and_saturates(gl):
    """RGBA8 (the ES 2.0 baseline): opacities in units of 1/32, every blended addition rounded
    to a code of 1/255, and each channel clamped at 1 (32 opaque particles)."""
    points = np.tile([[0.0, 2.6, 0.0]], (100, 1))  # one pixel, one layer
    for opacity, count in ((1.0, 10), (1.0, 100), (0.05, 20), (0.005, 20)):
        got = shadow_map(gl, SETTINGS, points[:count], opacity=opacity, fmt="rgba8")
        code = np.round(opacity * RGBA8_UNIT * 255) / 255  # what one addition leaves
        want = min(count * code, 1.0) / RGBA8_UNIT
        assert got.max() == pytest.approx(want, abs=1e-9), (opacity, count, got.max(), want)
    # a sprite's rim fainter than half a code adds nothing: 0.005 / 32 of opacity is lost


def sprites(gl, points, shadow, sort, opacity=1.0, size=(256, 256)):
    """The image (h, w, 3) and light map of white smoke sprites at ``points`` over black, drawn in
    the points' order or sorted, with the shadow map ``shadow`` (or none)."""
    g = PassGraph()
    g.quantity("position", -5.0, 9.0, components=3)
    g.quantity("life", (-10.0, 0.0), (10.0, 2000.0))
    g.add("position", _keep("position"), writes="position", reads="position")
    g.add("life", _keep("life"), writes="life", reads="life")
    with Simulation(gl, g, len(points), fmt="rgba32f") as sim:
        sim.upload("position", points)
        sim.upload("life", np.tile(ALIVE, (len(points), 1)))
        quantities = {q: sim.plan.quantities[q] for q in ("position", "life")}
        renderer = SpriteRenderer(gl, quantities, sim.layout, size, sim.fmt, [], sprite="smoke",
                                  point_size=40.0, size_spread=0.0, attenuation=(0, 0, 1 / 36),
                                  blend="over", tint=(1, 1, 1, 1), opacity=opacity,
                                  background=(0, 0, 0), shadow=shadow, sort=sort)
        try:
            renderer.draw(sim.buffers, CAMERA)
            light = renderer.shadow.read() if shadow is not None else None
            return renderer.read().astype(float) / 255, light
        finally:
            renderer.release()


CAMERA = Camera(eye=(0.0, 2.5, 6.0), target=(0.0, 2.5, 0.0))


def expected_light(settings, light_map, points):
    """The twin of shadow_light(): the map at each point's pixel, its layers in front of it."""
    pixels, _, _ = settings.camera().project(points, (settings.size, settings.size))
    x = np.floor(pixels[:, 0]).astype(int)
    y = settings.size - 1 - np.floor(pixels[:, 1]).astype(int)
    forward, front = settings.axis()
    layer = np.clip(((points - settings.light) @ forward - front) / settings.layer_depth(), 0, 3.999)
    before = np.einsum("nk,nk->n", light_map[y, x], np.clip(layer[:, None] - np.arange(4), 0, 1))
    return light_through(before, settings)


def centre_pixels(image, points):
    pixels, _, _ = CAMERA.project(points, image.shape[1::-1])
    return image[pixels[:, 1].astype(int), pixels[:, 0].astype(int), 0]


def test_sprites_are_lit_through_the_opacity_in_front_of_them(gl):
    """A column under a light above it: each sprite's centre shows the light the twin computes
    from the map (layers above it, its own layer's share); without the map all are lit alike."""
    settings = OpacityShadow(light=(0.0, 9.0, 0.0), centre=(0.0, 2.5, 0.0), radius=2.5, size=64,
                             extinction=0.7)
    points = np.stack([np.zeros(9), np.linspace(0.5, 4.5, 9), np.zeros(9)], 1)
    image, light_map = sprites(gl, points, settings, sort=None)
    flat, _ = sprites(gl, points, None, sort=None)
    alpha = centre_pixels(flat, points)  # white over black: each sprite's alpha at the pixel
    assert np.all(alpha > 0.9)
    got = centre_pixels(image, points) / alpha
    want = expected_light(settings, light_map, points)
    assert np.all(np.diff(want) > 0) and want[0] < 0.5  # lower: more in front of it, darker
    assert np.allclose(got, want, atol=0.01), (got.round(3), want.round(3))


def test_over_blending_needs_back_to_front(gl):
    """Two half-opaque sprites on one line of sight, the front one lit and the back one in its
    shadow (the light behind the camera): drawn back to front the pixel is the front one over the
    back one; in the wrong order the dark one lies on top (the Mali sample's picture)."""
    settings = OpacityShadow(light=(0.0, 2.5, 14.0), centre=(0.0, 2.5, 0.0), radius=2.5, size=64,
                             extinction=6.0)
    # On the camera's axis (and the light's): the front one at the front of the first layer,
    # so its own share of that layer barely shades it. Texel order: front first, the wrong
    # order for "over".
    points = np.array([[0.0, 2.5, 2.4], [0.0, 2.5, -2.0]])
    image, light_map = sprites(gl, points, settings, sort="full", opacity=0.5)
    lit, dark = expected_light(settings, light_map, points)
    assert lit > dark + 0.3
    flat, _ = sprites(gl, points[:1], None, sort=None, opacity=0.5)
    a = centre_pixels(flat, points[:1])[0]  # the sprites' alpha at the pixel (both centred)
    over = lambda top, under: a * top + (1 - a) * a * under  # noqa: E731  (over black)
    got = centre_pixels(image, points[:1])[0]
    assert got == pytest.approx(over(lit, dark), abs=0.02)
    wrong, _ = sprites(gl, points, settings, sort=None, opacity=0.5)
    assert centre_pixels(wrong, points[:1])[0] == pytest.approx(over(dark, lit), abs=0.02)
    reordered, _ = sprites(gl, points[::-1].copy(), settings, sort=None, opacity=0.5)
    assert centre_pixels(reordered, points[:1])[0] == pytest.approx(got, abs=0.01)


# -- the scene, end to end -----------------------------------------------------------------------

def test_cli_errors_are_one_line(tmp_path):
    import subprocess
    import sys

    for args, name in ((["--tau", "-1"], "tau"), (["--sort", "0"], "sort"),
                       (["--light", "0,2.5,0"], "light"), (["--sway", "1,0,0"], "sway"),
                       (["--noise", "0.5,0,0.6,1"], "noise frequency")):
        r = subprocess.run([sys.executable, "-m", "es2particles", "plan", "smoke", *args],
                           capture_output=True, text=True, cwd=tmp_path)
        assert r.returncode == 2, (args, r.stdout, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and name in lines[0], (args, r.stderr)
