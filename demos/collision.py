"""The collision scene: a fountain of particles falling under gravity onto objects, bouncing or
sliding off, ageing, fading and re-emitted; the objects drawn under the particles.

Run it with ``python demos/collision.py`` (after ``pip install .``); it writes
``out/collision.png`` (a still, after one longest lifetime so the fountain is steady) and
``out/collision.webp`` (an animation), and prints the pass plan with the field's memory table.
Change ``shape`` (circle, box, capsule, a union like "circle+box", or a PNG silhouette whose dark
or opaque pixels are solid) and the other parameters below.

The same still from the command line:
``es2particles run collision --shape circle+box --out out/collision.png``
"""

from pathlib import Path

from es2particles import open_context
from es2particles.io.output import save_animation, save_image
from es2particles.frame.pipeline import Pipeline
from es2particles import Bloom
from es2particles.scenes.collision import Collision, CollisionParams

PARAMS = CollisionParams(shape="circle+box+capsule", gravity=(0.0, -3.0), drag=0.05, sliding=0.5,
                         bounce=0.6, lifetime=(3.0, 5.0))
PARTICLES = 2 ** 17
SIZE = (768, 768)
FRAMES = 48


def main():
    out = Path("out")
    out.mkdir(exist_ok=True)
    with open_context() as ctx:
        scene = Collision(PARAMS)
        with Pipeline(ctx, scene, PARTICLES, SIZE, point_size=2.0, gradient="gold",
                      bloom=Bloom(threshold=0.5)) as pipeline:
            print(pipeline.plan)
            frames = []
            for frame in pipeline.frames(FRAMES, steps_per_frame=2):
                if frame == 0:  # after one longest lifetime: the fountain is steady
                    print("wrote", save_image(pipeline.image(), out / "collision.png"))
                frames.append(pipeline.image()[::2, ::2])
            print("wrote", save_animation(frames, out / "collision.webp", fps=15))


if __name__ == "__main__":
    main()
