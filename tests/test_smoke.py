"""The smoke scene: its graph with and without the acceleration pass, the passes against the
float64 twin (inertial and tracers, stiff and loose), the opacity shadow map against a numpy
splat, shading through it, why "over" needs back to front, and the scene end to end."""

from contextlib import contextmanager

import numpy as np
import pytest

from es2particles import ParameterError, PassGraph, Simulation
from es2particles.render.camera import Camera
from es2particles.scenes.smoke import Smoke, SmokeParams
from es2particles.frame.pipeline import Renderer
from es2particles.render.shadow import RGBA8_UNIT, OpacityShadow, light_through, opacity_map
from es2particles.render.sprites import Sprites, smoke_texture
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
    plan = Smoke(SmokeParams(tau=0.0)).graph().plan(Smoke.render_reads)
    assert [p.name for p in plan.passes] == ["life", "position"]
    assert {p.name for p in plan.left_out_passes} == {"acceleration", "velocity"}
    assert set(plan.left_out_quantities) == {"acceleration", "velocity"}
    text = "\n".join(plan.describe())
    assert "left out: pass acceleration, pass velocity, quantity velocity, quantity " \
           "acceleration" in text


# -- the exact step, against an ODE solver (numpy only) -----------------------------------------

def runge_kutta(x, v, u, g, tau, dt, n):
    """x and v after dt of v' = (u - v) / tau + g, by n classical Runge-Kutta steps."""
    h = dt / n
    f = lambda v: (u - v) / tau + g  # noqa: E731
    for _ in range(n):
        k1 = f(v)
        k2 = f(v + h / 2 * k1)
        k3 = f(v + h / 2 * k2)
        k4 = f(v + h * k3)
        x = x + h / 6 * (v + 2 * (v + h / 2 * k1) + 2 * (v + h / 2 * k2) + (v + h * k3))
        v = v + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x, v


@pytest.mark.parametrize("tau, dt", [(1e-4, 1 / 30), (0.01, 1 / 30), (0.3, 1 / 30),
                                     (30.0, 1 / 30), (100.0, 1 / 120), (30.0, 1e-3)])
def test_the_step_solves_stokes_relaxation_exactly_for_the_air_it_sees(tau, dt):
    """The twin's step (``relax``, what the passes compute) against a fine Runge-Kutta
    integration of v' = (u - v) / tau + g with u frozen over the step, stiff to loose (dt / tau
    from 333 to 1e-5, where tau (dt - phi) cancels in float32)."""
    p = SmokeParams(tau=tau, dt=dt)
    u, g = np.array([0.4, 0.9, -0.2]), np.asarray(p.gravity)
    x0, v0 = np.array([[1.0, 2.0, 3.0]]), np.array([[-1.0, 0.5, 2.0]])
    _, v1, x1 = twin.relax(x0, v0, u, p)
    x, v = runge_kutta(x0[0], v0[0], u, g, tau, dt, max(2000, int(20 * dt / tau)))
    assert np.allclose(v1[0], v, rtol=0, atol=1e-10), (v1, v)
    assert np.allclose(x1[0] - x0[0], x - x0[0], rtol=1e-8, atol=1e-13), (x1, x)


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


@pytest.mark.parametrize("tau, dt", [(0.3, 1 / 30), (0.02, 1 / 30), (1e-4, 1 / 30),
                                     (100.0, 1 / 120)])
def test_inertial_passes_follow_the_twin(gl, tau, dt):
    p = SmokeParams(tau=tau, dt=dt)
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
    if tau > 1:  # loose: the particles barely feel the air in 12 steps; gravity alone moves them
        assert np.abs(gx - tx).max() < 0.01 * np.abs(tx - x).max()
    assert touching(p, gx, steps * p.dt).min() > -1e-5
    if tau < 1e-3:  # stiff: the particles move with the air they saw (plus the settling g tau)
        air = twin.air(p, last, (steps - 1) * p.dt)[clear]
        slip = np.linalg.norm(gv[clear] - air - np.asarray(p.gravity) * tau, axis=1)
        assert slip.max() < 1e-3, f"stiff particles leave the air by {slip.max():.3g} m/s"


def test_tracer_pass_follows_the_twin(gl):
    p = SmokeParams(tau=0.0)
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


@pytest.mark.parametrize("fmt", ["rgba8", "rgba16f"])
def test_packed_and_half_state_round_one_step_by_half_a_step_of_the_format(gl, fmt):
    """RGBA8 (16-bit codes over each range) and RGBA16F (11-bit mantissas): one step from the
    state as stored, against the float64 twin from the same values, differs by the rounding of
    the writes only (half a code, or an ulp of the value, per component). The acceleration
    (range +-2 max speed / tau) is rounded too, and reaches the velocity times phi ~ tau."""
    p = SmokeParams(tau=0.05)
    rng = np.random.default_rng(3)
    x = cloud(2000, rng, p)
    scene = Smoke(p)
    with Simulation(gl, scene.graph(), len(x), outputs=("position", "life"), fmt=fmt) as sim:
        sim.upload("position", x)
        sim.upload("velocity", np.tile(np.asarray(p.wind), (len(x), 1)))
        sim.upload("life", np.tile(ALIVE, (len(x), 1)))
        x0, v0 = sim.download("position"), sim.download("velocity")
        sim.step()
        gx, gv = sim.download("position"), sim.download("velocity")
    a, tv, tx = twin.inertial_step(p, x0, v0, 0.0)
    phi, lag = twin.relaxation(p.dt, p.tau)
    if fmt == "rgba8":
        code = lambda q: scene.graph().quantities[q]  # noqa: E731
        half = {q: (np.array(code(q).hi) - np.array(code(q).lo)) / 65024 / 2
                for q in ("position", "velocity", "acceleration")}
        dx = half["position"] + half["acceleration"] * lag
        dv = half["velocity"] + half["acceleration"] * phi
    else:  # an ulp of each stored value (2^-10 relative), and of the acceleration: GL leaves
        # the rounding of a float written into a half-float target to the driver (llvmpipe's
        # is off by up to a whole ulp)
        ulp = lambda v: 2.0 ** (np.floor(np.log2(np.maximum(np.abs(v), 2 ** -14))) - 10)  # noqa
        dx = ulp(tx) + ulp(a) * lag
        dv = ulp(tv) + ulp(a) * phi
    err_x, err_v = np.abs(gx - tx) - dx, np.abs(gv - tv) - dv
    assert err_x.max() < 1e-5, f"{fmt}: position off by {err_x.max():.3g} m beyond rounding"
    assert err_v.max() < 1e-4, f"{fmt}: velocity off by {err_v.max():.3g} m/s beyond rounding"


def test_an_acceleration_beyond_half_floats_is_refused(gl):
    """At tau 1e-5 the acceleration's range (2 max speed / tau) passes rgba16f's 65504: one line
    naming the quantity, not a silent overflow."""
    scene = Smoke(SmokeParams(tau=1e-5))
    with pytest.raises(ParameterError, match="quantity 'acceleration' reaches .* rgba16f"):
        Simulation(gl, scene.graph(), 64, outputs=("position", "life"), fmt="rgba16f")
    Simulation(gl, scene.graph(), 64, outputs=("position", "life"), fmt="rgba8").release()


# -- the opacity shadow map ----------------------------------------------------------------------

SETTINGS = OpacityShadow(light=(0.0, 8.0, 0.0), centre=(0.0, 2.0, 0.0), radius=3.0, size=64)


@contextmanager
def still(gl, points):
    """A simulation of particles that stay at ``points``, alive: (simulation, its position and
    life quantities), what a renderer reads."""
    g = PassGraph()
    g.quantity("position", -5.0, 9.0, components=3)
    g.quantity("life", (-10.0, 0.0), (10.0, 2000.0))
    g.add("position", _keep("position"), writes="position", reads="position")
    g.add("life", _keep("life"), writes="life", reads="life")
    with Simulation(gl, g, len(points), fmt="rgba32f") as sim:
        sim.upload("position", points)
        sim.upload("life", np.tile(ALIVE, (len(points), 1)))
        yield sim, {q: sim.plan.quantities[q] for q in ("position", "life")}


def shadow_map(gl, settings, points, opacity=1.0, fmt="rgba32f"):
    """The GPU map of one-pixel sprites (a white 1x1 sprite: each adds exactly its opacity), as
    (size, size, 4) float64 opacities (row 0 at the bottom), in opacity units."""
    from dataclasses import replace

    white = np.full((1, 1, 4), 255, np.uint8)
    sprites = Sprites(sprite=white, size_spread=0.0, attenuation=(0, 0, 1), opacity=opacity,
                      shadow=replace(settings, format=fmt))
    with still(gl, points) as (sim, quantities):
        # point size 0: every sprite below a pixel, clamped to one pixel, in the map too
        with Renderer(gl, sprites, sim, size=(16, 16), point_size=0.0) as renderer:
            renderer.draw(CAMERA)
            data = renderer.read("shadow map").astype(np.float64)
    if fmt == "rgba8":
        return data / 255.0 / RGBA8_UNIT
    return data


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
    sprites = Sprites(sprite="smoke", size_spread=0.0, attenuation=(0, 0, 1 / 36), blend="over",
                      tint=(1, 1, 1, 1), opacity=opacity, background=(0, 0, 0), shadow=shadow,
                      sort=sort)
    with still(gl, points) as (sim, quantities):
        with Renderer(gl, sprites, sim, size=size, point_size=40.0) as renderer:
            renderer.draw(CAMERA)
            image = renderer.read().astype(float) / 255
            if shadow is None:
                return image, None, None
            # the sprites' size in the map at distance 1: the world size the camera gives them
            # (40 pixels of an image 1024 high at distance 6, a 45 degree view) over the map's
            # pixels per radian
            world = 40 * 6 / (1024 / 2 / np.tan(np.radians(22.5)))
            per_radian = shadow.size / 2 / np.tan(np.radians(shadow.camera().fov / 2))
            light = renderer.read("shadow map").astype(np.float64)  # a float map: opacities
            return image, light, world * per_radian


CAMERA = Camera(eye=(0.0, 2.5, 6.0), target=(0.0, 2.5, 0.0))


def bilinear_alpha(image, s, t):
    """The alpha of an (h, w, 4) uint8 texture at (s, t), LINEAR and clamped, as GL samples it
    (row 0 is t = 0)."""
    h, w = image.shape[:2]
    u, v = np.clip(s * w - 0.5, 0, w - 1), np.clip(t * h - 0.5, 0, h - 1)
    i0, j0 = np.floor(v).astype(int), np.floor(u).astype(int)
    i1, j1 = np.minimum(i0 + 1, h - 1), np.minimum(j0 + 1, w - 1)
    fv, fu = v - i0, u - j0
    a = image[..., 3].astype(float) / 255
    return ((1 - fv) * ((1 - fu) * a[i0, j0] + fu * a[i0, j1])
            + fv * ((1 - fu) * a[i1, j0] + fu * a[i1, j1]))


def expected_light(settings, light_map, points, opacity, map_size):
    """The twin of shadow_light(): the map at each point's pixel, its layers in front of it,
    less the point's own sprite there (``map_size``: its size in map pixels at distance 1)."""
    n = settings.size
    pixels, _, _ = settings.camera().project(points, (n, n))
    pixel = np.stack([pixels[:, 0], n - pixels[:, 1]], 1)  # from the bottom, as GL's window
    x, y = np.floor(pixel).astype(int).T
    forward, front = settings.axis()
    layer = np.clip(((points - settings.light) @ forward - front) / settings.layer_depth(), 0, 3.999)
    before = np.einsum("nk,nk->n", light_map[y, x], np.clip(layer[:, None] - np.arange(4), 0, 1))
    size = map_size / np.linalg.norm(points - settings.light, axis=1)
    point = (np.floor(pixel) + 0.5 - pixel) / size[:, None]
    inside = np.all(np.abs(point) <= 0.5, axis=1)
    own = inside * bilinear_alpha(smoke_texture(), 0.5 + point[:, 0], 0.5 - point[:, 1]) * opacity
    return light_through(np.maximum(before - (layer % 1) * own, 0), settings)


def centre_pixels(image, points):
    pixels, _, _ = CAMERA.project(points, image.shape[1::-1])
    return image[pixels[:, 1].astype(int), pixels[:, 0].astype(int), 0]


def test_sprites_are_lit_through_the_opacity_in_front_of_them(gl):
    """A column under a light above it: each sprite's centre shows the light the twin computes
    from the map (layers above it, its own layer's share); without the map all are lit alike."""
    settings = OpacityShadow(light=(0.0, 9.0, 0.0), centre=(0.0, 2.5, 0.0), radius=2.5, size=64,
                             extinction=0.7)
    points = np.stack([np.zeros(9), np.linspace(0.5, 4.5, 9), np.zeros(9)], 1)
    image, light_map, map_size = sprites(gl, points, settings, sort=None)
    flat, _, _ = sprites(gl, points, None, sort=None)
    alpha = centre_pixels(flat, points)  # white over black: each sprite's alpha at the pixel
    assert np.all(alpha > 0.9)
    got = centre_pixels(image, points) / alpha
    want = expected_light(settings, light_map, points, 1.0, map_size)
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
    image, light_map, map_size = sprites(gl, points, settings, sort="full", opacity=0.5)
    lit, dark = expected_light(settings, light_map, points, 0.5, map_size)
    assert lit > dark + 0.3
    flat, _, _ = sprites(gl, points[:1], None, sort=None, opacity=0.5)
    a = centre_pixels(flat, points[:1])[0]  # the sprites' alpha at the pixel (both centred)
    over = lambda top, under: a * top + (1 - a) * a * under  # noqa: E731  (over black)
    got = centre_pixels(image, points[:1])[0]
    assert got == pytest.approx(over(lit, dark), abs=0.02)
    wrong, _, _ = sprites(gl, points, settings, sort=None, opacity=0.5)
    assert centre_pixels(wrong, points[:1])[0] == pytest.approx(over(dark, lit), abs=0.02)
    reordered, _, _ = sprites(gl, points[::-1].copy(), settings, sort=None, opacity=0.5)
    assert centre_pixels(reordered, points[:1])[0] == pytest.approx(got, abs=0.01)


# -- the scene, end to end -----------------------------------------------------------------------

def test_cli_errors_are_one_line(tmp_path):
    import subprocess
    import sys

    for args, name in ((["--tau", "-1"], "tau"), (["--sort", "0"], "sort"),
                       (["--light", "0,2.5,0"], "light"), (["--sway", "1,0,0"], "sway"),
                       (["--noise", "0.5,0,0.6,1"], "--noise FREQ")):
        r = subprocess.run([sys.executable, "-m", "es2particles", "plan", "smoke", *args],
                           capture_output=True, text=True, cwd=tmp_path)
        assert r.returncode == 2, (args, r.stdout, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and name in lines[0], (args, r.stderr)


def test_the_noise_offset_wraps_on_its_period():
    """The drift of the noise is wrapped on its 289-cell period (skewed space), which leaves the
    air as it was: the twin at a late time against the unwrapped noise."""
    from es2particles.twins import flow

    p = SmokeParams()
    t = 4000.0  # the offset has drifted ~2500 noise cells
    x = np.random.default_rng(5).uniform(-2, 2, (200, 3)) + np.asarray(p.sphere[:3])
    centre, velocity = twin.sphere(p, t)
    raw = -p.noise[1] * p.noise[3] * np.asarray(p.wind) * t
    unwrapped = flow.air_velocity(x, centre, p.sphere[3], np.asarray(p.wind), velocity,
                                  np.asarray(p.noise), raw)
    assert np.abs(raw).max() > 2000
    assert np.allclose(twin.air(p, x, t), unwrapped, rtol=0, atol=1e-9)


def test_the_scene_end_to_end(gl):
    """A short run of the scene: the plan names the acceleration pass, the sort and the shadow
    map; the picture has smoke (light pixels above the floor) and the sphere where the twin puts
    it; tracers leave acceleration and velocity out."""
    from es2particles.frame.pipeline import Pipeline

    scene = Smoke()
    with Pipeline(gl, scene, particles=2 ** 12, size=(160, 160), steps=60) as p:
        p.warm_up()
        plan = p.describe()
        image = p.image()
        state = p.state()
    for words in ("acceleration: smoke.frag writes acceleration", "odd-even merge passes",
                  "sort key: sort/key.frag -> order", "sort merge: sort/merge.frag -> order",
                  "opacity shadow map: 4 layers", "shadow map: sprites/shadow.vert",
                  "mesh 2: sprites/mesh.vert + sprites/mesh.frag -> image",
                  "point sprites in back to front"):
        assert words in plan, words
    assert set(state) == {"position", "velocity", "acceleration", "life"}
    sky = image[:100].astype(float).mean(axis=2)  # above the floor's horizon
    background = 255 * np.mean((0.11, 0.12, 0.15))
    assert np.count_nonzero(sky > background + 40) > 200  # smoke
    centre, _ = twin.sphere(scene.params, 60 * scene.params.dt)
    assert np.allclose(scene.model_at(60)[:3, 3], centre)
    (pixel,), _, _ = scene.camera_at(0, 1).project(centre[None], (160, 160))
    r, g, b = image[int(pixel[1]), int(pixel[0])].astype(int)
    assert g > r + 20 and g > b + 20  # the green sphere
    with Pipeline(gl, Smoke(tau=0.0, shadows="off", sort="off"), 256,
                  (32, 32)) as p:
        assert "left out: pass acceleration, pass velocity" in p.describe()
