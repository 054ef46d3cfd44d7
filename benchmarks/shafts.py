"""Light shafts: the error of tap structures against the 1,024-tap reference, and their time.

Each row draws the same confetti frame (the shafts streaming from behind the falling column) with
one structure, and compares the picture with the reference's, made here: mean and largest
difference in codes of the 8-bit picture, the share of pixels more than 4 codes off, and the
milliseconds of the shafts' stages alone (occluders, passes, composite; the median of 5 after a
warm-up). The structures: the article's author (3 chained passes of 4 taps at a quarter of the
resolution), PavelDoGreat's 16 taps, three.js's 3 passes of 6, Babylon.js's 100, and ours. They
take our sampling of the one shaft integral (render/shafts.py), not the peers' exact shaders: what
is compared is how taps, passes and resolution trade error for time. docs/shafts.md quotes it.

    python benchmarks/shafts.py [--size 512] [--particles 4096]
"""

import argparse

import numpy as np

from es2particles import open_context
from es2particles.frame.pipeline import Pipeline
from es2particles.report.measure import median_time
from es2particles.scenes.confetti import Confetti

STRUCTURES = {
    "the author's: 3 x 4 taps at 1/4": dict(shaft_taps=4, shaft_passes=3, shaft_scale=0.25,
                                            shaft_jitter="off"),
    "PavelDoGreat's: 16 taps": dict(shaft_taps=16, shaft_passes=1, shaft_jitter="off"),
    "16 taps, jittered": dict(shaft_taps=16, shaft_passes=1),
    "three.js's: 3 x 6 taps at 1/2": dict(shaft_taps=6, shaft_passes=3, shaft_scale=0.5,
                                          shaft_jitter="off"),
    "Babylon.js's: 100 taps": dict(shaft_taps=100, shaft_passes=1, shaft_jitter="off"),
    "3 x 8 taps at 1/2, jittered": dict(shaft_taps=8, shaft_passes=3, shaft_scale=0.5),
    "3 x 8 taps, jittered": dict(shaft_taps=8, shaft_passes=3),
    "4 x 6 taps, jittered": dict(shaft_taps=6, shaft_passes=4),
    "ours (default): 2 x 12 taps, jittered": {},
    "2 x 12 taps": dict(shaft_jitter="off"),
}
OURS = "ours (default): 2 x 12 taps, jittered"


def picture(ctx, size, particles, **options):
    """The confetti frame with ``options``, the shafts' stages' milliseconds, and each pixel's
    distance in pixels from the light's point on the screen."""
    with Pipeline(ctx, Confetti(**options), particles=particles, size=size, steps=120) as p:
        next(p.frames())
        image = p.image().astype(float)
        stages = [s for s in p.plan.stages if s.kind == "shafts"]
        camera = p.camera(0, 1)
        frame = p.executor.frame(camera)
        seconds = median_time(lambda: [p.executor.run(s, frame) for s in stages], ctx.finish)
        lights = [s.uniforms["u_light"] for s in stages if s.name == "shaft composite"]
    if not lights:  # no shafts
        return image, 1e3 * seconds, None
    pixels, _, _ = camera.project(np.array([lights[0]]), size)  # x right, y down from the top
    rows, columns = np.mgrid[:size[1], :size[0]] + 0.5
    return image, 1e3 * seconds, np.hypot(columns - pixels[0, 0], rows - pixels[0, 1])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--particles", type=int, default=4096)
    args = parser.parse_args(argv)
    size = (args.size, args.size)
    with open_context() as ctx:
        reference, reference_ms, _ = picture(ctx, size, args.particles, shafts="reference")
        plain, _, _ = picture(ctx, size, args.particles)
        print(f"Confetti at {args.size}x{args.size}, {args.particles} particles, on "
              f"{ctx.caps.renderer}; the shafts change the picture by "
              f"{np.abs(reference - plain).mean():.1f} codes on average.\n")
        print("| structure | taps a pixel | samples a ray | mean error (codes) | largest | "
              "pixels > 4 codes off | ms |")
        print("|---|---|---|---|---|---|---|")
        print(f"| reference: 1,024 taps | 1024 | 1024 | 0 | 0 | 0 | {reference_ms:.1f} |")
        for name, options in STRUCTURES.items():
            image, ms, distance = picture(ctx, size, args.particles, shafts="on", **options)
            taps = options.get("shaft_taps", 12)
            passes = options.get("shaft_passes", 2)
            d = np.abs(image - reference).max(axis=2)
            print(f"| {name} | {taps * passes} | {taps ** passes} | {d.mean():.2f} | "
                  f"{d.max():.0f} | {np.mean(d > 4):.3%} | {ms:.1f} |")
            if name == OURS:
                ours = d, distance
        d, distance = ours
        far, near = distance[d > 4], d[distance < 20]
        where = (f"lie {far.min():.0f} to {far.max():.0f} pixels from the light's point"
                 if far.size else "are none")
        print(f"\nOurs: the pixels more than 4 codes off {where}; within 20 pixels of the light "
              f"the largest error is {near.max():.0f} codes." if near.size else
              f"\nOurs: the pixels more than 4 codes off {where}; no pixel lies within 20 "
              "pixels of the light.")


if __name__ == "__main__":
    main()
