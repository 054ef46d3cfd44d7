"""The liquid's GPU gather form against Clavet 2005's own sequential loop in float64
(tests/clavet_reference.py) on the author's scene: 900 particles, a dam break in a unit box, 600
steps (10 s): the deep density over rho0, the surface's height and its spread (the standard
deviation of each h-wide column's top), and the mean speed, every 150 steps, in RGBA8 and float
state. Prints a Markdown table; docs/scenes/liquid.md quotes it.

    python benchmarks/liquid.py [--steps 600] [--particles 900]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from clavet_reference import measures, step  # noqa: E402

from es2particles import open_context  # noqa: E402
from es2particles.frame.simulation import Simulation  # noqa: E402
from es2particles.scenes.liquid import Liquid  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=600)
    parser.add_argument("--particles", type=int, default=900)
    args = parser.parse_args(argv)
    scene, n = Liquid(), args.particles
    h, dt = scene.radius_for(n), scene.dt_for(n)
    marks = range(args.steps // 4, args.steps + 1, args.steps // 4)
    rows = {}
    with open_context() as ctx:
        for fmt in ("rgba8", "rgba32f"):
            with Simulation(ctx, scene.graph(ctx.caps, count=n), n, fmt=fmt) as sim:
                scene.initialise(sim, np.random.default_rng(1))
                start = time.perf_counter()
                for mark in marks:
                    sim.run(mark - sim.steps_done)
                    x, v = sim.download("position"), sim.download("velocity")
                    rows.setdefault(mark, {})[f"GPU {fmt}"] = (*measures(x, h, scene.params),
                                                               np.hypot(*v.T).mean())
                ctx.finish()
                print(f"GPU {fmt}: {time.perf_counter() - start:.1f} s", file=sys.stderr)
    x = scene.start(n, np.random.default_rng(1))["position"]
    v = np.zeros_like(x)
    start = time.perf_counter()
    for s in range(1, args.steps + 1):
        x, v = step(x, v, scene.params, h, dt)
        if s in marks:
            rows[s]["paper's loop, float64"] = (*measures(x, h, scene.params), np.hypot(*v.T).mean())
    print(f"paper's loop: {time.perf_counter() - start:.1f} s", file=sys.stderr)
    print(f"{n} particles, h = {h:.4g}, dt = {dt:.4g} s, {args.steps} steps")
    print()
    print("| step | run | deep density / rho0 | surface height | surface spread | mean speed |")
    print("|---|---|---|---|---|---|")
    for mark, runs in rows.items():
        for name, (density, height, spread, speed) in runs.items():
            print(f"| {mark} | {name} | {density:.3f} | {height:.3f} | {spread:.3f} | {speed:.3f} |")


if __name__ == "__main__":
    main()
