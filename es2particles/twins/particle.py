"""numpy twin of ``lib/particle.glsl`` (float64) and ``lib/hash.glsl`` (float32): one step of a
collision-scene particle, the independent reference of tests/test_collision.py and the report."""

import numpy as np

from .drag import exact_drag
from .life import alive

def acceleration(x, p):
    ox, oy, w2 = p.spring
    return np.asarray(p.gravity, float) + w2 * (np.array([ox, oy]) - x)


def respond(x, v, a, d, n, hit, p, moved):
    vn = np.sum(v * n, axis=-1)
    an = np.sum(a * n, axis=-1)
    turn = hit & (vn < 0)
    speed = np.hypot(v[:, 0], v[:, 1])
    along = v - vn[:, None] * n
    along_len = np.hypot(along[:, 0], along[:, 1])
    has_tangent = along_len > 1e-6 * speed
    t = along / np.where(has_tangent, along_len, 1)[:, None]
    sliding = np.where(has_tangent, p.sliding, 1.0)[:, None]  # head-on: all along the normal
    new_v = speed[:, None] * (n * sliding + t * (1 - sliding)) * p.bounce
    v = np.where(turn[:, None], new_v, v)
    x = np.where(hit[:, None], x - d[:, None] * n, x)
    v2 = np.sum(v * v, axis=-1)
    # turned: over the depth its own move explains, at most the normal speed's share less what
    # the response took; over any deeper part, the whole work (lib/particle.glsl)
    ours = np.maximum(d, np.minimum(moved, 0))
    capped = np.minimum(2 * ours * an, np.maximum(vn * vn - (speed * speed - v2), 0)) \
        + 2 * (d - ours) * an
    work = np.where(turn, capped, 2 * d * an)
    scale = np.sqrt(np.maximum(v2 - work, 0) / np.where(v2 > 0, v2, 1))
    v = np.where((hit & (v2 > 0))[:, None], v * scale[:, None], v)
    return x, v


def collide(x, v, a, field, p, before):
    d, n = field.sample(x)
    d = d.astype(np.float64)
    moved = x - before
    # Inside yet moving along the outward normal: it came through the other side of a thin wall
    # (see collide() in lib/particle.glsl); leave by the side it came from.
    # ... within two cells of the surface: deeper, it is inside a thick object
    back = (d < 0) & (np.sum(moved * n, axis=-1) > 0) & (d > -2 * field.cell)
    n = np.where(back[:, None], -n, n)
    d = np.where(back, np.sum(moved * n, axis=-1), d)
    x, v = respond(x, v, a, d, n, d < 0, p, np.sum(moved * n, axis=-1))
    x0, y0, x1, y1 = field.rect
    for axis, edge, sign in ((0, x0, 1.0), (0, x1, -1.0), (1, y0, 1.0), (1, y1, -1.0)):
        depth = sign * (x[:, axis] - edge)
        normal = np.zeros_like(x)
        normal[:, axis] = sign
        x, v = respond(x, v, a, depth, normal, depth < 0, p, sign * (x[:, axis] - before[:, axis]))
    return x, v



def integrate(x, v, field, p):
    a0 = acceleration(x, p)
    reach = (np.hypot(v[:, 0], v[:, 1]) + np.hypot(a0[:, 0], a0[:, 1]) * p.dt) * p.dt
    fixed = p.fixed_substeps(field.cell)
    n = np.full(len(x), fixed) if fixed > 0 else np.ceil(reach / (0.5 * field.cell))
    n = np.clip(n, 1, p.max_substeps(field.cell))
    h = p.dt / n
    decay, gain = exact_drag(p.drag, h)
    for i in range(int(n.max()) if len(n) else 0):
        active = (i < n)[:, None]
        a = acceleration(x, p)
        v_new = np.clip(v * decay[:, None] + a * gain[:, None], -p.max_speed, p.max_speed)
        x_new = x + v_new * h[:, None]
        x_new, v_new = collide(x_new, v_new, a, field, p, x)
        v_new = np.clip(v_new, -p.max_speed, p.max_speed)
        x, v = np.where(active, x_new, x), np.where(active, v_new, v)
    return x, v


def step_reference(x, v, life, field, p):
    """One step of every particle in float64, without respawn (tests keep lifetimes long)."""
    x, v, life = (np.array(a, dtype=np.float64) for a in (x, v, life))
    living = alive(life)
    xi, vi = integrate(x[living], v[living], field, p)
    x[living], v[living] = xi, vi
    life[:, 0] += p.dt
    return x, v, life
