"""The smoke scene: its graph with and without the acceleration pass, the passes against the
float64 twin (inertial and tracers, stiff and loose), the opacity shadow map against a numpy
splat, shading through it, why "over" needs back to front, and the scene end to end.

The passes are compared step by step with the twin's step from the GPU's own state, each particle
within its own bound derived from float32 and the format (the air's float32 error from its noise
lattices' local Hessians, lib/trig.glsl's sin and cos, each pass's roundings, the writes' half code
or float16 ulp): a half-code bias in every RGBA8 write fails the packed comparison."""

from contextlib import contextmanager

import numpy as np
import pytest

from bounds import TRIG_ERROR, U, decode_error, float_rounding, rounding_error
from es2particles import ParameterError, PassGraph, Simulation
from es2particles.render.camera import Camera
from es2particles.scenes.smoke import Smoke, SmokeParams
from es2particles.frame.pipeline import Renderer
from es2particles.render.shadow import RGBA8_UNIT, OpacityShadow, light_through, opacity_map
from es2particles.render.sort import DepthSort
from es2particles.render.sprites import Sprites, smoke_texture
from es2particles.twins import flow
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

# The float32 error of the passes, per particle.
#
# Each bound follows the shader's float32 arithmetic from the state as the GPU read it, against
# the float64 twin from the same state. The air's error is tests/test_flow.py's derivation made
# local: the noise reads its three lattices at p = s x + offset (+ the PSI offsets), each
# coordinate off by the roundings of s x, the sums and simplex3's unskew and by float32's 1/6 and
# PSI offsets, which moves each noise's gradient by its local Hessian (finite differences of the
# twin's analytic gradient) and its value by its gradient; the curl takes the gradients times s
# (times sqrt 2 for the curl, 1 for J^T n), the ramp terms the values; plus test_flow's 32 U of
# the sizes summed for the arithmetic. The sphere's centre and velocity come from lib/trig.glsl's
# sin and cos of w t, within TRIG_ERROR (test_numerics.py; the built-ins were not on NVIDIA) and
# w t's roundings, moving the air by test_flow's bound of its gradient (the dipole by (R / r)^3).
# A point on the sphere may be on either side of it in float32: the air is then the sphere's
# velocity or the ideal flow slipping past it. Then each pass's roundings.

DIVISION_ULPS = 2.5  # GLSL's precision of a division (GLSL 4.x, ES 3.00; ES 1.00 states none)


def _norm(a):
    return np.linalg.norm(a, axis=-1)


def air_error(p, x, t, dx=0.0):
    """Each point's bound on |float32 u_air(x, t) - float64| (x (n, 3) float64), with x itself
    off by up to ``dx`` (n,) in the shader (carried by the air's local Jacobian, forward
    differences of the twin)."""
    amplitude, s, ramp = p.noise[0], p.noise[1], p.noise[2]
    radius, wind = p.sphere[3], np.asarray(p.wind, float)
    centre, velocity = twin.sphere(p, t)
    raw = -p.noise[1] * p.noise[3] * wind * t  # the noise's drift, wrapped as in twin.air
    skewed = raw + raw.sum() / 3
    skewed -= 289.0 * np.floor(skewed / 289.0 + 0.5)
    offset = skewed - skewed.sum() / 6
    e_offset = 12 * U * (np.abs(raw).max() + np.abs(skewed).max())
    r, _, alpha, slope = flow._sphere_frame(x, centre, radius, ramp)
    # Each lattice coordinate as the shader computes it: s x (s a float32 uniform) + offset,
    # + the PSI offset (a float32 constant), each sum rounded; in simplex3, d0 = p - cell +
    # (sum of cell) G3 with G3 = 1/6 in float32, and the corners' offsets a few U more.
    sx = s * x
    argument = U * np.abs(sx) + float_rounding(sx) + float_rounding(sx + offset) + e_offset
    gradients, values = 0.0, 0.0
    for shift in (0.0, flow.PSI_OFFSET_Y, flow.PSI_OFFSET_Z):
        q = sx + offset + shift
        cell = np.floor(q + q.sum(axis=1, keepdims=True) / 3)
        unskew = cell.sum(axis=1, keepdims=True) / 6
        moved = (argument + np.abs(np.float32(shift) - shift)
                 + (float_rounding(q) if np.any(shift) else 0.0)
                 + float_rounding(q - cell) + float_rounding(unskew)
                 + 6 * np.abs(unskew) * abs(float(np.float32(1 / 6)) - 1 / 6) + 2 * U)
        _, g = flow.simplex3(q)
        h = 1e-4
        hessian = np.stack([(flow.simplex3(q + h * e)[1] - g) / h for e in np.eye(3)], -1)
        # |H delta| <= sum_j |H e_j| delta_j; |g . delta| <= sum_j |g_j| delta_j
        gradients = gradients + np.sum(np.linalg.norm(hessian, axis=1) * moved, axis=1)
        values = values + np.sum(np.abs(g) * moved, axis=1)
    error = amplitude * (s * (np.sqrt(2) * alpha + (1 - alpha)) * gradients
                         + (slope + (1 - alpha) / r) * values)
    error = error + 32 * U * (_norm(wind) + 3 * _norm(wind - velocity)
                              + amplitude * s * 3 * flow.NOISE_GRADIENT_BOUND)
    w = 2 * np.pi / p.sway[3]
    sway = np.asarray(p.sway[:3], float)
    e_argument = 8 * U * abs(w * t)  # w = TAU / period, t = step dt, their product
    e_centre = _norm(sway) * (TRIG_ERROR + e_argument) + 2 * U * (_norm(sway) + _norm(centre))
    e_velocity = _norm(sway) * w * (TRIG_ERROR + e_argument + 6 * U) + 2 * U * _norm(velocity)
    gradient = (amplitude * s * s * 3 * flow.NOISE_HESSIAN_BOUND
                + 6 * _norm(wind - velocity) / radius)  # test_flow's bound of the air's gradient
    error = error + gradient * e_centre + (radius / np.maximum(r, radius)) ** 3 * e_velocity
    # On the sphere's surface (a particle put there) float32 may see it on the other side, where
    # the air is the sphere's velocity or the ideal flow, which slips past it there.
    u = twin.air(p, x, t)
    surface = np.abs(r - radius) <= dx + e_centre + 4 * U * (_norm(x) + _norm(centre))
    if surface.any():
        outside = centre + (x - centre) * (radius * (1 + 1e-12) / r)[:, None]
        slip = _norm(twin.air(p, outside, t) - velocity)
        error = np.where(surface, error + slip + e_velocity, error)
    if np.any(dx):
        h = 1e-6
        jacobian = np.stack([(twin.air(p, x + h * e, t) - u) / h for e in np.eye(3)], -1)
        error = error + np.linalg.norm(jacobian, axis=(1, 2)) * dx
    return error


def centre_error(p, t):
    """The bound of the shader's sphere centre at time t (as in air_error)."""
    centre, _ = twin.sphere(p, t)
    sway = np.asarray(p.sway[:3], float)
    e_argument = 8 * U * abs(2 * np.pi / p.sway[3] * t)
    return _norm(sway) * (TRIG_ERROR + e_argument) + 2 * U * (_norm(sway) + _norm(centre))


def onto_sphere(p, x, e_x, t):
    """twin.outside_sphere with its bound: a point inside is put on the surface, c + R d / |d|,
    which moves the error across d by R / |d| and adds the centre's; where float32 may see the
    point on the other side of the surface (its error plus the centre's), the two outcomes
    differ by |R - |d||."""
    centre, _ = twin.sphere(p, t)
    radius = p.sphere[3]
    moved = twin.outside_sphere(p, x, t)
    e_c = centre_error(p, t)
    r = _norm(x - centre)
    inside = r < radius
    e_inside = e_c + radius / np.maximum(r, 1e-12) * (e_x + e_c) + 6 * U * (_norm(x) + radius)
    e = np.where(inside, e_inside, e_x)
    unsure = np.abs(r - radius) <= e_x + e_c + 2 * U * _norm(x)
    return moved, np.where(unsure, np.maximum(e, e_inside) + np.abs(radius - r), e)


def inertial_bound(p, x, v, t, e_x=0.0, e_v=0.0, write=None):
    """The inertial step of the passes from (x, v) at time t against twin.inertial_step: the
    twin's (acceleration, velocity, position), each one's float32 bound (n,) (a 2-norm), and each
    one's write bound per component (0 for rgba32f: a float32 value is stored as computed).
    ``e_x``, ``e_v``: the state's error as the shader reads it (n,); ``write``: {quantity: a
    write's error per component} for the stored acceleration, velocity and position."""
    write = {q: np.asarray((write or {}).get(q, 0.0), float)
             for q in ("acceleration", "velocity", "position")}
    u = twin.air(p, x, t)
    a, v1, x1 = twin.relax(x, v, u, p)
    slip = _norm(u - v)
    phi, lag = twin.relaxation(p.dt, p.tau)
    gravity = _norm(np.asarray(p.gravity, float))
    # a = (u - v) / tau + g: the air's error and e_v over tau, the sum's and the subtraction's
    # roundings, the division (2.5 ulp), tau and g as float32, the last sum
    e_a = ((air_error(p, x, t, e_x) + e_v + U * (_norm(u) + slip)) / p.tau
           + (2 * DIVISION_ULPS + 1) * U * slip / p.tau + U * (gravity + _norm(a)))
    # v' = v + a phi (phi a float32 uniform); the stored acceleration's write error times phi
    e_v1 = e_v + e_a * phi + 2 * U * _norm(a) * phi + U * _norm(v1)
    # x' = x + v dt + a lag (dt and lag float32 uniforms)
    step = x + v * p.dt
    e_x1 = (e_x + e_v * p.dt + 2 * U * _norm(v) * p.dt + e_a * lag + 2 * U * _norm(a) * lag
            + U * (_norm(step) + _norm(x1)))
    x1, e_x1 = onto_sphere(p, x1, e_x1, t + p.dt)
    return ((a, v1, x1), (e_a, e_v1, e_x1),
            (write["acceleration"], write["velocity"] + write["acceleration"] * phi,
             write["position"] + write["acceleration"] * lag))


def tracer_bound(p, x, t):
    """The tracers' midpoint step from x at time t against twin.tracer_step: (position, its
    bound (n,))."""
    u = twin.air(p, x, t)
    middle = x + u * (0.5 * p.dt)
    e_middle = (air_error(p, x, t) + 2 * U * _norm(u)) * 0.5 * p.dt + U * _norm(middle)
    u1 = twin.air(p, middle, t + 0.5 * p.dt)
    x1 = x + u1 * p.dt
    e_x1 = (air_error(p, middle, t + 0.5 * p.dt, e_middle) + 2 * U * _norm(u1)) * p.dt \
        + U * _norm(x1)
    return onto_sphere(p, x1, e_x1, t + p.dt)


def cloud(count, rng, physics):
    """Points around the sphere's path, outside it."""
    centre = np.asarray(physics.sphere[:3])
    x = centre + rng.uniform(-2.0, 2.0, (count, 3))
    r = np.linalg.norm(x - centre, axis=1)
    keep = r > physics.sphere[3] * 1.05
    return x[keep]


def assert_outside_sphere(p, x, t):
    """No particle inside the sphere of time t (float64), beyond the float32 centre's error and
    the roundings of a point put back on the surface, x + d (R / |d| - 1)."""
    centre = twin.sphere(p, t)[0]
    depth = p.sphere[3] - _norm(x - centre)
    allowed = centre_error(p, t) + 6 * U * (_norm(x) + p.sphere[3])
    k = np.argmax(depth - allowed)
    assert depth[k] <= allowed[k], (f"a particle {depth[k]:.3e} m inside the sphere, beyond "
                                    f"float32's {allowed[k]:.3e}")


def check(label, got, want, bound, write=0.0):
    """Every particle's every component within its float32 bound (a 2-norm, (n,)) plus its write
    bound (per component); returns the largest error/bound."""
    error = np.abs(got - want)
    total = np.broadcast_to(bound[:, None] + write, error.shape)
    k = np.unravel_index(np.argmax(error - total), error.shape)
    assert error[k] <= total[k], (
        f"{label}: particle {k[0]} errs by {error[k]:.3e} > its bound {total[k]:.3e} (= float32 "
        f"{bound[k[0]]:.3e} + write {total[k] - bound[k[0]]:.3e})")
    return (error / total).max()


@pytest.mark.parametrize("tau, dt", [(0.3, 1 / 30), (0.02, 1 / 30), (1e-4, 1 / 30),
                                     (100.0, 1 / 120)])
def test_inertial_passes_follow_the_twin(gl, tau, dt):
    """12 steps, each from the GPU's own state (rgba32f: read exactly) against the twin's step from
    it, every particle within its own bound (inertial_bound): the acceleration, velocity and
    position. Particles the step puts back on the sphere are compared too (onto_sphere)."""
    p = SmokeParams(tau=tau, dt=dt)
    rng = np.random.default_rng(1)
    x = cloud(3000, rng, p)
    v = np.asarray(p.wind) + rng.normal(0, 0.3, x.shape)
    scene = Smoke(p)
    worst = {"acceleration": 0.0, "velocity": 0.0, "position": 0.0}
    with Simulation(gl, scene.graph(), len(x), outputs=("position", "life"), fmt="rgba32f") as sim:
        sim.upload("position", x)
        sim.upload("life", np.tile(ALIVE, (len(x), 1)))
        sim.upload("velocity", v)
        for k in range(12):
            x0, v0 = sim.download("position"), sim.download("velocity")
            sim.step()
            got = {q: sim.download(q) for q in worst}
            t = k * p.dt
            want, bounds, _ = inertial_bound(p, x0, v0, t)
            for q, w, b in zip(worst, want, bounds):
                worst[q] = max(worst[q], check(f"tau {tau}, step {k}, {q}", got[q], w, b))
            assert_outside_sphere(p, got["position"], t + p.dt)
            if tau < 1e-3:  # stiff: each moves with the air it saw (plus the settling g tau),
                # up to its velocity's bound and the part of its start left, exp(-dt / tau)
                air = twin.air(p, x0, t) + np.asarray(p.gravity) * tau
                slip = _norm(got["velocity"] - air)
                assert np.all(slip <= bounds[1] + np.exp(-p.dt / tau) * _norm(v0 - air)), \
                    f"stiff particles leave the air by {slip.max():.3g} m/s"
    print(f"tau {tau}: largest error/bound over 12 steps: " +
          ", ".join(f"{q} {r:.3f}" for q, r in worst.items()))


def test_tracer_pass_follows_the_twin(gl):
    """Tracers (tau = 0): the midpoint step, 12 steps each from the GPU's own state against the
    twin's step, every particle within its own bound (tracer_bound)."""
    p = SmokeParams(tau=0.0)
    rng = np.random.default_rng(2)
    x = cloud(3000, rng, p)
    scene = Smoke(p)
    worst = 0.0
    with Simulation(gl, scene.graph(), len(x), outputs=("position", "life"), fmt="rgba32f") as sim:
        sim.upload("position", x)
        sim.upload("life", np.tile(ALIVE, (len(x), 1)))
        for k in range(12):
            x0 = sim.download("position")
            sim.step()
            want, bound = tracer_bound(p, x0, k * p.dt)
            got = sim.download("position")
            worst = max(worst, check(f"tracers, step {k}", got, want, bound))
            assert_outside_sphere(p, got, (k + 1) * p.dt)
    print(f"tracers: largest error/bound over 12 steps {worst:.3f}")


@pytest.mark.parametrize("fmt", ["rgba8", "rgba16f"])
def test_packed_and_half_state_round_one_step_by_half_a_step_of_the_format(gl, fmt):
    """RGBA8 (16-bit codes over each range) and RGBA16F (11-bit mantissas): one step from the
    state as stored, against the float64 twin from the same values, within the float32 bound of
    the passes plus the rounding of the writes: half a code of each range and the codec's
    rounding, or a whole float16 ulp (GL leaves the conversion to the driver: llvmpipe's rounds
    towards zero), of the stored acceleration too, which reaches the velocity times phi and the
    position times tau (dt - phi)."""
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
        got = [sim.download(q) for q in ("acceleration", "velocity", "position")]
    quantities = scene.graph().quantities
    ranges = {q: (np.array(quantities[q].lo), np.array(quantities[q].hi))
              for q in ("position", "velocity", "acceleration")}
    if fmt == "rgba8":  # the shader decodes the start (a driver may fuse it), then each write
        e_x = _norm(decode_error(x0, *ranges["position"]))
        e_v = _norm(decode_error(v0, *ranges["velocity"]))
        write = {q: rounding_error(fmt, *ranges[q]) for q in ranges}
    else:  # float16 reads exactly into float32; each write within a whole ulp of the value
        e_x = e_v = 0.0
        want, bounds, _ = inertial_bound(p, x0, v0, 0.0)
        write = {q: float_rounding(np.abs(w) + b[:, None], fmt, whole_ulp=True)
                 for q, w, b in zip(("acceleration", "velocity", "position"), want, bounds)}
    want, bounds, writes = inertial_bound(p, x0, v0, 0.0, e_x, e_v, write)
    for q, g, w, b, wr in zip(("acceleration", "velocity", "position"), got, want, bounds, writes):
        ratio = check(f"{fmt}: {q}", g, w, b, wr)
        print(f"{fmt}: {q} within {ratio:.3f} of its bound (float32 up to {b.max():.2e}, write "
              f"up to {np.max(wr):.2e})")


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
        # point size 1 in a 16-pixel image: every sprite below a pixel, clamped to one pixel, in
        # the map too
        with Renderer(gl, sprites, sim, size=(16, 16), point_size=1.0) as renderer:
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
                      sort=sort)  # None or a DepthSort
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
    image, light_map, map_size = sprites(gl, points, settings, sort=DepthSort(), opacity=0.5)
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

@pytest.mark.slow
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
