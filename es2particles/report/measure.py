"""Measurements behind the report: run time and error of each scene per format and size, and the
collision scene's error against time step. Each returns plain rows (dicts) for tables and charts.

Timings are medians of repeats after a warm-up, with the GPU finished inside each timing. Errors
are against float64 numpy: the de Jong map itself, and for the collision scene the exact solution
of a projectile with linear drag (smooth, no contact) or the float64 twin at a finer step.
"""

import statistics
import time

import numpy as np

from ..fields.field2d import CollisionField
from ..frame.pipeline import Pipeline
from ..frame.settings import Bloom
from ..scenes.collision import RECT, Collision, CollisionParams
from ..scenes.dejong import ARTICLE_COEFFICIENTS, DeJong, dejong_map
from ..frame.simulation import Simulation
from ..twins.particle import step_reference


def timings(function, finish=lambda: None, repeats=5):
    """(median, min, max) seconds of ``repeats`` calls after one warm-up call; ``finish`` (e.g.
    ``ctx.finish``) runs inside each timing so that GPU work is counted."""
    function()
    finish()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        finish()
        times.append(time.perf_counter() - start)
    return statistics.median(times), min(times), max(times)


def median_time(function, finish, repeats=5):
    return timings(function, finish, repeats)[0]


def density_distance(a, b, bins=64, extent=2.0):
    """Total-variation distance between the bins x bins densities of two point sets."""
    rng = [[-extent, extent], [-extent, extent]]
    ha = np.histogram2d(a[:, 0], a[:, 1], bins, rng)[0].ravel()
    hb = np.histogram2d(b[:, 0], b[:, 1], bins, rng)[0].ravel()
    return 0.5 * np.abs(ha / ha.sum() - hb / hb.sum()).sum()


class DeJongInFormat(DeJong):
    """De Jong with its position in the simulation's format, 16-bit codes in rgba8 (the scene's
    own keeps 32 bits, ``rgba8_32``, wherever a format holds less): the formats compared."""

    state_bits = 16


def dejong_row(ctx, fmt, count, rounding, k_steps=20, image=(512, 512)):
    """One de Jong configuration: step and frame time, one-step and density errors. ``fmt``
    ``rgba8_32``: the scene as it runs (32-bit packed position in an rgba8 simulation)."""
    scene = DeJong() if fmt == "rgba8_32" else DeJongInFormat()
    with Pipeline(ctx, scene, count, image, fmt="rgba8" if fmt == "rgba8_32" else fmt,
                  bloom=Bloom(), rounding=rounding) as p:
        finish = ctx.finish
        step = median_time(lambda: p.step(1), finish)
        frame = median_time(lambda: (p.step(1), p.render()), finish)
        sim = p.sim
        start = sim.download("position")
        sim.step()
        got = sim.download("position")
        exact = np.clip(dejong_map(start, ARTICLE_COEFFICIENTS, 3), -2, 2)
        err = np.abs(got - exact)
        reference = start.copy()
        sim.upload("position", start)
        for _ in range(k_steps):
            reference = np.clip(dejong_map(reference, ARTICLE_COEFFICIENTS, 3), -2, 2)
        sim.run(k_steps)
        distance = density_distance(sim.download("position"), reference)
    # The sampling-noise floor of that distance: float64 against float64 from an independent
    # start of the same size. Below it, a distance says nothing about the format.
    other = np.random.default_rng(count + 1).uniform(-2, 2, (count, 2))
    for _ in range(k_steps):
        other = np.clip(dejong_map(other, ARTICLE_COEFFICIENTS, 3), -2, 2)
    return {"scene": "dejong", "format": fmt if fmt == "rgba8_32" else sim.format_note,
            "rounding": rounding, "N": count,
            "step_s": step, "frame_s": frame, "max_error": err.max(),
            "rms_error": float(np.sqrt((err ** 2).mean())), f"density_tv_{k_steps}": distance,
            "density_floor": density_distance(other, reference)}


def projectile(x0, v0, t, gravity, drag):
    """Exact position of a particle under constant gravity and linear drag k (float64)."""
    g = np.asarray(gravity, float)
    decay = np.exp(-drag * t)
    return x0 + g * t / drag + (v0 - g / drag) * (1 - decay) / drag


def smooth_start(count, rng):
    x0 = np.stack([rng.uniform(-0.6, -0.2, count), rng.uniform(-0.6, 0.0, count)], 1)
    v0 = np.stack([rng.uniform(0.5, 1.5, count), rng.uniform(1.0, 2.0, count)], 1)
    return x0, v0


def collision_dt_row(ctx, fmt, rounding, k, horizon, count=256, drag=0.5):
    """Error at ``horizon`` seconds of free flight with drag, dt = 2^-k, against the exact path.

    The field is 8 x 8 cells: its half cell (0.125) exceeds every move here, so each step is one
    sub-step and the error is the integrator's at step dt (with a fine field the sub-steps would
    set the error whatever dt is)."""
    dt = 2.0 ** -k
    # No emission: the lifetime is unused, but must fit the life clock at the smallest dt
    params = CollisionParams(emit=False, dt=dt, drag=drag, gravity=(0.0, -1.0),
                      lifetime=(horizon, horizon))
    scene = Collision(params, field=CollisionField(RECT, [], resolution=(8, 8)))
    x0, v0 = smooth_start(count, np.random.default_rng(k))
    steps = int(round(horizon / dt))
    with Simulation(ctx, scene.graph(), count, fmt=fmt, rounding=rounding) as sim:
        scene.initialise(sim, np.random.default_rng(0))
        sim.upload("position", x0)
        sim.upload("velocity", v0)
        sim.upload("life", np.stack([np.zeros(count), np.full(count, params.max_age)], 1))
        x0, v0 = sim.download("position"), sim.download("velocity")  # the decoded start
        start = time.perf_counter()
        sim.run(steps)
        ctx.finish()
        elapsed = time.perf_counter() - start
        x = sim.download("position")
    exact = projectile(x0, v0, steps * dt, params.gravity, drag)
    return {"format": sim.format_note, "rounding": rounding, "k": k, "dt": dt,
            "error": float(np.abs(x - exact).max()), "run_s": elapsed}


def collision_row(ctx, fmt, count, rounding, horizon_steps=15):
    """Collision scene: step time, frame time with rendering, the storage format's error over a
    short horizon (against the float64 twin at the same dt, so only the format and float32
    arithmetic differ), deepest penetration, and energy drift (r = 1, s = 1, no drag, no
    emitter: the response keeps the speed, so any drift is the integrator's and the format's)."""
    params = CollisionParams(emit=False, drag=0.0, bounce=1.0, sliding=1.0)
    scene = Collision(params.changed(shape="circle+box+capsule"))
    rng = np.random.default_rng(count)
    x = rng.uniform(-0.95, 0.95, (4 * count, 2))
    x = x[scene.field.exact_distance(x) > 0.02][:count]
    v = rng.uniform(-2, 2, (count, 2))
    life = np.stack([np.zeros(count), np.full(count, params.max_age)], 1)
    with Pipeline(ctx, scene, count, (512, 512), fmt=fmt, bloom=Bloom(), rounding=rounding) as p:
        sim = p.sim
        for name, values in (("position", x), ("velocity", v), ("life", life)):
            sim.upload(name, values)
        x, v, life = (sim.download(q) for q in ("position", "velocity", "life"))
        energy0 = 0.5 * np.sum(v * v, 1) - params.gravity[1] * x[:, 1]
        step = median_time(sim.step, ctx.finish)
        frame = median_time(lambda: (sim.step(), p.render()), ctx.finish)
        for name, values in (("position", x), ("velocity", v), ("life", life)):
            sim.upload(name, values)
        deepest = 0.0
        for _ in range(horizon_steps):
            sim.step()
            deepest = min(deepest, float(scene.field.exact_distance(sim.download("position")).min()))
        xg, vg = sim.download("position"), sim.download("velocity")
        note = sim.format_note
    xr, vr, lr = x, v, life
    for _ in range(horizon_steps):
        xr, vr, lr = step_reference(xr, vr, lr, scene.field, params)
    energy = 0.5 * np.sum(vg * vg, 1) - params.gravity[1] * xg[:, 1]
    return {"scene": "collision", "format": note, "rounding": rounding, "N": count,
            "step_s": step, "frame_s": frame,
            "median_error": float(np.median(np.abs(xg - xr).max(axis=1))),
            "max_error": float(np.abs(xg - xr).max()), "deepest": deepest,
            "energy_drift": float((energy.sum() - energy0.sum()) / abs(energy0.sum()))}


def fitted_order(dts, errors, points=4):
    """Slope of log(error) against log(dt) over the ``points`` largest steps, where the
    integrator's error dominates rounding: the observed order of convergence."""
    pairs = sorted(zip(dts, errors), reverse=True)[:points]
    return float(np.polyfit(np.log([d for d, _ in pairs]), np.log([e for _, e in pairs]), 1)[0])
