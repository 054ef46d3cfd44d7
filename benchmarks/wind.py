"""The wind field's cost a step, beside the same job in numpy (issue 39).

Run: ``python benchmarks/wind.py`` (``--grids 128,256,512``, ``--particles 262144,1048576``,
``--repeats 3``, ``--quick``: 64 and 128 cells, 2^14 and 2^16 particles).

Ours: one step of the scene's plan (the fluid's passes on the MAC grid, 40 pressure iterations,
and the particles' three passes) through the public Pipeline, timed with ``ctx.finish()``
inside, the median of ``--repeats`` after a warm-up step. The peer: the same step in float64
numpy in the same process, the fluid by the tests' independent reference
(``tests/wind_reference.py``: advection, force, divergence, 40 Jacobi iterations, projection)
and the particles by one bilinear sample of the faces and an Euler move. Both grow with the
cells times the iterations and with the particles; the table prints ms a step, the ratio, and
how each grows from one size to the next. Timings are benchmark output: no test holds them.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import wind_reference as ref  # noqa: E402

from es2particles import open_context  # noqa: E402
from es2particles.frame.pipeline import Pipeline  # noqa: E402
from es2particles.report.measure import median_time  # noqa: E402
from es2particles.scenes.wind import Wind  # noqa: E402


def median_ms(function, repeats, finish=lambda: None):
    return median_time(function, finish, repeats) * 1e3


def ours(ctx, cells, particles, repeats):
    scene = Wind(grid=f"{cells}x{cells}")
    with Pipeline(ctx, scene, particles=particles, size=(256, 256), steps=0) as pipeline:
        pipeline.begin(1)

        return median_ms(lambda: pipeline.step(1), repeats, ctx.finish)


def numpy_peer(cells, particles, repeats):
    scene = Wind(grid=f"{cells}x{cells}")
    p = scene.params
    kinds, speeds = p.wall_uniforms
    air = ref.Air(scene.solid, p.cell, tuple(int(k) for k in kinds), speeds)
    rng = np.random.default_rng(1)
    h, w = air.shape
    state = {"u": np.zeros((h, w + 1)), "v": np.zeros((h + 1, w)), "p": np.zeros((h, w)),
             "x": rng.uniform(0, 1, (particles, 2)), "velocity": np.zeros((particles, 2))}

    def step():
        u, v, _, pressure = ref.step(air, state["u"], state["v"], state["p"], p.dt, p.wind,
                                     p.gusts, 0, p.pressure_iterations, p.warm_start)
        wind = ref.wind_at(air, u, v, state["x"])
        velocity = state["velocity"] + min(1.0, p.dt / p.relax) * (wind - state["velocity"])
        state.update(u=u, v=v, p=pressure, velocity=velocity,
                     x=np.clip(state["x"] + p.dt * velocity, 0, 1))
    return median_ms(step, repeats)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grids", default="128,256,512")
    parser.add_argument("--particles", default="262144,1048576")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    grids = [64, 128] if args.quick else [int(g) for g in args.grids.split(",")]
    counts = [2 ** 14, 2 ** 16] if args.quick else [int(n) for n in args.particles.split(",")]
    rows = []
    with open_context() as ctx:
        print(f"context: {ctx.caps.renderer}")
        for n in counts:
            for cells in grids:
                a = ours(ctx, cells, n, args.repeats)
                b = numpy_peer(cells, n, args.repeats)
                rows.append((cells, n, a, b))
                print(f"{cells}^2 cells, {n} particles: ours {a:.1f} ms a step, numpy {b:.1f} ms "
                      f"({b / a:.2f}x)", flush=True)
    print("\n| cells | particles | ours (ms a step) | numpy (ms a step) | numpy / ours |")
    print("|---|---|---|---|---|")
    for cells, n, a, b in rows:
        print(f"| {cells}^2 | 2^{n.bit_length() - 1} | {a:.1f} | {b:.1f} | {b / a:.2f}x |")
    print("\nhow each grows, cells 4x (per count of particles):")
    for n in counts:
        line = [(c, a, b) for c, m, a, b in rows if m == n]
        for (c0, a0, b0), (c1, a1, b1) in zip(line, line[1:]):
            print(f"  2^{n.bit_length() - 1} particles, {c0}^2 -> {c1}^2: ours x{a1 / a0:.2f}, "
                  f"numpy x{b1 / b0:.2f}")


if __name__ == "__main__":
    main()
