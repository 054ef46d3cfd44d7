"""The wind flame's 3D air: its cost a step, beside the same step in numpy, and how both grow
with the cells (issue 42's wind source).

Run: ``python benchmarks/air3d.py`` (``--cells 16,32,48,64``, ``--repeats 3``, ``--quick``: 16
and 24 cells a side; ``--advection maccormack``: both carry by MacCormack's scheme).

Ours: one step of ``run flame --source wind``'s plan (advection of the three face grids, the
fire's carry and feed, the curl and its confinement, buoyancy, the divergence, 40 Jacobi
iterations of the 7-point Poisson equation and the projection) through the public Pipeline,
timed with ``ctx.finish()`` inside, the median of ``--repeats`` after a warm-up step. The peer:
the same step in float64 numpy in the same process, the tests' independent reference
(``tests/air3d_reference.py``). Both grow with the cells (times the iterations): 8x a doubling
of the side. Timings are benchmark output: no test holds them.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import air3d_reference as ref  # noqa: E402

from es2particles import open_context  # noqa: E402
from es2particles.frame.pipeline import Pipeline  # noqa: E402
from es2particles.report.measure import median_time  # noqa: E402
from es2particles.scenes.flame import Flame  # noqa: E402


def ours(ctx, cells, repeats, advection):
    scene = Flame(source="wind", cells=cells, advection=advection)
    with Pipeline(ctx, scene, size=(64, 64), steps=0) as pipeline:
        pipeline.begin(1)
        pipeline.step(30)  # a fire has risen: the feed and the flow are at work
        return median_time(lambda: pipeline.step(1), ctx.finish, repeats) * 1e3


def numpy_peer(cells, repeats, advection):
    scene = Flame(source="wind", cells=cells, advection=advection)
    air, p = scene.air, scene.params
    d, h, w = (cells,) * 3
    reference = ref.Air3(np.zeros((d, h, w), bool), air.lo, air.hi,
                         tuple(int(k) for k in air.walls))
    rng = np.random.default_rng(1)
    state = {"u": rng.uniform(-1, 1, (d, h, w + 1)), "v": rng.uniform(-1, 1, (d, h + 1, w)),
             "w": rng.uniform(-1, 1, (d + 1, h, w)), "p": np.zeros((d, h, w)),
             "fire": rng.uniform(0, 1, (d, h, w, 2))}

    def step():
        u, v, w_, fire, _, pressure = ref.step(
            reference, state["u"], state["v"], state["w"], state["p"], state["fire"], p.dt,
            air.fire.keep, (0.0, 0.0, 0.0), (0.0, 1.0), 0, p.buoyancy, p.vorticity,
            p.pressure_iterations, maccormack=advection == "maccormack")
        state.update(u=u, v=v, w=w_, fire=fire, p=pressure)
    return median_time(step, lambda: None, repeats) * 1e3


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", default="16,32,48,64")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--advection", default="semi-lagrangian",
                        choices=("semi-lagrangian", "maccormack"))
    args = parser.parse_args(argv)
    sides = [16, 24] if args.quick else [int(c) for c in args.cells.split(",")]
    rows = []
    with open_context() as ctx:
        print(f"context: {ctx.caps.renderer}; {args.advection} advection")
        for cells in sides:
            a = ours(ctx, cells, args.repeats, args.advection)
            b = numpy_peer(cells, args.repeats, args.advection)
            rows.append((cells, a, b))
            print(f"{cells}^3 cells: ours {a:.1f} ms a step, numpy {b:.1f} ms ({b / a:.2f}x)",
                  flush=True)
    print("\n| cells | ours (ms a step) | numpy (ms a step) | numpy / ours |")
    print("|---|---|---|---|")
    for cells, a, b in rows:
        print(f"| {cells}^3 | {a:.1f} | {b:.1f} | {b / a:.2f}x |")
    print("\nhow each grows with the cells (the exponent k of cells^k; 1: linear):")
    for (c0, a0, b0), (c1, a1, b1) in zip(rows, rows[1:]):
        k = np.log((c1 / c0) ** 3)
        print(f"  {c0}^3 -> {c1}^3: ours x{a1 / a0:.2f} (k {np.log(a1 / a0) / k:.2f}), "
              f"numpy x{b1 / b0:.2f} (k {np.log(b1 / b0) / k:.2f})")


if __name__ == "__main__":
    main()
