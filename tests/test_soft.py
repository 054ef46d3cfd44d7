"""Soft particles and a lower-resolution sprite buffer (the ARM chapter's smoke look,
render/sprites.py with soft and buffer_scale, sprites/upsample.frag): a sprite fades by its
distance to the opaque scene behind it, read from the scene's depth texture or from a packed
pre-pass; laid back over the picture, a bilateral upsample follows the scene's edges better than
a bilinear or nearest one. References in float64: the fade's clamp(gap / soft, 0, 1), a
sphere's silhouette from a pinhole."""

import time

import numpy as np
import pytest

from es2particles import Simulation
from es2particles.errors import CapabilityError
from es2particles.frame.pipeline import Pipeline, Renderer
from es2particles.render.buffer import SoftParticles, SpriteBuffer
from es2particles.render.camera import Camera
from es2particles.render.meshes import floor
from es2particles.render.sprites import Sprites
from es2particles.scenes import Collision3D, Fountain

pytestmark = pytest.mark.gl
SIZE = (96, 96)
DOWN = Camera(eye=(0.0, 5.0, 0.0), target=(0.0, 0.0, 0.0), up=(0.0, 0.0, -1.0), fov=40.0)


def centre_glow(gl, height, soft, scene_depth, buffer_scale=1.0):
    """The sprite's added light at the centre pixel: a white disc sprite over a black floor,
    seen straight down, its centre ``height`` above the floor."""
    scene = Fountain()
    with Simulation(gl, scene.graph(), 1, fmt="rgba32f") as sim:
        sim.upload("position", np.array([[0.0, height, 0.0]]))
        sim.upload("life", np.array([[0.0, 10.0]]))
        black = floor(3.0, colour=(0.0, 0.0, 0.0), colour2=(0.0, 0.0, 0.0))
        sprites = Sprites(sprite="disc", blend="add", size_spread=0.0, tint=(1, 1, 1, 1),
                          opacity=1.0, attenuation=(1.0, 0.0, 0.0), meshes=(black,),
                          light=(0.0, 5.0, 0.0), background=(0, 0, 0),
                          soft=SoftParticles(soft, scene_depth) if soft > 0 else None,
                          buffer=SpriteBuffer(buffer_scale) if buffer_scale < 1 else None)
        with Renderer(gl, sprites, sim, size=SIZE, point_size=40.0 * 1024 / SIZE[1]) as r:
            r.draw(DOWN)
            image = r.read().astype(float)
    return image[SIZE[1] // 2 - 1:SIZE[1] // 2 + 1, SIZE[0] // 2 - 1:SIZE[0] // 2 + 1].mean()


@pytest.mark.parametrize("scene_depth", ["texture", "packed"])
def test_a_soft_sprite_fades_by_its_distance_to_the_scene_behind(gl, scene_depth):
    """At heights of a quarter, a half and twice the soft distance over the floor the centre
    glows clamp(height / soft, 0, 1) of a free sprite's, to the colour's rounding (a code) and
    the packed distance's 16 bits (far / 65024 over soft)."""
    soft = 0.4
    free = centre_glow(gl, 2.0, 0.0, "auto", buffer_scale=1.0)
    assert free > 100
    codes = 1.5 / free + 100.0 / 65024 / soft
    for height in (0.1, 0.2, 0.8):
        got = centre_glow(gl, height, soft, scene_depth) / free
        want = min(height / soft, 1.0)
        print(f"{scene_depth}: height {height}: {got:.4f} of a free sprite's glow, "
              f"clamp(h / soft) = {want:.4f}")
        assert abs(got - want) < codes + 0.01
    assert centre_glow(gl, -0.05, soft, scene_depth) == 0  # under the floor: hidden


def test_the_depth_texture_path_needs_a_context_that_has_it(gl):
    from es2particles.frame.plan import plan_frame
    from es2particles.frame.settings import FrameSettings
    from es2particles.gl.context import Capabilities

    caps = Capabilities.assumed(version="OpenGL ES 2.0", extensions=frozenset())
    scene = Collision3D(soft=0.2, field_resolution=16)
    plan = plan_frame(scene, FrameSettings(particles=64, size=(32, 32)), caps)
    assert "scene depth" in plan.resources  # auto: the packed pre-pass
    with pytest.raises(CapabilityError, match="scene depth 'texture': this context cannot"):
        from dataclasses import replace

        from es2particles.frame.plan import PlanBuilder
        from es2particles.frame.settings import Defaults

        b = PlanBuilder("x", FrameSettings(particles=64, size=(32, 32)), caps, Sprites())
        b.graph_plan = plan.graph
        b.layout, b.format, b.size = plan.layout, plan.format, (32, 32)
        replace(scene.rendering(), soft=SoftParticles(0.1, "texture")).plan(b, Defaults())


def sphere_edges(camera, size, centre=(0.0, 1.0, 0.0), radius=1.0, width=2.0):
    """Pixels within ``width`` pixels of a sphere's silhouette: the pixel's ray passes the
    centre at the radius, to a pixel's worth of world at the sphere's distance."""
    w, h = size
    eye, target = np.array(camera.eye, float), np.array(camera.target, float)
    f = (target - eye) / np.linalg.norm(target - eye)
    r = np.cross(f, (0.0, 1.0, 0.0))
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    focal = h / 2 / np.tan(np.radians(camera.fov) / 2)
    cols, rows = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    d = f + ((cols - w / 2) / focal)[..., None] * r - ((rows - h / 2) / focal)[..., None] * u
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    c = np.array(centre) - eye
    miss = np.linalg.norm(c - (d @ c)[..., None] * d, axis=-1)
    return np.abs(miss - radius) < width * np.linalg.norm(c) / focal


@pytest.mark.slow
def test_a_bilateral_upsample_follows_the_object_s_edge_better(gl):
    """The chapter's smoke look on the 3D collision (puff sprites added, soft over 0.1 m) at
    full resolution, and from a buffer of half the resolution laid back by each upsampler: along
    the sphere's silhouette the bilateral one strays least from the full-resolution picture. The
    time each takes is printed; whether the smaller buffer is faster is the benchmarks' question
    (`bench.py`'s upsample section): on an H200 the half buffer drew no faster, its fixed cost
    is most of it."""
    size = (480, 270)
    look = dict(sprite="puff", blend="add", soft=0.1)

    def render(**options):
        with Pipeline(gl, Collision3D(**look, **options), particles=2 ** 13, size=size,
                      point_size=40.0, seed=3) as p:
            next(p.frames())
            image = p.image().astype(float)
            stage = p.plan.stage("sprites")
            gl.finish()
            start = time.perf_counter()
            for _ in range(3):
                p.executor.run(stage, p.executor.frame(p.camera(0, 1)))
            gl.finish()
            return image, (time.perf_counter() - start) / 3, p.camera(0, 1)

    reference, full_time, camera = render()
    edges = sphere_edges(camera, size)
    errors = {}
    for upsample in ("nearest", "bilinear", "bilateral"):
        image, half_time, _ = render(buffer_scale=0.5, upsample=upsample)
        diff = np.abs(image - reference).mean(axis=2)
        errors[upsample] = diff[edges].mean()
        print(f"{upsample}: edge error {errors[upsample]:.2f} codes, elsewhere "
              f"{diff[~edges].mean():.2f}; sprites {half_time * 1e3:.1f} ms against "
              f"{full_time * 1e3:.1f} at full resolution")
    assert errors["bilateral"] < errors["bilinear"] < errors["nearest"]


def over_picture(gl, soft, upsample="bilinear"):
    """Three overlapping 'over' sprites of opacity 0.6 well above a grey floor (at heights far
    past ``soft``: no fade), seen straight down: the picture."""
    scene = Fountain()
    with Simulation(gl, scene.graph(), 3, fmt="rgba32f") as sim:
        sim.upload("position", np.array([[0.0, 2.0, 0.0], [0.25, 1.8, 0.1], [-0.1, 1.6, -0.2]]))
        sim.upload("life", np.array([[0.0, 10.0]] * 3))
        grey = floor(3.0, colour=(0.5, 0.5, 0.5), colour2=(0.5, 0.5, 0.5))
        sprites = Sprites(sprite="disc", blend="over", size_spread=0.0, tint=(1, 0.5, 0.2, 1),
                          opacity=0.6, attenuation=(1.0, 0.0, 0.0), meshes=(grey,),
                          light=(0.0, 5.0, 0.0), background=(0, 0, 0),
                          soft=SoftParticles(soft) if soft > 0 else None,
                          buffer=SpriteBuffer(upsample=upsample) if soft > 0 else None)
        with Renderer(gl, sprites, sim, size=SIZE, point_size=40.0 * 1024 / SIZE[1]) as r:
            r.draw(DOWN)
            return r.read().astype(float)


def test_a_buffer_at_the_picture_s_resolution_lays_the_sprites_over_as_drawing_them_there(gl):
    """Over is associative: the sprites drawn premultiplied into a buffer of their own and that
    buffer laid over the picture make the picture the sprites drawn straight into it make, to
    the buffer's and the picture's rounding (a code each)."""
    direct = over_picture(gl, 0.0)
    buffered = over_picture(gl, 1e-3)  # soft, so buffered; every sprite far above the floor
    covered = direct[..., 0] - direct[..., 2] > 20  # orange sprites over the grey floor
    off = np.abs(buffered - direct)
    print(f"buffered against direct: max {off.max():.1f} codes, mean {off.mean():.3f}; "
          f"{covered.mean():.2f} of the pixels covered")
    assert covered.mean() > 0.1
    assert off.max() <= 2
