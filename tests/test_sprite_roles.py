"""The sprites' inputs are roles mapped to a scene's quantities (render/sprites.py): position
alone (no life clock: every particle drawn), size (a factor of the sprite's size), colour (the
particle's tint) and orientation (its texture turned counterclockwise on screen). Each drawn on
GL and checked against where an independent float64 pinhole puts the sprite, and what the role
asks of its footprint."""

import numpy as np
import pytest

from es2particles import PassGraph, Simulation
from es2particles.frame.pipeline import Renderer
from es2particles.render.camera import Camera
from es2particles.render.sprites import Sprites

pytestmark = pytest.mark.gl
SIZE = (160, 120)
CAMERA = Camera(eye=(0.0, 0.0, 6.0), target=(0.0, 0.0, 0.0))
QUANTITIES = {"position": (3, -2, 2), "size": (1, 0, 4), "colour": (3, 0, 1),
              "orientation": (1, -4, 4), "heading": (3, -4, 4)}


def graph(tmp_path, names):
    """A graph holding ``names``, each kept as it is by its own pass."""
    g = PassGraph()
    for name in names:
        components, lo, hi = QUANTITIES[name]
        g.quantity(name, lo, hi, components=components)
        shader = tmp_path / f"hold_{name}.frag"
        shader.write_text(f"#version 100\nvoid main()\n{{\n    write_{name}(read_{name}(v_uv));\n}}\n")
        g.add(name, str(shader), writes=name, reads=[name])
    return g


def pixel(point):
    """(column, row) of a world point: a pinhole of the camera's fov, independent of
    render/camera.py."""
    d = np.subtract(point, CAMERA.eye)
    focal = SIZE[1] / 2 / np.tan(np.radians(CAMERA.fov) / 2)
    depth = -d[2]  # the camera looks down -z, up +y
    return SIZE[0] / 2 + focal * d[0] / depth, SIZE[1] / 2 - focal * d[1] / depth


def draw(gl, tmp_path, values, sprite="disc", pixels=32.0, **sprites):
    names = list(values)
    sprites = {"tint": (1, 1, 1, 0), **sprites}
    with Simulation(gl, graph(tmp_path, names), len(values["position"]), fmt="rgba32f") as sim:
        for name, value in values.items():
            sim.upload(name, np.asarray(value, float))
        rendering = Sprites(roles={n: n for n in names}, sprite=sprite, size_spread=0.0,
                            attenuation=(1.0, 0.0, 0.0), blend="over", background=(0, 0, 0),
                            **sprites)
        with Renderer(gl, rendering, sim, size=SIZE, point_size=pixels * 1024 / SIZE[1]) as r:
            r.draw(CAMERA)
            return r.read().astype(float)


def footprint(image, centre, radius=36):
    yy, xx = np.mgrid[0:SIZE[1], 0:SIZE[0]]
    near = (xx - centre[0]) ** 2 + (yy - centre[1]) ** 2 < radius ** 2
    return near & (image.max(axis=2) > 8), xx, yy


def test_position_alone_draws_every_particle_where_the_camera_sees_it(gl, tmp_path):
    points = [(-1.2, 0.5, 0.0), (1.0, -0.4, 0.5)]
    image = draw(gl, tmp_path, {"position": points})
    for p in points:
        lit, xx, yy = footprint(image, pixel(p))
        assert lit.sum() > 100, p  # a 32-pixel disc, drawn with no life clock
        centre = (xx[lit].mean(), yy[lit].mean())
        assert np.hypot(centre[0] - pixel(p)[0], centre[1] - pixel(p)[1]) < 0.75, (p, centre)


def test_size_scales_and_colour_tints_each_sprite(gl, tmp_path):
    points = [(-1.2, 0.0, 0.0), (1.2, 0.0, 0.0)]
    image = draw(gl, tmp_path, {"position": points, "size": [[0.5], [1.0]],
                                "colour": [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]}, tint=(1, 1, 1, 1))
    (small, _, _), (large, _, _) = (footprint(image, pixel(p)) for p in points)
    ratio = small.sum() / large.sum()
    print(f"lit pixels {small.sum()} and {large.sum()}: area ratio {ratio:.3f} (0.25 asked)")
    assert abs(ratio - 0.25) < 0.05
    red, blue = image[small].mean(axis=0), image[large].mean(axis=0)
    assert red[0] > 50 and max(red[1:]) < 2 and blue[2] > 50 and max(blue[:2]) < 2, (red, blue)


@pytest.mark.parametrize("angle", [0.0, np.pi / 2, 2.0, -0.7])
def test_orientation_turns_the_texture_counterclockwise_on_screen(gl, tmp_path, angle):
    """A texture opaque only in its left half, drawn 64 pixels wide: its lit half-disc's
    centroid lies on the side the turn puts it, (-cos a, -sin a) on screen with y up, to what
    pixels can place it (0.75 pixel at the centroid's distance, as the position test)."""
    texture = np.zeros((64, 64, 4), np.uint8)
    yy, xx = (np.mgrid[0:64, 0:64] + 0.5) / 32 - 1
    texture[(xx < 0) & (np.hypot(xx, yy) < 0.9)] = 255
    point = (0.0, 0.0, 0.0)
    image = draw(gl, tmp_path, {"position": [point], "orientation": [[angle]]}, sprite=texture,
                 pixels=64.0)
    lit, xx, yy = footprint(image, pixel(point))
    dx, dy = xx[lit].mean() - pixel(point)[0], -(yy[lit].mean() - pixel(point)[1])
    turned = np.degrees(np.arctan2(dy, dx) - np.arctan2(-np.sin(angle), -np.cos(angle)))
    turned = (turned + 180) % 360 - 180
    tolerance = np.degrees(np.arctan(0.75 / np.hypot(dx, dy)))
    print(f"angle {np.degrees(angle):.0f}: lit half's centroid off by {turned:.2f} degrees "
          f"(pixels place it to {tolerance:.2f})")
    assert lit.sum() > 400 and abs(turned) < tolerance


@pytest.mark.parametrize("point, velocity", [((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)),
                                             ((0.0, 0.0, 0.0), (0.0, -2.0, 0.0)),
                                             ((0.8, 0.5, 0.0), (0.3, 0.4, -2.0)),
                                             ((-1.0, -0.4, 1.0), (-0.5, 0.2, 1.5))])
def test_heading_points_the_texture_the_way_the_particle_moves_on_screen(gl, tmp_path, point,
                                                                        velocity):
    """A texture opaque only in its left half, turned by a velocity (the heading role): its lit
    half's centroid lies behind the particle's motion on the screen, the motion's direction
    taken here from the test's own pinhole, d/de pixel(p + e v) at e = 0 (float64), to what
    pixels can place it."""
    texture = np.zeros((64, 64, 4), np.uint8)
    yy, xx = (np.mgrid[0:64, 0:64] + 0.5) / 32 - 1
    texture[(xx < 0) & (np.hypot(xx, yy) < 0.9)] = 255
    image = draw(gl, tmp_path, {"position": [point], "heading": [velocity]}, sprite=texture,
                 pixels=64.0)
    centre = np.array(pixel(point))
    e = 1e-7
    ahead = (np.array(pixel(np.add(point, e * np.asarray(velocity)))) - centre) / e
    moving = np.arctan2(-ahead[1], ahead[0])  # y up on the screen
    lit, xx, yy = footprint(image, centre)
    dx, dy = xx[lit].mean() - centre[0], -(yy[lit].mean() - centre[1])
    turned = np.degrees(np.arctan2(dy, dx) - (moving + np.pi))
    turned = (turned + 180) % 360 - 180
    tolerance = np.degrees(np.arctan(0.75 / np.hypot(dx, dy)))
    print(f"heading {np.degrees(moving):.1f} degrees on screen: the lit half behind it off by "
          f"{turned:.2f} degrees (pixels place it to {tolerance:.2f})")
    assert lit.sum() > 200 and abs(turned) < tolerance
