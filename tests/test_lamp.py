"""The ARM chapter's lamp and shadows (render/lamp.py, collision3d --shadows on): the object's
shadow on the floor where the rays from the lamp past the sphere land, the particles' shadows on
the floor and on the object, and none from particles the object hides from the lamp; places
found in float64 (ray and sphere, pinhole projection), independent of the renderer."""

import numpy as np
import pytest

from es2particles import Simulation
from es2particles.cli import main
from es2particles.frame.pipeline import Renderer
from es2particles.render.camera import Camera
from es2particles.scenes import Collision3D

pytestmark = pytest.mark.gl
SIZE = (320, 240)
CAMERA = Camera(eye=(0.0, 5.0, 7.0), target=(0.0, 0.5, 0.0), fov=50.0)
LAMP = (3.0, 6.0, 0.0)
CENTRE, RADIUS = np.array([0.0, 1.0, 0.0]), 1.0


def pixel(points):
    """(column, row) of world points, by a pinhole of the camera's fov (not render/camera.py)."""
    eye, target = np.array(CAMERA.eye), np.array(CAMERA.target)
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, (0.0, 1.0, 0.0))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.asarray(points, float) - eye
    focal = SIZE[1] / 2 / np.tan(np.radians(CAMERA.fov) / 2)
    depth = d @ forward
    return np.stack([SIZE[0] / 2 + focal * (d @ right) / depth,
                     SIZE[1] / 2 - focal * (d @ up) / depth], -1)


def floor_behind(point):
    """Where the ray from the lamp through ``point`` meets the floor y = 0."""
    lamp = np.array(LAMP)
    t = lamp[1] / (lamp[1] - point[1])
    return lamp + t * (np.asarray(point, float) - lamp)


def draw(gl, positions, shadows="on", lamp_angle=90.0):
    """The collision3d scene's lamp-lit frame with particles (alive) at ``positions``."""
    lamp = dict(lamp=LAMP, lamp_angle=lamp_angle) if shadows == "on" else {}
    scene = Collision3D(shadows=shadows, field_resolution=32, **lamp)
    count = max(len(positions), 1)
    with Simulation(gl, scene.graph(gl.caps), count, fmt="rgba32f") as sim:
        x = np.array(positions, float).reshape(-1, 3) if len(positions) else np.zeros((1, 3))
        sim.upload("position", x)
        sim.upload("velocity", np.zeros((count, 3)))
        life = np.tile([1.0, 300.0], (count, 1)) if len(positions) else np.array([[0.0, 0.0]])
        sim.upload("life", life)
        with Renderer(gl, scene.rendering(), sim, size=SIZE, point_size=30.0) as renderer:
            renderer.draw(CAMERA)
            return renderer.read().astype(float).mean(axis=2)


def brightness(image, world, radius=2):
    c, r = np.round(pixel(world)).astype(int)
    return image[r - radius:r + radius + 1, c - radius:c + radius + 1].mean()


def test_the_object_shadows_the_floor_where_the_lamp_s_rays_pass_it(gl):
    image = draw(gl, [])
    behind = floor_behind(CENTRE)  # the shadow's middle: the ray through the sphere's centre
    beside = floor_behind(CENTRE + np.array([0.0, 0.0, 1.8]))  # a ray that misses the sphere
    assert np.linalg.norm(np.cross(beside - LAMP, CENTRE - LAMP)) / np.linalg.norm(
        beside - LAMP) > RADIUS  # the control ray misses the sphere
    shade, lit = brightness(image, behind), brightness(image, beside)
    print(f"floor in the sphere's shadow {shade:.1f}, beside it {lit:.1f}")
    assert shade < 0.6 * lit


def test_particles_shadow_the_floor_and_the_object_and_hidden_ones_do_not(gl):
    """A cloud of particles between the lamp and a floor patch darkens that patch; one between
    the lamp and the top of the sphere darkens the sphere there; one below the sphere, which the
    sphere hides from the lamp, leaves the sphere as it was."""
    rng = np.random.default_rng(2)

    def cloud(at, n=400, spread=0.12):
        return np.asarray(at) + rng.uniform(-spread, spread, (n, 3))

    patch = np.array([-0.5, 0.0, 2.2])  # on the floor, in the lamp's light
    over_patch = np.array(LAMP) + 0.5 * (patch - np.array(LAMP))  # halfway to the lamp
    # A point of the sphere both the lamp and the camera see, and a cloud on its way to the lamp,
    # far enough along that the camera sees the cloud well away from the point.
    lamp, eye = np.array(LAMP), np.array(CAMERA.eye)
    towards = (lamp - CENTRE) / np.linalg.norm(lamp - CENTRE) + (eye - CENTRE) / np.linalg.norm(
        eye - CENTRE)
    top = CENTRE + RADIUS * towards / np.linalg.norm(towards)
    over_top = top + 0.7 * (lamp - top)
    assert np.linalg.norm(pixel(over_top) - pixel(top)) > 30
    hidden = CENTRE - 1.4 * (np.array(LAMP) - CENTRE) / np.linalg.norm(np.array(LAMP) - CENTRE)
    hidden[1] = max(hidden[1], 0.1)

    bare = draw(gl, [])
    floor_shaded = draw(gl, cloud(over_patch))
    top_shaded = draw(gl, cloud(over_top))
    behind = draw(gl, cloud(hidden))
    seen_top = top
    figures = {"floor patch": (brightness(bare, patch), brightness(floor_shaded, patch)),
               "sphere top": (brightness(bare, seen_top), brightness(top_shaded, seen_top)),
               "sphere top, particles hidden": (brightness(bare, seen_top),
                                                brightness(behind, seen_top))}
    for name, (before, after) in figures.items():
        print(f"{name}: {before:.1f} without particles, {after:.1f} with")
    assert figures["floor patch"][1] < 0.8 * figures["floor patch"][0]
    assert figures["sphere top"][1] < 0.8 * figures["sphere top"][0]
    assert abs(figures["sphere top, particles hidden"][1] - figures["sphere top, particles "
                                                                    "hidden"][0]) < 1.0


def test_the_plan_lists_the_lamp_s_stages_in_the_chapter_s_order(capsys):
    assert main(["plan", "collision3d", "--shadows", "on", "--field-resolution", "24",
                 "--particles", "256"]) == 0
    text = capsys.readouterr().out
    order = ["lamp depth: mesh 2", "lamp particles", "mesh 2:", "lamp shadow: mesh 2",
             "mesh 1:", "sprites:"]
    where = [text.index(f". {name}") for name in order]
    assert where == sorted(where), text


def test_shadows_off_draws_what_it_drew_before(gl):
    """--shadows off (the default) keeps the plain meshes: no light map in the plan."""
    scene = Collision3D(field_resolution=24)
    with Simulation(gl, scene.graph(gl.caps), 16) as sim, \
            Renderer(gl, scene.rendering(), sim, size=(32, 32)) as renderer:
        assert "light map" not in renderer.plan.resources


def test_the_lamp_s_disc_is_full_to_three_quarters_of_its_cone_then_fades(gl):
    """The chapter's lamp lights a disc: full out to 0.75 of its cone's radius (in the light
    map's projection, tan of the angle off its axis over tan of the half cone), fading to 0 at
    the rim by smoothstep: at 0.95 of the radius 0.104 of the light is left. Each floor point's
    brightness is taken against the same point with the lamp off (its colour and the scene's
    light cancel out) and against the disc's full middle."""
    lit, unlit = draw(gl, [], lamp_angle=40.0), draw(gl, [], shadows="off")
    lamp, target = np.array(LAMP), np.zeros(3)
    axis = (target - lamp) / np.linalg.norm(target - lamp)
    half = np.radians(40.0 / 2)

    def floor_point(r, direction):
        """The floor point along ``direction`` from the target at ``r`` of the cone's radius."""
        lo, hi = 0.0, 20.0
        for _ in range(60):
            mid = (lo + hi) / 2
            v = target + mid * np.asarray(direction) - lamp
            angle = np.arccos(np.dot(v, axis) / np.linalg.norm(v))
            lo, hi = (mid, hi) if np.tan(angle) / np.tan(half) < r else (lo, mid)
        return target + lo * np.asarray(direction)

    def share(r):
        p = floor_point(r, (0.0, 0.0, 1.0))  # towards the camera, clear of the sphere's shadow
        return brightness(lit, p) / brightness(unlit, p)

    full, edge = share(0.5), share(0.95)
    print(f"lamp's light against the lamp off: {full:.3f} at half the cone, {edge:.3f} at 0.95")
    assert edge < 0.6 * full
