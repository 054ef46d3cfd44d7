"""The numpy twins against physics that shares none of their code (issue #31).

The GPU tests of the 2D collision, the 3D collision and the fountain compare the shaders with
their numpy twins (``twins/particle.py``, ``twins/collision3d.py``, ``twins/fountain.py``), which
are line-by-line copies: a bug put into a shader and its twin alike passes every such comparison.
Here each twin meets closed forms written out below in float64, none of them twin code:

1. free flight under constant gravity and linear drag, against v(t) = v_inf + (v0 - v_inf)
   e^(-kt) and its integral (the parabola at k = 0), within the error semi-implicit Euler makes
   in sub-steps that move at most half a cell;
2. one contact with a flat floor, against the stated response (the chapter's Listing 2.3,
   docs/scenes/collision.md: v' = |v| r (n s + t (1 - s)), a head-on hit straight back in 2D),
   found within one sub-step of the true crossing and pushed out onto the surface; the
   fountain's floor against restitution (the normal velocity reversed and scaled by r);
3. resting contact: a particle on a floor under gravity stays there, within the field's
   storage, gains no energy and does not hop;
4. the side-of-entry rule: particles crossing walls thinner than two cells, at 64 offsets of the
   wall across a cell and speeds up to the velocity range's corner, come back out on the side
   they came from;
5. the sub-step rule, measured: no sub-step moves a particle more than half a cell (half a voxel
   relative to the 3D object);
6. the fields' sampling (the nearest cell's distance carried along its normal) against the
   analytic distance of a circle, a sphere and boxes, within bounds from the cell size.

Fast tier: numpy only, no GL context.
"""

import itertools

import numpy as np
import pytest

from es2particles.fields.field2d import Box, Circle, CollisionField
from es2particles.fields.field3d import Box as Box3, Sphere, VoxelField
from es2particles.scenes.collision import RECT, CollisionParams
from es2particles.scenes.collision3d import Collision3D, Collision3DParams
from es2particles.scenes.fountain import FountainParams
from es2particles.twins import collision3d as twin3d
from es2particles.twins import particle as twin2d
from es2particles.twins.fountain import fountain_step

F64 = 2.0 ** -52  # float64's relative step
# A twin's sub-step rounds each value it carries a handful of times (the drag update, the move,
# the response: under 8 roundings), each within F64 of the values' size; nothing in a sub-step
# multiplies an earlier error by more than 1 (drag's decay <= 1, the response scales by <= 1),
# so the errors add up over the sub-steps.
ROUNDINGS_PER_SUBSTEP = 8


def float64_drift(substeps, size):
    """The float64 rounding a twin can gather over ``substeps`` sub-steps on values of ``size``."""
    return ROUNDINGS_PER_SUBSTEP * substeps * F64 * size


def packed_distance_error(span):
    """How far a packed field's decoded distance is from the exact one at a cell's centre: half a
    code of the 16-bit grid (65024 codes over the span), and float32's rounding in the texel's
    encoding and in the decode (four operations, each within 2^-24 of a value no larger than the
    span)."""
    return span / 65024 / 2 + 4 * 2.0 ** -24 * span


# --- closed forms (float64) ----------------------------------------------------------------------

def free_flight(x0, v0, g, k, t):
    """Position and velocity at time t of x'' = g - k x' from x0, v0 (rows are particles)."""
    x0, v0, g = (np.asarray(a, float) for a in (x0, v0, g))
    if k == 0:
        return x0 + v0 * t + g * t * t / 2, v0 + g * t
    v_inf = g / k
    return (x0 + v_inf * t + (v0 - v_inf) * -np.expm1(-k * t) / k,
            v_inf + (v0 - v_inf) * np.exp(-k * t))


def euler_position_error_bound(x0, v0, g, k, dt, steps, longest_move):
    """The most semi-implicit Euler's positions (the velocity advanced first, exactly, then the
    move) can be from the closed form after ``steps`` steps, per particle.

    Over a sub-step h from velocity v the exact move is v_inf h + (v - v_inf)(1 - e^-kh)/k; the
    twin's is v(h) h = (v_inf + (v - v_inf) e^-kh) h. With a = g - k v = -k (v - v_inf) and
    z = kh, the difference is a (1 - e^-z (1 + z)) / k^2, and 0 <= 1 - e^-z (1 + z) <= z^2 / 2
    (its derivative z (1 - e^-z) lies in [0, z]), so each sub-step adds at most |a| h^2 / 2
    (exactly g h^2 / 2 at k = 0). The velocity is exact at every sub-step's end, so these add up:
    a step of n sub-steps of h = dt / n adds at most max|a| h dt / 2.

    h: the whole step where nothing limits it (``longest_move`` None: the fountain), else the
    longest a sub-step may be if none moves more than ``longest_move`` (half a cell): a sub-step
    moves its speed times h, so h <= longest_move / (the fastest the particle goes in the step).
    The rule forbids longer sub-steps; shorter ones only shrink the error."""
    bound = np.zeros(len(x0))
    for step in range(steps):
        samples = [free_flight(x0, v0, g, k, t)[1] for t in step * dt + dt * np.linspace(0, 1, 17)]
        speed = np.max([np.linalg.norm(v, axis=1) for v in samples], axis=0)
        acceleration = np.max([np.linalg.norm(g - k * v, axis=1) for v in samples], axis=0)
        h = dt if longest_move is None else np.minimum(dt, longest_move / speed)
        bound += acceleration * h * dt / 2
    return bound


def drag_gain_error_bound(g, k, v0, dt, steps, longest_move):
    """How far the velocity can be from the closed form through lib/drag.glsl's gain, the share
    (1 - e^-kh) / k of the acceleration a that a sub-step h adds: a sub-step's velocity is off by
    |a| h times the gain's relative error, so the run's by at most max|a| T times the largest.

    - Below k h = 1e-3 the gain is taken to first order, h (1 - kh / 2) (documented there): the
      series alternates, so the rest is under (kh)^2 / 6 of h, h at most the longest sub-step
      (the whole step, or ``longest_move`` over the slowest speed).
    - From k h = 1e-3 it is (1 - e^-kh) / k: exp's result near 1 is within 2^-53 of it and the
      subtraction is exact, so relative to kh >= 1e-3 it is within 2^-53 / 1e-3."""
    if k == 0:
        return 0.0  # the gain is h exactly
    h = dt
    if longest_move is not None:
        slowest = min(np.linalg.norm(free_flight(np.zeros_like(v0), v0, g, k, t)[1], axis=1).min()
                      for t in np.linspace(0, steps * dt, 8 * steps + 1))
        h = min(dt, longest_move / max(slowest, 1e-300))
    truncation = (k * h) ** 2 / 6 if k * h < 1e-3 else 0.0
    cancellation = 2.0 ** -53 / 1e-3
    largest = np.linalg.norm(np.asarray(g) - k * np.asarray(v0), axis=1).max()
    return largest * steps * dt * (truncation + cancellation)


# --- the twins, driven as their scenes drive them ------------------------------------------------

def run_collision2d(field, p, x, v, steps=1):
    life = np.tile([0.0, 10.0], (len(x), 1))  # alive throughout
    for _ in range(steps):
        x, v, life = twin2d.step_reference(x, v, life, field, p)
    return x, v


def run_collision3d(scene, x, v, steps=1, decoded=None, first_step=0):
    for step in range(first_step, first_step + steps):
        x, v = twin3d.step_reference(x, v, scene.field, scene.params, step, scene.substep,
                                     scene.surface_speed, None, decoded, scene.max_substeps)
    return x, v


def run_fountain(p, x, v, steps=1):
    for _ in range(steps):
        x, v, died = fountain_step(x, v, p)
        assert not died.any(), "the test's particles must stay in the fountain's box"
    return x, v


def empty_field_2d(resolution=256):
    """No object: the field reads far everywhere (the scene's walls are exact planes apart)."""
    return CollisionField(RECT, [], resolution=(resolution, resolution))


def scene_3d(field=None, **changes):
    """A 3D collision scene with no random kick; ``field``: the object (default: the scene's)."""
    return Collision3D(Collision3DParams(**{"jitter": 0.0, **changes}), field=field)


def half_voxel(scene):
    """The longest sub-step move the 3D rule allows relative to the object, in world units."""
    return 0.5 * scene.field.voxel * scene.params.scale


def viscosity_for(k, p=Collision3DParams()):
    """The air's viscosity that gives the Stokes drag rate k = 6 pi eta r / m."""
    return k * p.mass / (6 * np.pi * p.radius)


# --- 1. free flight ------------------------------------------------------------------------------

FLIGHT_2D = (np.array([[-0.6, -0.6], [-0.6, 0.2], [0.5, -0.7], [0.0, 0.5]]),
             np.array([[0.8, 2.4], [1.2, 0.5], [-1.1, 2.0], [0.3, 0.8]]))
FLIGHT_3D = (np.array([[2.5, 2.0, 2.5], [-2.5, 1.0, 2.0], [2.0, 3.5, -2.5]]),  # off the sphere
             np.array([[-0.5, 4.0, 0.3], [0.6, 5.0, -0.4], [0.2, 2.0, 0.5]]))
FLIGHT_FOUNTAIN = (np.array([[0.0, 0.5, 0.0], [1.0, 0.2, -1.0], [-2.0, 3.0, 1.0]]),
                   np.array([[1.0, 6.0, -0.5], [-1.5, 7.0, 2.0], [2.0, 3.0, -1.0]]))
# k = 0: the parabola; 0.05: below k h = 1e-3 in the collision scenes' sub-steps (drag's
# first-order gain); 2: strong drag, the exact exponential form.
DRAG_RATES = (0.0, 0.05, 2.0)


def run_free_flight(twin, k):
    """(x0, v0, g, dt, steps, the longest sub-step move allowed, the twin's x and v at the end,
    its sub-steps at most)."""
    if twin == "collision":
        g, dt, steps = np.array([0.4, -3.0]), 1 / 60, 60
        x0, v0 = FLIGHT_2D
        field = empty_field_2d()
        p = CollisionParams(emit=False, gravity=tuple(g), drag=k, dt=dt)
        x, v = run_collision2d(field, p, x0, v0, steps)
        return x0, v0, g, dt, steps, field.cell / 2, x, v, steps * p.max_substeps(field.cell)
    if twin == "collision3d":
        g, dt, steps = np.array([0.3, -9.81, 0.2]), 1 / 60, 60
        x0, v0 = FLIGHT_3D
        scene = scene_3d(gravity=tuple(g), viscosity=viscosity_for(k), dt=dt)
        assert scene.params.drag == pytest.approx(k, rel=1e-12, abs=1e-300)
        x, v = run_collision3d(scene, x0, v0, steps)
        return x0, v0, g, dt, steps, half_voxel(scene), x, v, steps * scene.max_substeps
    g, dt, steps = np.array([0.0, -9.81, 0.0]), 1 / 30, 30
    x0, v0 = FLIGHT_FOUNTAIN
    x, v = run_fountain(FountainParams(gravity=tuple(g), drag=k, dt=dt), x0, v0, steps)
    return x0, v0, g, dt, steps, None, x, v, steps


@pytest.mark.slow
@pytest.mark.parametrize("k", DRAG_RATES)
@pytest.mark.parametrize("twin", ["collision", "collision3d", "fountain"])
def test_free_flight_follows_the_closed_form(twin, k):
    x0, v0, g, dt, steps, longest_move, x, v, substeps = run_free_flight(twin, k)
    t = steps * dt
    x_exact, v_exact = free_flight(x0, v0, g, k, t)
    # The flight must be free: inside the 2D scene's walls, above the 3D floor.
    path = np.array([free_flight(x0, v0, g, k, s)[0] for s in np.linspace(0, t, 61)])
    if twin == "collision":
        assert np.abs(path).max() < 0.95
    else:
        assert path[..., 1].min() > 0.1
    size = np.abs(v0).max() + np.linalg.norm(g) * t
    # The velocity: exact drag at every sub-step, so only rounding and the drag gain's error
    # separate it from the closed form.
    velocity_bound = (float64_drift(substeps, size)
                      + drag_gain_error_bound(g, k, v0, dt, steps, longest_move))
    velocity_error = np.abs(v - v_exact).max()
    assert velocity_error <= velocity_bound, (
        f"velocity {velocity_error:.3g} from the closed form, allowed {velocity_bound:.3g}")
    # The position: semi-implicit Euler's own error, the velocity's error over the run, rounding.
    position_bound = (euler_position_error_bound(x0, v0, g, k, dt, steps, longest_move)
                      + velocity_bound * t + float64_drift(substeps, np.abs(x0).max() + size * t))
    position_error = np.linalg.norm(x - x_exact, axis=1)
    assert np.all(position_error <= position_bound), (
        f"positions {position_error} from the closed form, allowed {position_bound}")


# --- 2. one contact with a flat floor ------------------------------------------------------------

FIELD_RESOLUTION_2D = 64
FIELD_RESOLUTION_3D = 32  # of a box 3 m wide: voxels of 3 / (32 - 8 margin voxels) m


def floor_2d(kind):
    """(field, the floor's height, how far the field's floor may be from it): ``field``, a slab
    the field holds, its top 0.37 cell off the grid; or ``scene floor``, the scene's y = -1, an
    exact plane the twin tests apart from the field."""
    cell = 2 / FIELD_RESOLUTION_2D
    if kind == "scene floor":
        return empty_field_2d(FIELD_RESOLUTION_2D), -1.0, 0.0
    top, depth = -0.5 + 0.37 * cell, 0.2
    field = CollisionField(RECT, [Box((0.0, top - depth), (1.5, depth))],
                           resolution=(FIELD_RESOLUTION_2D, FIELD_RESOLUTION_2D))
    return field, top, packed_distance_error(field.range[2])


def floor_3d(kind, **changes):
    """(scene, the floor's height, how far the field's floor may be from it, where to put
    particles on it (x, z)): ``field``, the top of a box 3 m wide 0.37 voxel off the grid; or
    ``scene floor``, y = 0, an exact plane, away from the scene's sphere."""
    if kind == "scene floor":
        return scene_3d(**changes), 0.0, 0.0, np.array([3.0, 3.0])
    top = 1.0 + 0.37 * 3 / (FIELD_RESOLUTION_3D - 8)
    field = VoxelField([Box3((0.0, top - 0.5, 0.0), (1.5, 0.5, 1.5))], FIELD_RESOLUTION_3D)
    scene = scene_3d(field, **changes)
    return scene, top, packed_distance_error(field.range[1] - field.range[0]), np.zeros(2)


def stated_response(v_in, n, r, s):
    """The response the docs state to a hit at velocity v_in on a face of unit normal n:
    v' = |v| r (n s + t (1 - s)), t the unit tangent along the motion. Returns v' and which hits
    are head-on (no motion along the face: no t; the caller says what happens)."""
    speed = np.linalg.norm(v_in, axis=1, keepdims=True)
    along = v_in - np.sum(v_in * n, axis=1, keepdims=True) * n
    length = np.linalg.norm(along, axis=1, keepdims=True)
    head_on = length[:, 0] <= 1e-9 * speed[:, 0]
    t = along / np.where(head_on[:, None], 1.0, length)
    return speed * r * (n * s + t * (1 - s)), head_on


def check_contact(x0, v_in, x, v, n, top, r, s, dt, longest_move, allowance, substeps):
    """One step, with no forces, of particles that meet the plane n.x = top within it.

    Their velocity is the stated response. And they lie where the sub-stepped contact puts them:
    found inside at the end of a sub-step, at time t_k, at x0 + v t_k, pushed out along n onto
    the plane, then flying on at v' for the rest of the step, so x(dt) = A + B t_k with
    A = (x0 onto the plane) + v' dt and B = (v along the plane) - v'. t_k is the true crossing
    time t_c or up to one sub-step later: within the time it takes to move ``longest_move``.
    ``allowance``: how far the field's plane may be from the exact one."""
    speed = np.linalg.norm(v_in, axis=1)
    crossing = (np.sum(x0 * n, axis=1) - top) / -np.sum(v_in * n, axis=1)
    assert np.all((crossing > 0) & (crossing < dt))
    v_model, head_on = stated_response(v_in, n, r, s)
    if n.shape[1] == 3:
        # Head-on in 3D: along the chapter's random tangent, any one; so the twin's, once its
        # share of the speed, r (1 - s), is checked.
        normal_part = np.sum(v[head_on] * n[head_on], axis=1, keepdims=True) * n[head_on]
        tangential = v[head_on] - normal_part
        length = np.linalg.norm(tangential, axis=1, keepdims=True)
        assert np.allclose(length[:, 0], speed[head_on] * r * (1 - s), rtol=0,
                           atol=float64_drift(substeps, speed.max()))
        turn = tangential / np.where(length > 0, length, 1.0)
        v_model[head_on] = speed[head_on, None] * r * (n[head_on] * s + turn * (1 - s))
    else:  # in 2D its whole speed goes back along the normal
        v_model[head_on] = speed[head_on, None] * r * n[head_on]
    velocity_tolerance = float64_drift(substeps, speed.max())
    error = np.abs(v - v_model).max(axis=1)
    worst = error.argmax()
    assert error[worst] <= velocity_tolerance, (
        f"in at {v_in[worst]}, out at {v[worst]}, stated {v_model[worst]}")
    assert np.all(np.linalg.norm(v, axis=1) <= speed + velocity_tolerance), "a contact gave energy"
    # On the outside, never inside.
    position_tolerance = allowance + float64_drift(substeps, np.abs(x0).max() + speed.max() * dt)
    height = np.sum(x * n, axis=1) - top
    assert height.min() >= -position_tolerance, f"ended {-height.min():.3g} inside"
    # Where: the t_k that fits best, how well it fits, and when it is.
    a_term = x0 - (np.sum(x0 * n, axis=1) - top)[:, None] * n + v_model * dt
    b_term = v_in - np.sum(v_in * n, axis=1, keepdims=True) * n - v_model
    b_length = np.linalg.norm(b_term, axis=1)
    t_k = np.sum(b_term * (x - a_term), axis=1) / np.where(b_length > 0, b_length ** 2, 1.0)
    misfit = np.linalg.norm(a_term + b_term * t_k[:, None] - x, axis=1)
    assert misfit.max() <= position_tolerance + velocity_tolerance * dt, (
        f"{misfit.max():.3g} from where the contact puts it")
    timed = b_length > 0.05 * speed  # where v and v' differ enough to tell t_k
    slack = position_tolerance / np.where(timed, b_length, 1.0)  # a position error, in time
    lag = (t_k - crossing) * speed / longest_move  # in sub-steps of the longest move
    assert np.all(t_k[timed] >= crossing[timed] - slack[timed]), "found before it got there"
    assert np.all(lag[timed] <= 1 + (slack * speed / longest_move)[timed]), (
        f"a contact found {lag[timed].max():.2f} sub-steps of the longest move after the crossing")


RESPONSES = [(0.6, 0.5), (1.0, 0.0), (1.0, 1.0), (0.8, 0.25), (0.0, 0.3)]  # (bounce r, sliding s)


def incoming_2d(top, dt):
    """Particles at angles -75..75 degrees from the downward normal (0: head-on), three speeds,
    reaching y = top a tenth, half and nine tenths of the way through the step."""
    angle, speed, when = (a.ravel() for a in np.meshgrid(np.radians(np.linspace(-75, 75, 31)),
                                                          [1.0, 4.0, 7.5], [0.1, 0.5, 0.9]))
    v = speed[:, None] * np.stack([np.sin(angle), -np.cos(angle)], 1)
    x = np.stack([np.linspace(-0.5, 0.5, len(angle)), top - v[:, 1] * when * dt], 1)
    return x, v


def incoming_3d(top, dt, place):
    """As incoming_2d, at three azimuths round the normal too, around ``place`` (x, z)."""
    angle, azimuth, speed, when = (a.ravel() for a in np.meshgrid(
        np.radians(np.linspace(0, 75, 6)), np.radians([0, 100, 230]), [1.0, 4.0, 7.5],
        [0.1, 0.5, 0.9]))
    v = speed[:, None] * np.stack([np.sin(angle) * np.cos(azimuth), -np.cos(angle),
                                   np.sin(angle) * np.sin(azimuth)], 1)
    spread = np.linspace(-0.5, 0.5, len(angle))
    x = np.stack([place[0] + spread, top - v[:, 1] * when * dt, place[1] - spread], 1)
    return x, v


@pytest.mark.parametrize("r, s", RESPONSES)
@pytest.mark.parametrize("floor", ["field", "scene floor"])
def test_a_contact_in_2d_is_the_stated_response(floor, r, s):
    p = CollisionParams(emit=False, gravity=(0.0, 0.0), drag=0.0, bounce=r, sliding=s)
    field, top, allowance = floor_2d(floor)
    x0, v_in = incoming_2d(top, p.dt)
    x, v = run_collision2d(field, p, x0, v_in)
    n = np.tile([0.0, 1.0], (len(x0), 1))
    check_contact(x0, v_in, x, v, n, top, r, s, p.dt, field.cell / 2, allowance,
                  p.max_substeps(field.cell))


@pytest.mark.parametrize("r, s", RESPONSES)
@pytest.mark.parametrize("floor", ["field", "scene floor"])
def test_a_contact_in_3d_is_the_stated_response(floor, r, s):
    scene, top, allowance, place = floor_3d(floor, gravity=(0.0, 0.0, 0.0), viscosity=0.0,
                                            bounce=r, sliding=s)
    x0, v_in = incoming_3d(top, scene.params.dt, place)
    x, v = run_collision3d(scene, x0, v_in)
    n = np.tile([0.0, 1.0, 0.0], (len(x0), 1))
    check_contact(x0, v_in, x, v, n, top, r, s, scene.params.dt, half_voxel(scene), allowance,
                  scene.max_substeps)


@pytest.mark.parametrize("r", [0.0, 0.5, 1.0])
def test_a_fountain_floor_bounce_is_restitution(r):
    """The fountain's floor keeps r of the normal velocity, reversed, and all the rest
    (docs/scenes/fountain.md), against the exact bounce at the crossing time t_c within the step.
    The twin puts a particle that ends its step below the floor back onto it, rising with r of
    the speed it had at the floor by energy: its step's end (v1, y1) gives v1^2 + 2 g y1. For a
    semi-implicit step with no drag that is w^2 - g^2 dt^2 exactly (w the exact impact speed:
    the step loses g^2 dt^2 / 2 of energy), so the rebound is r sqrt(w^2 - g^2 dt^2), on the
    floor. With r = 0 the particle stops on the floor."""
    p = FountainParams(floor="bounce", bounce=r, drag=0.0)
    g, dt = -p.gravity[1], p.dt
    vy, when = (a.ravel() for a in np.meshgrid(np.linspace(-9.0, -2.0, 8),
                                               np.linspace(0.05, 0.95, 7)))
    y0 = -vy * when * dt
    n = len(vy)
    x0 = np.stack([np.linspace(-2, 2, n), y0, np.linspace(1, -1, n)], 1)
    v0 = np.stack([np.linspace(-3, 3, n), vy, np.linspace(2, -2, n)], 1)
    x, v = run_fountain(p, x0, v0)
    crossing = (vy + np.sqrt(vy * vy + 2 * g * y0)) / g  # y0 + vy t - g t^2 / 2 = 0
    assert np.all((crossing > 0) & (crossing < dt))
    impact = g * crossing - vy
    rounding = float64_drift(4, 10.0)  # the closed form's and the twin's, on values up to 10
    rebound = r * np.sqrt(impact ** 2 - (g * dt) ** 2)
    assert np.abs(v[:, 1] - rebound).max() <= rounding, (
        f"rebound off r sqrt(w^2 - g^2 dt^2) by {np.abs(v[:, 1] - rebound).max():.3g} m/s")
    assert np.all(v[:, 1] <= r * impact), "rebound faster than r times the exact impact speed"
    assert np.all(x[:, 1] == 0), "not on the floor"
    # Along the floor nothing changes: no force there, no friction in the model.
    assert np.abs(v[:, [0, 2]] - v0[:, [0, 2]]).max() <= rounding
    assert np.abs(x[:, [0, 2]] - (x0 + v0 * dt)[:, [0, 2]]).max() <= rounding


# --- 3. resting contact --------------------------------------------------------------------------

RESTING_STEPS = 600  # 10 s at dt 1/60
DROPS = np.array([0.0, 0.33, 2.0])  # cells above the floor: on it, a third of a cell, two cells


def check_resting(heights, speeds, g, allowance, rounding):
    """Heights over the floor and speeds (step, particle), from the start: never deeper than the
    field's allowance under the floor (the docs allow a cell; the field holds its floor closer),
    never above the start (or the allowance: a push-out onto a plane the field holds that much
    above the exact one), energy v^2 / 2 + g h never above the last step's but by that
    allowance's worth (from rest no speed is left to pay for it), and at rest in the end."""
    assert heights.min() >= -allowance - rounding, f"sank {-heights.min():.3g} under the floor"
    top = np.maximum(heights[0], 0) + allowance
    assert np.all(heights <= top + rounding), f"hopped {(heights - top).max():.3g} above it"
    energy = 0.5 * speeds ** 2 + g * heights
    gained = np.diff(energy, axis=0).max()
    assert gained <= g * allowance + rounding, f"gained {gained:.3g} in a step"
    assert speeds[-1].max() <= rounding and np.abs(heights[-1]).max() <= allowance + rounding, (
        "not at rest on the floor in the end")


@pytest.mark.slow
@pytest.mark.parametrize("floor", ["field", "scene floor"])
def test_a_particle_rests_on_a_2d_floor(floor):
    p = CollisionParams(emit=False, bounce=0.6, sliding=0.5)  # gravity 3 down, drag 0.05
    field, top, allowance = floor_2d(floor)
    drops = np.repeat(DROPS, 3) * field.cell
    places = np.tile([-0.4, 0.013, 0.5], len(DROPS))
    x, v = np.stack([places, top + drops], 1), np.zeros((len(drops), 2))
    heights, speeds = [drops], [np.zeros(len(drops))]
    for _ in range(RESTING_STEPS):
        x, v = run_collision2d(field, p, x, v)
        heights.append(x[:, 1] - top)
        speeds.append(np.linalg.norm(v, axis=1))
    check_resting(np.array(heights), np.array(speeds), -p.gravity[1], allowance,
                  float64_drift(p.max_substeps(field.cell), 1.0 - p.gravity[1]))
    # Head-on hits go straight back: nothing moves sideways.
    assert np.abs(x[:, 0] - places).max() <= float64_drift(RESTING_STEPS, 1.0), "crept"


@pytest.mark.slow
@pytest.mark.parametrize("floor", ["field", "scene floor"])
def test_a_particle_rests_on_a_3d_floor(floor):
    scene, top, allowance, place = floor_3d(floor)  # gravity 9.81 down, r = s = 0.5, air's drag
    p = scene.params
    drops = np.repeat(DROPS, 2) * scene.field.voxel
    places = np.tile([[-0.4, 0.2], [0.31, -0.5]], (len(DROPS), 1)) + place
    x = np.stack([places[:, 0], top + drops, places[:, 1]], 1)
    v = np.zeros_like(x)
    heights, speeds = [drops], [np.zeros(len(drops))]
    for step in range(RESTING_STEPS):
        x, v = run_collision3d(scene, x, v, first_step=step)
        heights.append(x[:, 1] - top)
        speeds.append(np.linalg.norm(v, axis=1))
    check_resting(np.array(heights), np.array(speeds), -p.gravity[1], allowance,
                  float64_drift(scene.max_substeps, 1.0 + top - p.gravity[1]))
    # Those put on the floor stay where they are (a dropped one may go off along the random
    # tangent of its head-on hit, as the chapter's do).
    on_floor = drops == 0
    assert np.abs(x[on_floor][:, [0, 2]] - places[on_floor]).max() <= float64_drift(
        RESTING_STEPS, 4.0), "crept"


@pytest.mark.slow
@pytest.mark.parametrize("r, height", [(0.5, 0.0), (1.0, 1.0)])
def test_the_fountain_floor_gives_no_energy(r, height):
    """Semi-implicit Euler loses g^2 dt^2 / 2 a step in flight, and a bounce with r <= 1 keeps
    at most the speed it had: the energy of a particle on or over the floor never grows."""
    p = FountainParams(floor="bounce", bounce=r, drag=0.0)
    g = -p.gravity[1]
    x, v = np.array([[0.0, height, 0.0]]), np.zeros((1, 3))
    worst = 0.0
    for _ in range(3000):
        x, v = run_fountain(p, x, v)
        worst = max(worst, 0.5 * np.sum(v * v) + g * x[0, 1] - g * height)
    assert worst <= float64_drift(3000, g * 10), f"energy grew by {worst:.3g} J/kg"


# --- 4. the side of entry on thin walls ----------------------------------------------------------

OFFSETS = np.arange(64) / 64  # of a cell: where a wall's face sits on the grid


def aimed_at_wall(low, high, gap, dt, velocities):
    """Particles aimed at the wall low <= x <= high from both sides: ``velocities`` (x towards
    the wall), each from ``gap`` plus 1/16, 3/16 .. 15/16 of a step's move away from the face.
    Returns a dict of x, v, from_low, and each particle's wall (low, high)."""
    velocities = np.asarray(velocities, float)
    when = np.tile((np.arange(8) + 0.5) / 8, len(velocities))
    v = np.repeat(velocities, 8, axis=0)
    x = np.zeros_like(v)
    x[:, 0] = low - (gap + when * v[:, 0] * dt)
    from_high_x, from_high_v = x.copy(), v.copy()
    from_high_x[:, 0] = high + (gap + when * v[:, 0] * dt)
    from_high_v[:, 0] *= -1
    count = 2 * len(v)
    return {"x": np.concatenate([x, from_high_x]), "v": np.concatenate([v, from_high_v]),
            "from_low": np.arange(count) < len(v), "low": np.full(count, low),
            "high": np.full(count, high)}


def joined(parts):
    return {key: np.concatenate([part[key] for part in parts]) for key in parts[0]}


def check_side_of_entry(start, x, v, allowance):
    """Each came back out on the side it came from (within the field's ``allowance``), and each
    met its wall (its x velocity turned)."""
    wrong = np.where(start["from_low"], x[:, 0] > start["low"] + allowance,
                     x[:, 0] < start["high"] - allowance)
    first = wrong.argmax()
    assert not wrong.any(), (
        f"{wrong.sum()} of {len(x)} came out on the far side or stayed in; the first from "
        f"{start['x'][first]} at {start['v'][first]} to {x[first]}, the wall "
        f"{start['low'][first]} .. {start['high'][first]}")
    assert np.all(v[:, 0] * start["v"][:, 0] < 0), "every particle must have met its wall"


@pytest.mark.slow
def test_thin_walls_in_2d_are_left_by_the_side_of_entry():
    """Walls half a cell and one cell thick, each at 64 offsets across a cell, met from both sides
    at speeds up to the velocity range's corner (8, 8): a cell of such a wall can hold its far
    face's normal, and only the side-of-entry rule sends the particle back. Particles start at
    least half a cell from the face: nearer, one could sit in a cell that holds the far face's
    normal (the field reads it inside before it has moved), where no step puts it (a sub-step
    that ends in such a cell is turned back)."""
    resolution = 32
    cell = 2 / resolution
    p = CollisionParams(emit=False, drag=0.0, bounce=0.6, sliding=0.5)  # gravity 3 down
    walls = {0.5: -0.5, 1.0: 0.5}  # thickness in cells: the grid line its low face starts from
    velocities = list(itertools.product(np.linspace(2, 8, 7), [-8.0, -4.0, 0.0, 4.0, 8.0]))
    for offset in OFFSETS:
        faces = [(x + offset * cell, x + (offset + th) * cell) for th, x in walls.items()]
        walls_field = [Box(((a + b) / 2, 0.0), ((b - a) / 2, 1.5)) for a, b in faces]
        field = CollisionField(RECT, walls_field, resolution=(resolution, resolution))
        start = joined([aimed_at_wall(a, b, cell / 2, p.dt, velocities) for a, b in faces])
        start["x"][:, 1] = np.linspace(-0.4, 0.4, len(start["x"]))
        # Two steps: the slowest reach the face within them, the fastest stay clear of the other
        # wall after turning.
        x, v = run_collision2d(field, p, start["x"], start["v"], steps=2)
        check_side_of_entry(start, x, v, packed_distance_error(field.range[2]))


def slab_field(field, a, b):
    """(distance, normal) per voxel of ``field``, float32 as decoded, of the slab a <= x <= b
    (object space): the exact distance to the nearer face and that face's outward normal, as a
    one-voxel shell of a mesh gives them. The scene refuses analytic shapes under two voxels
    thick; the twin takes such a field as ``decoded``."""
    x = field.centres()[..., 0]
    normal = np.zeros(x.shape + (3,))
    normal[..., 0] = np.where(a - x > x - b, -1.0, 1.0)
    return np.maximum(a - x, x - b).astype(np.float32), normal.astype(np.float32)


@pytest.mark.slow
def test_thin_walls_in_3d_are_left_by_the_side_of_entry():
    """A slab one voxel thick (the 3D rule acts from a quarter voxel deep, for walls a voxel
    thick or more: docs/scenes/collision3d.md) at 64 offsets across a voxel, met from both sides
    at the velocity range's corner (12, +-12, +-12) and slower, by a still object."""
    scene = scene_3d(VoxelField([Box3((0.0, 1.0, 0.0), (0.5, 0.5, 0.5))], 24),
                     gravity=(0.0, 0.0, 0.0), viscosity=0.0)
    voxel, pivot = scene.field.voxel, scene.field.pivot
    # Three speeds (the twin groups particles by sub-step length), many directions.
    corners = [[12.0, y, z] for y in (-12.0, 12.0) for z in (-12.0, 12.0)]
    directions = np.array([[np.cos(t), np.sin(t) * np.cos(u), np.sin(t) * np.sin(u)]
                           for t in np.radians([0, 35, 60]) for u in np.radians([0, 120, 240])])
    velocities = np.concatenate([corners, 12.0 * directions, 4.0 * directions])
    for offset in OFFSETS:
        a, b = offset * voxel, (offset + 1) * voxel
        start = aimed_at_wall(a, b, voxel / 2, scene.params.dt, velocities)
        x, v = run_collision3d(scene, start["x"] + pivot, start["v"], steps=2,
                               decoded=slab_field(scene.field, a, b))
        # The slab is exact in float32: only rounding, on positions within a metre.
        check_side_of_entry(start, x - pivot, v, float64_drift(2 * scene.max_substeps, 1.0))


# --- 5. sub-steps, measured ----------------------------------------------------------------------

def record_moves(monkeypatch, module, move):
    """Each sub-step's moves, ``move`` of collide()'s arguments: the twin calls collide() once a
    sub-step, after the move, with where the sub-step started."""
    moves = []
    collide = module.collide

    def recording(*args, **kwargs):
        moves.append(move(*args))
        return collide(*args, **kwargs)

    monkeypatch.setattr(module, "collide", recording)
    return moves


@pytest.mark.parametrize("changes", [{}, {"dt": 0.05}, {"spring": (0.0, 0.0, 400.0)},
                                     {"gravity": (300.0, -400.0)}])
def test_no_2d_substep_moves_more_than_half_a_cell(monkeypatch, changes):
    """One step of particles in every direction at the fastest the velocity range allows (its
    corner the fastest); a spring fixes one count for all (fixed_substeps), strong gravity adds
    to the reach."""
    p = CollisionParams(emit=False, **changes)
    field = empty_field_2d(256)
    moves = record_moves(monkeypatch, twin2d,
                         lambda x, v, a, field, p, before: np.linalg.norm(x - before, axis=1))
    angle = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    v0 = np.clip(np.stack([np.cos(angle), np.sin(angle)], 1) * p.max_speed * np.sqrt(2),
                 -p.max_speed, p.max_speed)
    run_collision2d(field, p, np.zeros_like(v0), v0)
    assert len(moves) > 1, "the fastest particles need several sub-steps"
    longest = np.max(moves)
    assert longest <= field.cell / 2 + float64_drift(1, 1.0), f"{longest / field.cell:.3f} cells"


@pytest.mark.slow
@pytest.mark.parametrize("changes", [{}, {"dt": 0.05}, {"scale": 2.0},
                                     {"spin": (200.0, 0.0, 0.0, 1.0)},
                                     {"sway": (0.3, 0.2, 0.0, 0.5)}])
def test_no_3d_substep_moves_more_than_half_a_voxel_relative_to_the_object(monkeypatch, changes):
    """Particles in many directions at the velocity range's corner speed, started on the
    object's bounding sphere (where a turning object's surface is fastest), falling in: each
    sub-step's move in the object's own space is at most half a voxel."""
    scene = scene_3d(None, **changes)
    field, p = scene.field, scene.params
    lo, hi = field.bounds
    moves = record_moves(monkeypatch, twin3d,
                         lambda x, v, a, q_before, obj, pose, *rest:
                         np.linalg.norm(obj.to_object(x, pose) - q_before, axis=1))
    direction = np.random.default_rng(0).normal(size=(256, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    x0 = field.pivot + np.linalg.norm(hi - lo) / 2 * p.scale * direction
    v0 = np.clip(-direction * p.max_speed * np.sqrt(3), -p.max_speed, p.max_speed)
    run_collision3d(scene, x0, v0)
    assert len(moves) > 1, "the fastest particles need several sub-steps"
    longest = np.concatenate(moves).max()
    assert longest <= field.voxel / 2 + float64_drift(1, 10.0), (
        f"{longest / field.voxel:.3f} voxels")


# --- 6. the fields' sampling against the analytic shapes -----------------------------------------

# The 2D field holds each normal component in 8 bits (127 n + 127): at most half a step, 0.5 / 127,
# off per component, so the unit vector is moved by at most d = sqrt(2) 0.5 / 127 and normalising
# turns it by at most asin(d); the chord between the two is shorter than that angle.
NORMAL_ERROR_2D = np.arcsin(np.sqrt(2) * 0.5 / 127)
# The 3D field holds an octahedral normal e in two bytes (127 e + 127): |de| <= sqrt(2) 0.5 / 127.
# Decoding p = (e_x, e_y, 1 - |e_x| - |e_y|) (or its fold below) moves p by at most sqrt(3) |de|
# (the third component by at most |de_x| + |de_y| <= sqrt(2) |de|), and |p| >= 1 / sqrt(3) on the
# octahedron, so the normal turns by at most asin(sqrt(3) sqrt(3) |de|).
NORMAL_ERROR_3D = np.arcsin(3 * np.sqrt(2) * 0.5 / 127)


def near_surface(points, outward, cell, rng):
    """Points within two cells of a surface, on both sides."""
    return points + outward * rng.uniform(-2, 2, (len(outward), 1)) * cell


def round_shape_bounds(from_centre, reach, normal_error):
    """The error (lowest, highest) of a round shape's field (circle or sphere, centre C, radius
    R) sampled at q: the nearest cell's centre c is within ``reach`` of q (half a cell's
    diagonal); its distance |c - C| - R carried along its normal n_c = (c - C) / |c - C| gives
    n_c.(q - C) - R, short of the exact |q - C| - R by |q - C| (1 - cos phi), phi the angle at C
    between q and c, sin phi <= reach / |c - C|; the stored normal's error adds at most
    ``normal_error`` times |q - c|."""
    sin_phi = np.minimum(reach / (from_centre - reach), 1.0)
    curvature = from_centre * (1 - np.sqrt(1 - sin_phi ** 2))
    return -curvature - normal_error * reach, normal_error * reach


def check_round_shape(field_sample, centre, radius, cell, reach, normal_error, quantum, dims, rng):
    outward = rng.normal(size=(20000, dims))
    outward /= np.linalg.norm(outward, axis=1, keepdims=True)
    q = near_surface(np.asarray(centre) + radius * outward, outward, cell, rng)
    from_centre = np.linalg.norm(q - centre, axis=1)
    error = field_sample(q) - (from_centre - radius)
    low, high = round_shape_bounds(from_centre, reach, normal_error)
    assert np.all(error >= low - quantum), f"{(low - error).max() / cell:.3g} cells short"
    assert np.all(error <= high + quantum), f"{(error - high).max() / cell:.3g} cells over"


def check_box_faces(field_sample, box, cell, quantum, dims, rng):
    """Points within two cells of each face of ``box`` and three cells or more from its other
    faces: the nearest cell's centre (within a cell) reads the same face, whose normal is exact
    (0 and +-1 are exact codes), and the distance carried along it is exact, to the storage's
    quantum."""
    centre, half = np.asarray(box.centre, float), np.asarray(box.half_size, float)
    for axis, side in itertools.product(range(dims), (-1.0, 1.0)):
        q = centre + rng.uniform(-1, 1, (4000, dims)) * np.maximum(half - 3 * cell, 0)
        depth = rng.uniform(-2, 2, 4000) * cell
        q[:, axis] = centre[axis] + side * (half[axis] + depth)
        error = np.abs(field_sample(q) - depth).max()
        assert error <= quantum, f"face {side:+g} of axis {axis}: {error / cell:.3g} cells off"


def test_the_2d_field_samples_a_circle_and_a_box_as_their_distances():
    circle, box = Circle((-0.4, 0.1), 0.3), Box((0.45, -0.2), (0.3, 0.2))
    field = CollisionField(RECT, [circle, box], resolution=(128, 128))
    cell, quantum = field.cell, packed_distance_error(field.range[2])
    sample = lambda q: field.sample(q)[0]  # noqa: E731
    rng = np.random.default_rng(1)
    check_round_shape(sample, circle.centre, circle.radius, cell, np.sqrt(2) / 2 * cell,
                      NORMAL_ERROR_2D, quantum, 2, rng)
    check_box_faces(sample, box, cell, quantum, 2, rng)


def test_the_3d_field_samples_a_sphere_and_a_box_as_their_distances():
    """tests/test_collision3d.py checks the stored voxels against the shapes tightly, and the
    sampling between them within a voxel (box edges and corners are the worst); here the
    sampling where the shapes allow a tight bound: a sphere's curvature, a box's flat faces."""
    rng = np.random.default_rng(2)
    sphere = Sphere((0.0, 1.0, 0.0), 0.8)
    field = VoxelField([sphere], 40)
    check_round_shape(lambda q: field.sample(q - field.pivot)[0], sphere.centre, sphere.radius,
                      field.voxel, np.sqrt(3) / 2 * field.voxel, NORMAL_ERROR_3D,
                      packed_distance_error(field.range[1] - field.range[0]), 3, rng)
    box = Box3((0.0, 0.6, 0.0), (0.8, 0.5, 0.4))
    boxed = VoxelField([box], 40)
    check_box_faces(lambda q: boxed.sample(q - boxed.pivot)[0], box, boxed.voxel,
                    packed_distance_error(boxed.range[1] - boxed.range[0]), 3, rng)
