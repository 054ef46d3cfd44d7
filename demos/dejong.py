"""The article's picture: the Peter de Jong attractor, 2^20 particles, 1024x1024, headless.

Run it with ``python demos/dejong.py`` (after ``pip install .``); it writes
``out/dejong.png`` and ``out/dejong.webp`` (a short animation of the coefficients) and prints the
pass plan. Change the picture by editing the values below:

- ``COEFFICIENTS``: a, b, c, d of x' = sin(a y) - cos(b x), y' = sin(c x) - cos(d y). The article's
  (1.4, -2.3, 2.4, -2.1) work well; (2.01, -2.53, 1.61, -0.33) and (-2.7, -0.09, -0.86, -2.2) are
  other good ones.
- ``GRADIENT``: inferno, ice, viridis, gold, grey, a colour list '#000000,#ff8800,#ffffff', or the
  path of a 256x1 PNG.
- ``RESEED``: False iterates the particles step after step (the density converges to the
  attractor); True restarts every frame from a grid, as the article does.

The same picture from the command line:
``es2particles run dejong --a 1.4 --b -2.3 --c 2.4 --d -2.1 --out out/dejong.png``
"""

from pathlib import Path

from es2particles import open_context
from es2particles.io.output import save_animation, save_image
from es2particles.frame.pipeline import Pipeline
from es2particles import Bloom
from es2particles.scenes.dejong import DeJong

COEFFICIENTS = (1.4, -2.3, 2.4, -2.1)
ANIMATE_TO = (1.5, -2.2, 2.3, -2.0)
GRADIENT = "inferno"
RESEED = False
PARTICLES = 2 ** 20
SIZE = (1024, 1024)
FRAMES = 24


def main():
    out = Path("out")
    out.mkdir(exist_ok=True)
    with open_context() as ctx:
        scene = DeJong(coefficients=COEFFICIENTS, reseed=RESEED, animate_to=ANIMATE_TO)
        with Pipeline(ctx, scene, PARTICLES, SIZE, gradient=GRADIENT, bloom=Bloom()) as pipeline:
            print(pipeline.plan)
            frames = []
            for frame in pipeline.frames(FRAMES, steps_per_frame=2):
                if frame == 0:
                    print("wrote", save_image(pipeline.image(), out / "dejong.png"))
                frames.append(pipeline.image()[::2, ::2])  # half size keeps the file small
            print("wrote", save_animation(frames, out / "dejong.webp", fps=12))


if __name__ == "__main__":
    main()
