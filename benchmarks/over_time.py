"""Two scenes' measures over time, as issue 41 asks: SPH's energy (the dam break's kinetic and
potential energy, per metre of depth in 2D, every --every steps, in float state and in RGBA8) and
the boids' order parameter (the norm of the mean unit velocity) from random headings, in 2D and
3D. Prints Markdown tables; docs/scenes/sph.md and docs/scenes/boids.md quote them.

    python benchmarks/over_time.py [--sph-steps 2000] [--boids-steps 800]

SPH's mechanical energy, E = sum m (|v|^2 / 2 + g y), can only fall: artificial viscosity and the
walls' restitution take energy out, and the weakly compressible water stores a little as
compression (the Tait pressure's work), which it gives back. The energy is from the saved state,
in float64.
"""

import argparse

import numpy as np

from es2particles import open_context
from es2particles.frame.simulation import Simulation
from es2particles.scenes.boids import Boids, order_parameter
from es2particles.scenes.sph import G, Sph


def energy(x, v, mass):
    """(kinetic, potential) energy of particles at ``x`` moving at ``v`` (float64; y is up)."""
    x, v = np.asarray(x, np.float64), np.asarray(v, np.float64)
    return 0.5 * mass * (v * v).sum(), mass * G * x[:, 1].sum()


def sph_rows(ctx, steps, every, spacing):
    scene = Sph(spacing=spacing)
    p = scene.params
    out = {}
    for fmt in ("rgba32f", "rgba8"):
        with Simulation(ctx, scene.graph(ctx.caps), p.count, fmt=fmt) as sim:
            scene.initialise(sim, np.random.default_rng(1))
            rows = []
            for mark in range(0, steps + 1, every):
                sim.run(mark - sim.steps_done)
                rows.append((mark, mark * p.step,
                             *energy(sim.download("position"), sim.download("velocity"), p.mass)))
            out[fmt] = rows
    return p, out


def boids_rows(ctx, steps, every, dimensions, count):
    scene = Boids.at_density(count, dimensions)
    with Simulation(ctx, scene.graph(ctx.caps), count) as sim:
        scene.initialise(sim, np.random.default_rng(1))
        rows = []
        for mark in range(0, steps + 1, every):
            sim.run(mark - sim.steps_done)
            rows.append((mark, order_parameter(sim.download("velocity"))))
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sph-steps", type=int, default=2000)
    parser.add_argument("--sph-spacing", type=float, default=0.05)
    parser.add_argument("--boids-steps", type=int, default=800)
    parser.add_argument("--boids", type=int, default=4096)
    args = parser.parse_args(argv)
    with open_context() as ctx:
        p, sph = sph_rows(ctx, args.sph_steps, args.sph_steps // 10, args.sph_spacing)
        print(f"SPH dam break, {p.count} particles {p.dx:g} m apart (2D: J a metre of depth; "
              f"potential from the floor)\n")
        print("| step | t (s) | kinetic (float) | potential (float) | total / start (float) | "
              "total / start (rgba8) |")
        print("|---|---|---|---|---|---|")
        first = {fmt: rows[0][2] + rows[0][3] for fmt, rows in sph.items()}
        for (mark, t, k, u), (_, _, k8, u8) in zip(sph["rgba32f"], sph["rgba8"]):
            print(f"| {mark} | {t:.3f} | {k:.1f} | {u:.1f} | {(k + u) / first['rgba32f']:.4f} | "
                  f"{(k8 + u8) / first['rgba8']:.4f} |")
        every = args.boids_steps // 8
        rows = {d: boids_rows(ctx, args.boids_steps, every, d, args.boids) for d in (2, 3)}
        print(f"\nBoids' order parameter, {args.boids} boids from random headings at the "
              "defaults' density\n")
        print("| step | 2D | 3D |")
        print("|---|---|---|")
        for (mark, two), (_, three) in zip(rows[2], rows[3]):
            print(f"| {mark} | {two:.3f} | {three:.3f} |")


if __name__ == "__main__":
    main()
