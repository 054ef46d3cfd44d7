"""The 3D fountain of the JOGL chapter: glowing fireball sprites leave the floor, fly parabolas,
fade and die at their lifetime or through the floor, over a checkered floor beside a textured
crate; the camera circles the scene.

Run it with ``python demos/fountain.py`` (after ``pip install .``); it writes
``out/fountain.png`` (a still from the fixed camera) and ``out/fountain.webp`` (an orbit), and
prints the plan. Change the parameters, the emitter table (point, launch direction, rate) and the
sprite options below.

The same from the command line:
``es2particles run fountain --out out/fountain.png`` and
``es2particles run fountain --frames 60 --camera orbit --out out/fountain.webp``
"""

from pathlib import Path

from es2particles import open_context
from es2particles.io.output import save_animation, save_image
from es2particles.frame.pipeline import Pipeline
from es2particles.scenes.fountain import Fountain, FountainParams

# Emitters: point, launch direction, share of births; ';' between them.
PARAMS = FountainParams(gravity=(0.0, -9.81, 0.0), drag=0.1, lifetime=(2.0, 2.5), floor="kill",
                        emitters="0,0,0,0,1,0,2; -2.5,0,1,0.3,1,0,1")
PARTICLES = 2 ** 12
SIZE = (960, 540)
FRAMES = 60


def main():
    out = Path("out")
    out.mkdir(exist_ok=True)
    with open_context() as ctx:
        still = Fountain(PARAMS)
        with Pipeline(ctx, still, PARTICLES, SIZE) as pipeline:
            print(pipeline.plan)
            next(pipeline.frames())
            save_image(pipeline.image(), out / "fountain.png")
        moving = Fountain(PARAMS.changed(camera="orbit"))
        with Pipeline(ctx, moving, PARTICLES, SIZE) as pipeline:
            frames = [pipeline.image() for _ in pipeline.frames(FRAMES, steps_per_frame=2)]
            save_animation(frames, out / "fountain.webp", fps=30)
    print(f"wrote {out / 'fountain.png'} and {out / 'fountain.webp'}")


if __name__ == "__main__":
    main()
