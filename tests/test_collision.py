"""The collision scene against the float64 numpy twin of its integrator and response."""

import numpy as np
import pytest

from es2particles import ParameterError, Simulation
from es2particles.fields.field2d import Box, Circle, CollisionField
from es2particles.scenes.collision import RECT, Collision, CollisionParams
from es2particles.twins.particle import step_reference

POSITION_HALF_CODE = 2 / 65024 / 2  # range [-1, 1]
VELOCITY_HALF_CODE = 16 / 65024 / 2  # range [-8, 8]
F32 = 1e-6  # float32 arithmetic over a sub-stepped step, in position units
# Velocity goes through more float32 operations (decay, response, energy rescale) in each of up to
# ~20 sub-steps at speeds up to 8: about 20 x 5 x 2^-24 x 8 = 5e-5.
F32_VELOCITY = 5e-5


def free_particles(scene, n, rng, speed=2.0):
    """n particles at random places outside every object, random velocities, long lives."""
    points = []
    while sum(len(p) for p in points) < n:
        x = rng.uniform(-0.97, 0.97, (4 * n, 2))
        points.append(x[scene.field.exact_distance(x) > 0.02])
    x = np.concatenate(points)[:n]
    v = rng.uniform(-speed, speed, (n, 2))
    life = np.stack([np.zeros(n), np.full(n, 10.0)], 1)
    return x, v, life


def start(sim, scene, x, v, life):
    scene.initialise(sim, np.random.default_rng(0))
    sim.upload("position", x)
    sim.upload("velocity", v)
    sim.upload("life", life)


def download(sim):
    return sim.download("position"), sim.download("velocity"), sim.download("life")



def test_short_horizon_steps_agree_with_float64(gl):
    params = CollisionParams(emit=False, drag=0.2)
    scene = Collision(params.changed(shape="circle+box"))
    n, steps = 20000, 30
    errors_x, errors_v = [], []
    collided = 0
    with Simulation(gl, scene.graph(), n) as sim:
        start(sim, scene, *free_particles(scene, n, np.random.default_rng(1)))
        for _ in range(steps):
            x0, v0, l0 = download(sim)
            sim.step()
            x1, v1, _ = download(sim)
            xr, vr, _ = step_reference(x0, v0, l0, scene.field, params)
            turned = np.sum(vr * v0, axis=1) < 0.9 * np.sum(v0 * v0, axis=1)
            collided += np.count_nonzero(turned)
            errors_x.append(np.abs(x1 - np.clip(xr, -1, 1)).max(axis=1))
            errors_v.append(np.abs(v1 - np.clip(vr, -8, 8)).max(axis=1))
    ex, ev = np.concatenate(errors_x), np.concatenate(errors_v)
    tight_x, tight_v = POSITION_HALF_CODE + F32, VELOCITY_HALF_CODE + F32_VELOCITY
    outside = np.count_nonzero((ex > tight_x) | (ev > tight_v))
    print(f"collision, {steps} steps of {n} ({collided} particle-steps with a bounce): max "
          f"|position error| {ex.max():.3e} (half code {POSITION_HALF_CODE:.3e}), 99.9th "
          f"percentile {np.quantile(ex, 0.999):.3e}; max |velocity error| {ev.max():.3e} (half "
          f"code {VELOCITY_HALF_CODE:.3e}), 99.9th percentile {np.quantile(ev, 0.999):.3e}; "
          f"{outside} of {ex.size} particle-steps outside half a code + float32")
    assert collided > 1000, "the test must include collisions"
    # A grazing contact (distance within float32 rounding of 0) can take the other branch of
    # `d < 0` in float32 than in float64: allow a few such particle-steps, and bound them.
    assert outside <= 1e-4 * ex.size
    assert ex.max() <= 1e-4 and ev.max() <= 2e-3


def test_no_live_particle_ends_a_step_deeper_than_one_cell(gl):
    scene = Collision(CollisionParams(shape="circle+box+capsule", emit=True, bounce=0.9, sliding=0.2))
    with Simulation(gl, scene.graph(), 16384) as sim:
        scene.initialise(sim, np.random.default_rng(2))
        deepest = 0.0
        for _ in range(240):
            sim.step()
            x, _, life = download(sim)
            alive = (life[:, 0] >= 0) & (life[:, 0] < life[:, 1])
            deepest = min(deepest, scene.field.exact_distance(x[alive]).min())
    print(f"deepest live particle after any step: {deepest:.4f} (one cell {scene.field.cell:.4f})")
    assert deepest >= -scene.field.cell


@pytest.mark.parametrize("sliding", [0.0, 0.5, 1.0])
def test_energy_never_grows_with_r_at_most_one(gl, sliding):
    params = CollisionParams(emit=False, drag=0.0, bounce=1.0, sliding=sliding)
    scene = Collision(params.changed(shape="circle+box"))
    g = -params.gravity[1]
    n = 8192
    with Simulation(gl, scene.graph(), n) as sim:
        start(sim, scene, *free_particles(scene, n, np.random.default_rng(3)))

        def energy():
            x, v, _ = download(sim)
            return 0.5 * np.sum(v * v, axis=1) + g * x[:, 1]

        e = energy()
        # One step's quantisation can add at most |v| * half code + g * half code per particle.
        tolerance = 8 * VELOCITY_HALF_CODE + g * POSITION_HALF_CODE + 1e-5
        worst = -np.inf
        for _ in range(120):
            sim.step()
            e_next = energy()
            worst = max(worst, (e_next - e).max())
            e = e_next
    print(f"sliding {sliding}: largest one-step energy rise {worst:.2e} (quantisation "
          f"tolerance {tolerance:.2e})")
    assert worst <= tolerance


def test_degenerate_contacts_produce_no_nan(gl):
    field = CollisionField(RECT, [Box((0.0, -0.5), (0.2, 0.2)), Circle((0.35, -0.5), 0.15)])
    params = CollisionParams(emit=False, drag=0.0, gravity=(0.0, -3.0))
    scene = Collision(params, field=field)
    top = -0.3  # the box's top face
    x = np.array([[0.0, top], [0.0, top + 0.001], [0.0, top], [-0.999, -0.999],
                  [0.2, -0.3], [0.0, 0.0], [0.05, top]])
    v = np.array([[0.0, 0.0], [0.0, -3.0], [0.0, 0.0], [-1.0, -1.0], [1.0, -1.0], [0.0, 0.0],
                  [0.0, -7.9]])
    # on the surface at rest; along the normal; at rest in a wall corner; in the corner between
    # the box and the circle; free at rest; straight down hard.
    n = len(x)
    life = np.stack([np.zeros(n), np.full(n, 10.0)], 1)
    with Simulation(gl, scene.graph(), n) as sim:
        start(sim, scene, x, v, life)
        for _ in range(30):
            x0, v0, l0 = download(sim)
            sim.step()
            x1, v1, _ = download(sim)
            xr, vr, _ = step_reference(x0, v0, l0, field, params)
            assert np.all(np.isfinite(xr)) and np.all(np.isfinite(vr)), "the reference made NaN"
            # NaN written to a packed texture would come back as the range's bottom, far from
            # the reference; contacts here are exact, so allow the grazing-branch bound.
            assert np.abs(x1 - xr).max() <= 1e-4, (x1, xr)
            assert np.abs(v1 - vr).max() <= 2e-3, (v1, vr)


def test_no_tunnelling_through_a_thin_wall_at_a_large_time_step(gl):
    cells = (256, 256)
    cell = 2 / 256
    wall = Box((0.0, 0.0), (0.75 * cell, 1.0))  # 1.5 cells thick, floor to ceiling
    field = CollisionField(RECT, [wall], resolution=cells)
    params = CollisionParams(emit=False, drag=0.0, gravity=(0.0, 0.0), dt=0.05, bounce=1.0)
    scene = Collision(params, field=field)
    n = 4096
    rng = np.random.default_rng(4)
    x = np.stack([rng.uniform(-0.9, -0.1, n), rng.uniform(-0.8, 0.8, n)], 1)
    v = np.stack([rng.uniform(3, 7.9, n), rng.uniform(-1, 1, n)], 1)  # up to 50 cells a step
    life = np.stack([np.zeros(n), np.full(n, 10.0)], 1)
    with Simulation(gl, scene.graph(), n) as sim:
        start(sim, scene, x, v, life)
        for _ in range(20):
            sim.step()
            crossed = np.count_nonzero(sim.download("position")[:, 0] > 0)
            assert crossed == 0, f"{crossed} particles tunnelled through the wall"


def test_respawn_rate_matches_the_lifetime_distribution(gl):
    params = CollisionParams(lifetime=(1.0, 2.0))
    scene = Collision(params)
    n = 32768
    with Simulation(gl, scene.graph(), n) as sim:
        scene.initialise(sim, np.random.default_rng(5))
        sim.run(int(2.5 / params.dt))  # past the longest lifetime: steady
        counts = []
        age = sim.download("life")[:, 0]
        for _ in range(60):
            sim.step()
            new_age = sim.download("life")[:, 0]
            counts.append(np.count_nonzero(new_age < age))  # age went back: re-emitted
            age = new_age
    expected = n * params.dt / np.mean(params.lifetime)
    got = np.mean(counts)
    sigma = np.sqrt(expected / len(counts))
    print(f"re-emitted per step: {got:.1f}, expected N dt / mean lifetime = {expected:.1f} "
          f"(+-{sigma:.1f})")
    assert abs(got - expected) <= 5 * sigma + 0.02 * expected


def test_respawned_particles_start_at_the_emitter_with_emitted_velocities(gl):
    params = CollisionParams(lifetime=(0.5, 0.5))
    scene = Collision(params)
    with Simulation(gl, scene.graph(), 4096) as sim:
        scene.initialise(sim, np.random.default_rng(6))
        sim.run(45)
        x, v, life = download(sim)
    young = (life[:, 0] >= 0) & (life[:, 0] < 0.5 * params.dt)  # born this step: age 0
    assert young.sum() > 20
    speed = np.hypot(*v[young].T)
    angle = np.arctan2(v[young, 1], v[young, 0])
    assert np.all((speed > params.speed[0] - 0.05) & (speed < params.speed[1] + 0.05))
    assert np.all(np.abs(angle - np.radians(params.direction)) <= np.radians(params.spread) / 2 + 0.02)
    reach = params.speed[1] * params.dt * 2
    assert np.all(np.hypot(*(x[young] - params.emitter).T) <= reach)


def test_bad_scene_input_is_a_clear_error(tmp_path):
    from PIL import Image

    blank = tmp_path / "blank.png"
    Image.new("L", (32, 32), 255).save(blank)
    with pytest.raises(ParameterError, match="is empty: no solid pixels"):
        Collision(shape=str(blank))
    solid = tmp_path / "solid.png"
    Image.new("L", (32, 32), 0).save(solid)
    with pytest.raises(ParameterError, match="solid everywhere"):
        Collision(shape=str(solid))
    broken = tmp_path / "broken.png"
    broken.write_bytes(b"not a png")
    with pytest.raises(ParameterError, match="cannot be read as an image"):
        Collision(shape=str(broken))
    with pytest.raises(ParameterError, match="does not exist"):
        Collision(shape=str(tmp_path / "missing.png"))
    with pytest.raises(ParameterError, match="outside the scene rectangle"):
        CollisionField(RECT, [Circle((5.0, 5.0), 0.5)])
    with pytest.raises(ParameterError, match="--lifetime MIN must be in"):
        CollisionParams(lifetime=(-1.0, 2.0))
    with pytest.raises(ParameterError, match="shape must be circle"):
        Collision(shape="triangle")
    with pytest.raises(ParameterError, match="field resolution must be in"):
        CollisionField(RECT, [], resolution=(0, 0))


def test_a_mask_silhouette_makes_a_field_like_the_shape_it_draws(tmp_path):
    from PIL import Image

    yy, xx = np.indices((256, 256))
    image = np.full((256, 256), 255, np.uint8)
    # A disc of radius 0.3 at (0, -0.2) in a [-1, 1] scene: rows run top to bottom in the image.
    cx, cy, r = 128, 128 + 0.2 * 128, 0.3 * 128
    image[(xx + 0.5 - cx) ** 2 + (yy + 0.5 - cy) ** 2 < r ** 2] = 0
    Image.fromarray(image).save(tmp_path / "disc.png")
    from_mask = CollisionField(RECT, mask=tmp_path / "disc.png")
    analytic = CollisionField(RECT, [Circle((0.0, -0.2), 0.3)])
    near = np.abs(analytic.distance) < 0.2
    error = np.abs(from_mask.distance - analytic.distance)[near].max()
    print(f"mask distance vs analytic circle: max |error| {error:.4f} (cell {analytic.cell:.4f})")
    assert error <= 1.5 * analytic.cell
    cos = np.sum(from_mask.normal * analytic.normal, axis=-1)[near & (np.abs(analytic.distance) > 2 * analytic.cell)]
    assert cos.min() > 0.9


def test_emission_matches_the_life_cycle_twin(gl):
    """Particles born during a step get age r.w dt and lifetime mix(min, max, r.z), with r the
    hash of their texel and the step (twins/life.py), as lib/life.glsl computes it."""
    from es2particles.twins.life import LIFE_STEPS, emits, life_random

    params = CollisionParams(emit=True, lifetime=(2.0, 4.0))
    scene = Collision(params.changed(field_resolution=32))
    n = 4096
    with Simulation(gl, scene.graph(), n) as sim:
        scene.initialise(sim, np.random.default_rng(3))
        sim.run(10)
        before = sim.download("life")
        step = sim.steps_done
        sim.step()
        after = sim.download("life")
        uv, size = sim.layout.texel_uv(), sim.layout.size
    aged = before + [params.dt, 0.0]
    born = emits(before, aged, params.dt)
    assert born.sum() > 10, "some particles must be born in the step"
    r = life_random(uv, step, size).astype(np.float64)
    expected_lifetime = 2.0 + 2.0 * r[:, 2]
    # The clock is exact: ages are whole steps, decoded in float32 from a range of +-LIFE_STEPS
    # steps, so only the decode's rounding remains.
    decode = 4 * 2.0 ** -24 * LIFE_STEPS * params.dt
    # The hash takes fract() of float32 products of numbers up to ~400: ulp-level differences
    # (the driver may fuse multiply-adds) reach ~4e-3 in r (measured 3.9e-3 on llvmpipe), so the
    # twin is not bit-exact there. A wrong formula (another r component, another range) is O(1).
    hash_error = 1e-2
    age_error = np.abs(after[born, 0]).max()
    lifetime_error = np.abs(after[born, 1] - expected_lifetime[born]).max()
    print(f"emission vs twin: age {age_error:.2e}, lifetime {lifetime_error:.2e}")
    assert age_error <= decode, "a new particle's age starts at 0"
    assert lifetime_error <= params.dt / 2 + hash_error * 2.0, "lifetimes are whole steps"
    assert np.abs(after[~born, 0] - aged[~born, 0]).max() <= decode, "the others aged by dt"
