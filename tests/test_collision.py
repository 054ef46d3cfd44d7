"""The collision scene against the float64 numpy twin of its integrator and response.

The GPU's steps are compared step by step with the twin's float64 step from the same state, each
particle within its own bound, carried beside it through the sub-steps (step_with_bound): half a
code and the codec's rounding of the write, float32's roundings and GLSL's precision of exp,
division and sqrt through each operation's local derivative, and, where float32 may take the
other side of a branch, the distance to that branch's outcome. A half-code bias in every RGBA8
write fails it at the first step.
"""

import numpy as np
import pytest

from bounds import (DIVISION_ULPS, EXP_ULPS, HASH_ERROR, NORMALIZE, U, codec_error,
                    decode_error, half_code, push_out_rescale, push_out_work, rounding_error)
from es2particles import ParameterError, Simulation
from es2particles.fields.field2d import Box, Circle, CollisionField
from es2particles.scenes.collision import RECT, Collision, CollisionParams
from es2particles.twins.drag import exact_drag
from es2particles.twins.life import alive
from es2particles.twins.particle import step_reference

POSITION_HALF_CODE = half_code(-1.0, 1.0)  # the position's range
VELOCITY_HALF_CODE = half_code(-8.0, 8.0)  # the velocity's (max_speed 8)


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



# --- the float64 step with each particle's float32 error bound ---------------------------------
#
# step_with_bound() is twins/particle.py's step_reference, line for line in float64 (check_step
# verifies that the two agree to the bit), carrying beside each particle a bound on how far the
# shader's float32 computation of the same particle can be from it, per component: each
# operation's rounding, GLSL's precision of exp, division and sqrt, and the errors in flight
# carried through each operation's local derivative at the float64 point (a push-out keeps only
# the tangential part of a position's error; a tangent's direction moves only with the normal's
# error and the rounding of v - (v.n) n, divided by |v - (v.n) n|). Where float32 could take the
# other side of a branch (a contact, the turn, head-on or not, the thin-wall side, a wall, the
# field's cell, the sub-step count), the bound grows to the other branch's bound plus its distance
# from the float64 branch's outcome; the other sub-step count is an alternative reference.
# GLSL's precision of each operation is bounds.py's.


def _norm(a):
    return np.hypot(a[..., 0], a[..., 1])


def _along(u, e):
    """Bound of |u . delta| for |delta_i| <= e_i."""
    return np.abs(u[..., 0]) * e[..., 0] + np.abs(u[..., 1]) * e[..., 1]


def _perp(u):
    return np.stack([-u[..., 1], u[..., 0]], -1)


def _sample(field, p, i, j):
    """field.sample at p from cell (i, j) (field2d's arithmetic, for a neighbouring cell too)."""
    d, n = field._decoded
    x0, y0, x1, y1 = field.rect
    w, h = field.resolution
    centre = np.stack([x0 + (i + 0.5) / w * (x1 - x0), y0 + (j + 0.5) / h * (y1 - y0)], -1)
    normal = n[j, i].astype(np.float64)
    return d[j, i] + np.sum(normal * (p - centre), axis=-1), normal, centre


def _pick(outcomes, chosen, possible):
    """Merge branch outcomes ((x, v, ex, ev) each): outcome k where the float64 step takes it
    (``chosen[k]``, one per particle); where the GPU may take outcome k instead (``possible[k]``),
    the bound grows to k's own plus its distance from the chosen one."""
    x = sum(np.where(c[:, None], o[0], 0.0) for o, c in zip(outcomes, chosen))
    v = sum(np.where(c[:, None], o[1], 0.0) for o, c in zip(outcomes, chosen))
    ex = sum(np.where(c[:, None], o[2], 0.0) for o, c in zip(outcomes, chosen))
    ev = sum(np.where(c[:, None], o[3], 0.0) for o, c in zip(outcomes, chosen))
    for (xk, vk, exk, evk), may in zip(outcomes, possible):
        ex = np.where(may[:, None], np.maximum(ex, exk + np.abs(xk - x)), ex)
        ev = np.where(may[:, None], np.maximum(ev, evk + np.abs(vk - v)), ev)
    return x, v, ex, ev


def _contact(state, a, ea, d, ed, n, en, p, moved, e_moved):
    """respond() of twins/particle.py for a contact at every particle, with its bound. The depth
    d errs by n . (the position's error) + ``ed``; ``en``: the normal's error per component;
    ``moved``: the sub-step's move along n, within ``e_moved``."""
    x, v, ex, ev = state
    r, s = p.bounce, p.sliding
    with np.errstate(divide="ignore", invalid="ignore"):
        vn = np.sum(v * n, axis=-1)
        speed = np.hypot(v[:, 0], v[:, 1])
        along = v - vn[:, None] * n
        along_len = np.hypot(along[:, 0], along[:, 1])
        has_tangent = along_len > 1e-6 * speed
        t = along / np.where(has_tangent, along_len, 1)[:, None]
        sliding = np.where(has_tangent, s, 1.0)
        new_v = speed[:, None] * (n * sliding[:, None] + t * (1 - sliding)[:, None]) * r
        products = np.abs(v[:, 0] * n[:, 0]) + np.abs(v[:, 1] * n[:, 1])
        e_vn = _along(n, ev) + _along(v, en) + 2 * U * products
        e_speed = np.where(speed > 0, _along(v, ev) / speed, _norm(ev)) + 2 * U * speed
        # along = (I - n n^T) v: v's error enters by its tangential part; the normal's error
        # and float32's rounding (off the tangent line too) by the rest
        off_line = (speed + np.abs(vn)) * _norm(en) + 2 * U * products + U * (np.abs(vn)
                                                                                + along_len)
        e_along = _along(_perp(n), ev) + off_line
        # t = along / |along| turns by the part of along's error across it, along n; its sign
        # flips if |along| is within the error of 0
        e_t = np.abs(n) * np.minimum(2, off_line / along_len)[:, None] \
            + 2 * DIVISION_ULPS * U * np.abs(t)
        e_t = np.where(((along_len <= e_along) & has_tangent)[:, None], 2.0, e_t)
        e_t = np.where(has_tangent[:, None], e_t, 0.0)
        m = n * sliding[:, None] + t * (1 - sliding)[:, None]
        e_m = (sliding[:, None] * en + (1 - sliding)[:, None] * e_t
               + U * (np.abs(n) * sliding[:, None] + np.abs(t) * (1 - sliding)[:, None]
                      + np.abs(m)))
        e_new = r * (e_speed[:, None] * np.abs(m) + speed[:, None] * e_m) \
            + 3 * U * r * speed[:, None] * np.abs(m)
        # head-on or not within float32 of the 1e-6 threshold: the tangent's share may differ
        headon_unsure = np.abs(along_len - 1e-6 * speed) <= e_along + 1e-6 * e_speed
        e_new = e_new + np.where(headon_unsure, 2 * r * speed * (1 - s), 0)[:, None]
        turn = vn < 0
        turned = np.where(turn[:, None], new_v, v)
        e_turned = np.where(turn[:, None], e_new, ev)
        turn_unsure = (np.abs(vn) <= e_vn)[:, None]
        e_turned = np.where(turn_unsure, np.maximum(e_new, ev) + np.abs(new_v - v), e_turned)
        # out along the normal by the depth: the position's error keeps its tangential part
        out = x - d[:, None] * n
        tangent = _perp(n)
        e_out = (np.abs(tangent) * _along(tangent, ex)[:, None] + np.abs(n) * ed[:, None]
                 + np.abs(d)[:, None] * en + U * (np.abs(d[:, None] * n) + np.abs(out)))
        # the acceleration's work over the push-out taken from the kinetic energy: the float64
        # v * sqrt(max(v2 - work, 0) / v2) is sqrt(max(v2 - work, 0)) along v
        v2 = np.sum(turned * turned, axis=-1)
        an = np.sum(a * n, axis=-1)
        e_v2 = 2 * _along(turned, e_turned) + _norm(e_turned) ** 2 + 2 * U * v2
        e_an = _along(n, ea) + _along(a, en) + 2 * U * (np.abs(a * n).sum(axis=-1))
        e_depth = _along(n, ex) + ed
        def direction_error(direction):  # the error across it, over its length
            side = _perp(direction)
            return np.abs(side) * np.minimum(2, _along(side, e_turned) / np.sqrt(v2))[:, None]

        work, e_work = push_out_work(turn, turn_unsure[:, 0], vn, e_vn, d, e_depth, an, e_an,
                                     moved, e_moved, speed, e_speed, v2, e_v2)
        rescaled, e_rescaled = push_out_rescale(turned, v2, e_v2, work, e_work, direction_error)
    return out, rescaled, e_out, e_rescaled


def _contact_where(mask, state, a, ea, d, ed, n, en, p, moved, e_moved):
    """_contact for the particles of ``mask`` (the others keep their state: never taken)."""
    out = [np.array(part) for part in state]
    if mask.any():
        picked = _contact([part[mask] for part in state], a[mask], ea[mask], d[mask], ed[mask],
                          n[mask], en[mask], p, moved[mask], e_moved[mask])
        for whole, part in zip(out, picked):
            whole[mask] = part
    return out


def _collide(state, a, ea, field, p, before, e_before):
    """collide() of twins/particle.py with its bound."""
    x, v, ex, ev = state
    d, n = field.sample(x)
    d = d.astype(np.float64)
    x0, y0, x1, y1 = field.rect
    w, h = field.resolution
    ci, cj = (x[:, 0] - x0) / (x1 - x0) * w, (x[:, 1] - y0) / (y1 - y0) * h
    i = np.clip(np.floor(ci), 0, w - 1).astype(int)
    j = np.clip(np.floor(cj), 0, h - 1).astype(int)
    d_check, n_check, centre = _sample(field, x, i, j)
    assert np.array_equal(d_check, d) and np.array_equal(n_check, n)
    # d = d_cell + n . (p - centre): the cell's decode (a driver may fuse it: the codec's
    # rounding), the centre's and the dot's roundings, the normal's error times |p - centre|
    e_n = NORMALIZE * np.abs(n)
    e_d = _along(x - centre, e_n) + 6 * U * np.maximum(_norm(x), _norm(centre)) \
        + codec_error(field.range[0], field.range[0] + field.range[2]) + U * np.abs(d)
    # The cell: floor((p - x0) / width * cells) in float32 may be the neighbour near an edge,
    # whose distance and normal then apply.
    for c, cells, e_c, axis in ((ci, w, ex[:, 0] * w / (x1 - x0) + 8 * U * ci, 0),
                                (cj, h, ex[:, 1] * h / (y1 - y0) + 8 * U * cj, 1)):
        edge = np.round(c)
        unsure = (np.abs(c - edge) <= e_c) & (edge >= 1) & (edge <= cells - 1)
        if unsure.any():
            other = np.where(c >= edge, edge - 1, edge).astype(int)  # the cell across the edge
            across = np.where(unsure, other, i if axis == 0 else j)
            ii, jj = (across, j) if axis == 0 else (i, across)
            d_other, n_other, _ = _sample(field, x, ii, jj)
            e_d = e_d + np.where(unsure, np.abs(d_other - d), 0)
            e_n = e_n + np.where(unsure[:, None], np.abs(n_other - n), 0)
    e_depth = _along(n, ex) + e_d
    moved = x - before
    mn = np.sum(moved * n, axis=-1)
    # the thin wall's depth, moved . (-n): the position's error enters as in any depth
    e_moved = _along(n, e_before) + _along(moved, e_n) + 3 * U * _norm(moved)
    e_mn = _along(n, ex) + e_moved
    contact, back = d < 0, (d < 0) & (mn > 0) & (d > -2 * field.cell)
    may_contact = d < e_depth
    plain = _contact_where(may_contact, state, a, ea, d, e_d, n, e_n, p, mn, e_mn)
    flipped = _contact_where(may_contact, state, a, ea, -mn, e_moved, -n, e_n, p, -mn, e_mn)
    may_back = may_contact & (mn > -e_mn) & (d > -2 * field.cell - e_depth)
    may_plain = may_contact & ((mn <= e_mn) | (d <= -2 * field.cell + e_depth))
    state = _pick([state, plain, flipped], [~contact, contact & ~back, back],
                  [d >= -e_depth, may_plain, may_back])
    # the scene's walls: exact planes
    for axis, edge, sign in ((0, x0, 1.0), (0, x1, -1.0), (1, y0, 1.0), (1, y1, -1.0)):
        x, v, ex, ev = state
        depth = sign * (x[:, axis] - edge)
        normal = np.zeros_like(x)
        normal[:, axis] = sign
        e_wall = U * np.abs(depth)
        near = depth < ex[:, axis] + e_wall
        along = sign * (x[:, axis] - before[:, axis])
        e_along = ex[:, axis] + e_before[:, axis] + U * np.abs(along)
        wall = _contact_where(near, state, a, ea, depth, e_wall, normal, np.zeros_like(x), p,
                              along, e_along)
        state = _pick([state, wall], [depth >= 0, depth < 0], [depth >= -ex[:, axis] - e_wall,
                                                               near])
    return state


def _integrate(x, v, ex, ev, field, p, counts=None):
    """integrate() of twins/particle.py with its bound; ``counts``: sub-step counts to use instead
    of the particles' own. Returns (x, v, ex, ev, counts, unsure, other counts)."""
    g, (ox, oy, w2) = np.asarray(p.gravity, float), p.spring
    spring_centre = np.array([ox, oy])

    def acceleration(x, ex):
        a = g + w2 * (spring_centre - x)
        pull = np.abs(spring_centre - x)
        return a, (U * np.abs(g) + w2 * (ex + U * np.abs(spring_centre) + U * pull)
                   + 2 * U * w2 * pull + U * np.abs(a))

    a0, ea0 = acceleration(x, ex)
    reach = (np.hypot(v[:, 0], v[:, 1]) + np.hypot(a0[:, 0], a0[:, 1]) * p.dt) * p.dt
    fixed = p.fixed_substeps(field.cell)
    q = reach / (0.5 * field.cell)
    n = np.full(len(x), fixed) if fixed > 0 else np.ceil(q)
    n = np.clip(n, 1, p.max_substeps(field.cell))
    # The count is ceil(q) of the float32 q, which may lie across a whole number.
    e_reach = ((_norm(ev) + 2 * U * _norm(v)) + (_norm(ea0) + 3 * U * _norm(a0)) * p.dt
               + U * reach) * p.dt + 2 * U * reach
    e_q = e_reach / (0.5 * field.cell) + 5 * U * q
    whole = np.round(q)
    unsure = (fixed == 0) & (np.abs(q - whole) <= e_q) & (whole >= 1) \
        & (whole < p.max_substeps(field.cell))
    other = np.where(np.ceil(q) == whole, whole + 1, whole)
    if counts is not None:
        n = counts
    h = p.dt / n
    decay, gain = exact_drag(p.drag, h)
    k = p.drag
    kh = k * h
    e_h = (1 + 2 * DIVISION_ULPS) * U * h  # dt to float32, then dt / n
    e_kh = 3 * U * kh + k * e_h
    e_decay = decay * e_kh + 2 * (EXP_ULPS + 2 * kh) * U * decay
    e_small = e_h + 0.5 * h * e_kh + 3 * U * h  # h (1 - kh / 2)
    with np.errstate(divide="ignore"):  # (1 - decay) / k: 1 - decay exact (Sterbenz)
        e_large = (e_decay / k if k > 0 else np.inf) + (2 + 2 * DIVISION_ULPS) * U * gain
    e_gain = np.where(kh < 1e-3, e_small, e_large)
    near = np.abs(kh - 1e-3) <= e_kh  # the other formula (they differ by h (kh)^2 / 6)
    e_gain = np.where(near, np.maximum(e_small, e_large) + h * kh ** 2 / 6, e_gain)
    x, v, ex, ev = x.copy(), v.copy(), ex.copy(), ev.copy()
    for step in range(int(n.max()) if len(n) else 0):
        i = np.flatnonzero(step < n)  # the particles still sub-stepping
        xi, vi, exi, evi = x[i], v[i], ex[i], ev[i]
        a, ea = acceleration(xi, exi)
        v_new = np.clip(vi * decay[i, None] + a * gain[i, None], -p.max_speed, p.max_speed)
        ev_new = (evi * decay[i, None] + np.abs(vi) * e_decay[i, None]
                  + U * np.abs(vi) * decay[i, None] + np.abs(a) * e_gain[i, None]
                  + gain[i, None] * ea + U * np.abs(a) * gain[i, None] + U * np.abs(v_new))
        x_new = xi + v_new * h[i, None]
        ex_new = exi + ev_new * h[i, None] + np.abs(v_new) * e_h[i, None] \
            + U * (np.abs(v_new) * h[i, None] + np.abs(x_new))
        x[i], v[i], ex[i], ev[i] = _collide((x_new, v_new, ex_new, ev_new), a, ea, field, p,
                                            xi, exi)
        v[i] = np.clip(v[i], -p.max_speed, p.max_speed)
    return x, v, ex, ev, n, unsure, other


def step_with_bound(x, v, life, field, p):
    """step_reference's float64 step of every living particle with each particle's bound (n, 2)
    on the float32 GPU's distance from it (the shader decodes the RGBA8 start as numpy does, but
    a driver may fuse the decode: bounds.decode_error), and where the float32 sub-step count may
    be the other whole number, the step with that count: (x, v, ex, ev, (indices, x, v, ex, ev)
    of the other count, or None)."""
    start_x, start_v = np.array(x, float), np.array(v, float)
    x, v, ex, ev = start_x.copy(), start_v.copy(), np.zeros_like(start_x), np.zeros_like(start_v)
    living = alive(life)
    ex0 = decode_error(start_x[living], -1.0, 1.0)
    ev0 = decode_error(start_v[living], -p.max_speed, p.max_speed)
    xi, vi, exi, evi, _, unsure, other = _integrate(start_x[living], start_v[living], ex0, ev0,
                                                    field, p)
    x[living], v[living], ex[living], ev[living] = xi, vi, exi, evi
    alternative = None
    if unsure.any():
        index = np.flatnonzero(living)[unsure]
        alternative = (index, *_integrate(start_x[index], start_v[index], ex0[unsure],
                                          ev0[unsure], field, p, counts=other[unsure])[:4])
    return x, v, ex, ev, alternative


def check_step(label, got, start, field, params, verify=False):
    """The GPU's step ``got`` = (x, v) from ``start`` = (x, v, life) against step_with_bound:
    each living particle's every component within its own bound, the float32 error plus the
    write's rounding (half a code and the codec's float32); where the sub-step count may be the
    other whole number, within the bound of either count. Returns the float64 step's (x, v) and
    the largest error/bound of positions and velocities."""
    x1, v1 = got
    xr, vr, ex, ev, alternative = step_with_bound(*start, field, params)
    if verify:  # the same float64 step as the twin's, to the bit
        twin_x, twin_v, _ = step_reference(*start, field, params)
        assert np.array_equal(xr, twin_x) and np.array_equal(vr, twin_v)
    write_x = rounding_error("rgba8", -1.0, 1.0)
    write_v = rounding_error("rgba8", -params.max_speed, params.max_speed)
    error_x = np.abs(x1 - np.clip(xr, -1, 1))
    error_v = np.abs(v1 - np.clip(vr, -params.max_speed, params.max_speed))
    bound_x, bound_v = ex + write_x, ev + write_v
    if alternative is not None:  # the other count's step, where it is the nearer
        i, ax, av, aex, aev = alternative
        other_x, other_v = np.abs(x1[i] - ax), np.abs(v1[i] - av)
        ratio = np.maximum(error_x[i] / bound_x[i], error_v[i] / bound_v[i]).max(axis=1)
        other = np.maximum(other_x / (aex + write_x), other_v / (aev + write_v)).max(axis=1)
        nearer = other < ratio
        i = i[nearer]
        error_x[i], error_v[i] = other_x[nearer], other_v[nearer]
        bound_x[i], bound_v[i] = aex[nearer] + write_x, aev[nearer] + write_v
    for name, error, bound, write in (("position", error_x, bound_x, write_x),
                                      ("velocity", error_v, bound_v, write_v)):
        k = np.unravel_index(np.argmax(error - bound), error.shape)
        assert error[k] <= bound[k], (
            f"{label}: particle {k[0]}'s {name} errs by {error[k]:.3e} > its bound "
            f"{bound[k]:.3e} (= half a code + codec {write:.3e} + float32 {bound[k] - write:.3e})")
    return xr, vr, (error_x / bound_x).max(), (error_v / bound_v).max()


def test_short_horizon_steps_agree_with_float64(gl):
    """Step by step from the GPU's own state: every particle of every step within its own bound
    (check_step). A half-code bias in the RGBA8 writes fails it; so did the old bounds' outliers
    but for one allowance: a contact nearly head-on, where the tangent t = along / |along|
    divides float32's rounding of along = v - (v.n) n by |along| (1.6e-3 of the speed: 5e-5 m/s
    off, 1.4 half codes), which the bound now carries."""
    params = CollisionParams(emit=False, drag=0.2)
    scene = Collision(params.changed(shape="circle+box"))
    n, steps = 20000, 30
    collided, worst_x, worst_v = 0, 0.0, 0.0
    with Simulation(gl, scene.graph(), n) as sim:
        start(sim, scene, *free_particles(scene, n, np.random.default_rng(1)))
        for step in range(steps):
            x0, v0, l0 = download(sim)
            sim.step()
            x1, v1, _ = download(sim)
            xr, vr, ratio_x, ratio_v = check_step(f"step {step}", (x1, v1), (x0, v0, l0),
                                                  scene.field, params, verify=step == 0)
            turned = np.sum(vr * v0, axis=1) < 0.9 * np.sum(v0 * v0, axis=1)
            collided += np.count_nonzero(turned)
            worst_x, worst_v = max(worst_x, ratio_x), max(worst_v, ratio_v)
    print(f"collision, {steps} steps of {n} ({collided} particle-steps with a bounce): largest "
          f"error/bound {worst_x:.3f} (positions), {worst_v:.3f} (velocities)")
    assert collided > 1000, "the test must include collisions"


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
        worst = 0.0
        for step in range(30):
            x0, v0, l0 = download(sim)
            sim.step()
            x1, v1, _ = download(sim)
            # NaN written to a packed texture would come back as the range's bottom, far from
            # the reference: each particle within its own bound, which takes in the branches
            # float32 may take the other way at these contacts (step_with_bound).
            xr, vr, ratio_x, ratio_v = check_step(f"degenerate contacts, step {step}", (x1, v1),
                                                  (x0, v0, l0), field, params, verify=True)
            assert np.all(np.isfinite(xr)) and np.all(np.isfinite(vr)), "the reference made NaN"
            worst = max(worst, ratio_x, ratio_v)
    print(f"degenerate contacts: largest error/bound {worst:.3f}")


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
    with pytest.raises(ParameterError, match="is not a PNG image"):
        Collision(shape=str(broken))
    truncated = tmp_path / "truncated.png"
    truncated.write_bytes(blank.read_bytes()[:40])
    with pytest.raises(ParameterError, match="cannot be read as a PNG image"):
        Collision(shape=str(truncated))
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
    # The hash is not bit-exact with its twin (a driver may fuse and order its dot product's
    # multiply-adds): r is within HASH_ERROR of the twin's round the circle fract leaves
    # (bounds.py; measured 3.9e-3 on llvmpipe), so the lifetime mix(2, 4, r) within twice that
    # (or across the wrap), plus mix's roundings and the write: half a code (half a step) and the
    # codec. A wrong formula (another r component, another range) is O(1).
    age_error = np.abs(after[born, 0]).max()
    share = np.abs(after[born, 1] - expected_lifetime[born]) / 2.0
    lifetime_error = (np.minimum(share, 1 - share) * 2.0).max()
    bound = 2.0 * (HASH_ERROR + 3 * U) + rounding_error("rgba8", 0.0, 2 * LIFE_STEPS * params.dt)
    print(f"emission vs twin: age {age_error:.2e}, lifetime {lifetime_error:.2e} (bound "
          f"{bound:.2e})")
    assert age_error <= decode, "a new particle's age starts at 0"
    assert lifetime_error <= bound, (f"lifetimes {lifetime_error:.3e} off the twin's > bound "
                                     f"{bound:.3e} (2 HASH_ERROR + half a step + the codec)")
    assert np.abs(after[~born, 0] - aged[~born, 0]).max() <= decode, "the others aged by dt"
