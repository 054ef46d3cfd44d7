"""A grid's samples by hand against the hardware's LINEAR filter (issue 39, item 2).

Run: ``python benchmarks/sampling.py`` (``--particles 1048576``, ``--repeats 3``).

Each of N particles samples a grid quantity at its position once a step: bilinear on a 256^2
grid, trilinear on a 64^3 one (an atlas of 64 slices), stored rgba16f or rgba32f, declared
``sampling="hand"`` (4 or 8 decoded fetches, exact to float32) or ``"hardware"`` (one LINEAR
fetch, two on a 3D grid; weights at the hardware's sub-texel precision). The peer is the same
samples in numpy (scipy's ``map_coordinates``, order 1) in the same process. Prints ms a step
and the ratios; timings are benchmark output: no test holds them.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

from es2particles import PassGraph, Simulation, open_context
from es2particles.report.measure import median_time

SHADERS = Path(__file__).resolve().parent.parent / "tests" / "shaders"
SHAPES = {2: (256, 256), 3: (64, 64, 64)}


def graph(dims, sampling):
    g = PassGraph()
    g.grid("cells", SHAPES[dims])
    g.quantity("f", -1, 1, components=1, domain="cells", sampling=sampling)
    g.quantity("position", 0, 64, components=dims)
    g.quantity("value", -1, 1, components=1)
    g.add("keep_f", str(SHADERS / "grids/keep_f.frag"), writes="f", reads=["f"])
    g.add("keep_position", str(SHADERS / "keep_position.frag"), writes="position",
          reads=["position"])
    g.add("sample", str(SHADERS / ("grids/sample3d.frag" if dims == 3 else "grids/sample.frag")),
          writes="value", reads=["position", "f"])
    return g


def ours(ctx, dims, fmt, sampling, points, repeats):
    with Simulation(ctx, graph(dims, sampling), len(points), outputs=["value"], fmt=fmt) as sim:
        sim.upload("position", points)
        sim.run(2)
        return median_time(lambda: sim.run(1), ctx.finish, repeats) * 1e3


def numpy_peer(dims, points, repeats):
    from scipy import ndimage

    field = np.random.default_rng(2).uniform(-1, 1, SHAPES[dims][::-1])
    index = (points / 64 * SHAPES[dims] - 0.5)[:, ::-1].T
    return median_time(lambda: ndimage.map_coordinates(field, index, order=1, mode="nearest"),
                       lambda: None, repeats) * 1e3


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--particles", type=int, default=2 ** 20)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    ctx = open_context()
    print(f"{args.particles} samples a step, {ctx.caps.renderer}")
    print("| grid | format | by hand (ms) | by the hardware (ms) | hand / hardware | numpy (ms) "
          "| numpy / hardware |")
    print("|---|---|---|---|---|---|---|")
    for dims in (2, 3):
        points = np.random.default_rng(1).uniform(0, 64, (args.particles, dims))
        peer = numpy_peer(dims, points, args.repeats)
        for fmt in ("rgba16f", "rgba32f"):
            hand, hardware = (ours(ctx, dims, fmt, s, points, args.repeats)
                              for s in ("hand", "hardware"))
            print(f"| {'x'.join(map(str, SHAPES[dims]))} | {fmt} | {hand:.1f} | {hardware:.1f} "
                  f"| {hand / hardware:.2f} | {peer:.1f} | {peer / hardware:.2f} |")
            sys.stdout.flush()
    ctx.release()


if __name__ == "__main__":
    main()
