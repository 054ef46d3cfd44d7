"""The flame: the march's error against a 256-step reference, its time, its cost growth, and a
numpy peer.

Each row draws the same frame (the default camera, after the default steps) with a number of
segments a ray, their samples at the midpoints or dithered (4x4 Bayer and the frame), and
compares the picture with the 256-step midpoint reference's, made here: mean and largest
difference in codes of the 8-bit picture, and the milliseconds of the flame's stages alone (the
splat and the march; the median of 5 after a warm-up). The author's flame sphere-traces 128 steps
a pixel; the 128-step row is ours at that cost. The cost growth: milliseconds against steps and
against pixels (the wind source's air is stepped again for each row, but only the march is
timed). The peer: the same noise march in numpy (float64, ``twins/flame.py``) at 128x128,
against our march at that size. docs/scenes/flame.md quotes it.

    python benchmarks/flame.py [--size 512] [--source noise|smoke|wind]
"""

import argparse
import time

import numpy as np

from es2particles import open_context
from es2particles.frame.pipeline import Pipeline
from es2particles.render.flame import blackbody_ramp
from es2particles.report.measure import median_time
from es2particles.scenes.flame import Flame
from es2particles.twins.flame import march, noise_field

ROWS = [(16, "on"), (32, "on"), (64, "on"), (128, "on"), (16, "off"), (32, "off"), (64, "off")]


def picture(ctx, size, **options):
    """The frame with ``options``, and the flame's stages' milliseconds."""
    scene = Flame(**options)
    with Pipeline(ctx, scene, size=size) as p:
        next(p.frames())
        image = p.image().astype(float)
        stages = [s for s in p.plan.stages if s.kind in ("flame", "splat")]
        frame = p.executor.frame(p.camera(0, 1))
        seconds = median_time(lambda: [p.executor.run(s, frame) for s in stages], ctx.finish)
        return image, 1e3 * seconds, p


def numpy_peer(size, steps):
    """The noise flame's picture in numpy and its seconds."""
    scene = Flame(march_steps=steps, march_jitter="off")
    r, camera = scene.rendering(), scene.camera_at(0, 1)
    w, h = size
    eye, target = np.array(camera.eye), np.array(camera.target)
    f = (target - eye) / np.linalg.norm(target - eye)
    s = np.cross(f, camera.up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    k = np.tan(np.radians(camera.fov) / 2)
    y, x = np.mgrid[0:h, 0:w] + 0.5
    d = f + ((2 * x / w - 1) * k * w / h)[..., None] * s + ((2 * y / h - 1) * k)[..., None] * u
    rays = (d / np.linalg.norm(d, axis=-1, keepdims=True)).reshape(-1, 3)
    offset = r.rise * r.dt * scene.defaults.steps
    start = time.perf_counter()
    out = march(eye, rays, r.lo, r.hi, steps, lambda p: noise_field(p, r.shape, offset),
                (r.extinction, r.emission / r.extinction), blackbody_ramp(), r.background)
    return out.reshape(h, w, 3)[::-1] * 255, time.perf_counter() - start


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--source", default="noise", choices=("noise", "smoke", "wind"))
    args = parser.parse_args(argv)
    size, source = (args.size, args.size), {"source": args.source}
    with open_context() as ctx:
        reference, reference_ms, _ = picture(ctx, size, march_steps=256, march_jitter="off",
                                             **source)
        print(f"The {args.source} flame at {args.size}x{args.size} on {ctx.caps.renderer}.\n")
        print("| segments a ray | samples | mean error (codes) | largest | ms |")
        print("|---|---|---|---|---|")
        print(f"| 256 (the reference) | midpoints | 0 | 0 | {reference_ms:.1f} |")
        for steps, jitter in ROWS:
            image, ms, _ = picture(ctx, size, march_steps=steps, march_jitter=jitter, **source)
            d = np.abs(image - reference)
            print(f"| {steps} | {'dithered' if jitter == 'on' else 'midpoints'} | "
                  f"{d.mean():.3f} | {d.max():.0f} | {ms:.1f} |")
        print("\nCost growth (ms of the flame's stages):\n")
        print("| pixels | 16 | 64 | 256 segments |")
        print("|---|---|---|---|")
        for side in (128, 256, 512):
            ms = [picture(ctx, (side, side), march_steps=n, **source)[1] for n in (16, 64, 256)]
            print(f"| {side}x{side} | " + " | ".join(f"{m:.1f}" for m in ms) + " |")
        if args.source == "noise":
            ours, ms, _ = picture(ctx, (128, 128), march_steps=64, march_jitter="off")
            peer, seconds = numpy_peer((128, 128), 64)
            print(f"\nnumpy peer (float64), 128x128, 64 midpoint segments: {1e3 * seconds:.0f} ms "
                  f"against our {ms:.1f} ms ({1e3 * seconds / ms:.0f}x); pictures "
                  f"{np.abs(peer - ours).mean():.2f} codes apart on average (the peer takes the "
                  "nearest ramp texel)")


if __name__ == "__main__":
    main()
