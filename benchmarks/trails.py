"""Trails: the bytes and milliseconds of the screen-space fade and of ribbons on the fountain.

Each row runs the fountain with the camera orbiting (30 degrees a second at 30 frames a second
of a 12-second turn) and times the trails' own stages over 20 frames (the median): the fade's
one pass, the ribbons' history pass and strips. Bytes: the targets and vertex data the trails
add to the plan. docs/trails.md quotes it.

    python benchmarks/trails.py [--size 512] [--particles 2048]
"""

import argparse
import time

import numpy as np

from es2particles import open_context
from es2particles.frame.pipeline import Pipeline
from es2particles.scenes.fountain import Fountain

OWN = {"trails", "ribbon history", "ribbons"}


def measure(ctx, size, particles, trails):
    """(bytes the trails add, ms of their stages a frame)."""
    with Pipeline(ctx, Fountain(camera="orbit"), particles=particles, size=size,
                  trails=trails) as p:
        plan = p.plan
        added = sum(r.nbytes for n, r in plan.resources.items() if n in OWN)
        for name, v in plan.vertices.items():
            if name == "ribbons":
                added += v.count * 16 + v.indices_size * 4
        stages = [s for s in plan.stages if s.name in OWN]
        times = []
        for frame, _ in enumerate(p.frames(21)):
            env = p.executor.frame(p.camera(frame, 360))
            ctx.finish()
            start = time.perf_counter()
            for stage in stages:
                p.executor.run(stage, env, clear=False)
            ctx.finish()
            times.append(time.perf_counter() - start)
        return added, 1e3 * float(np.median(times[1:]))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--particles", type=int, default=2048)
    args = parser.parse_args(argv)
    size = (args.size, args.size)
    with open_context() as ctx:
        print(f"The fountain, {args.particles} particles, {args.size}x{args.size}, on "
              f"{ctx.caps.renderer}.\n")
        print("| trails | bytes added | ms a frame |")
        print("|---|---|---|")
        for trails in ("fade:0.97", "ribbons:8", "ribbons:16", "ribbons:32"):
            added, ms = measure(ctx, size, args.particles, trails)
            print(f"| {trails} | {added / 2 ** 20:.2f} MiB | {ms:.2f} |")


if __name__ == "__main__":
    main()
