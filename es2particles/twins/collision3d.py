"""float64 twin of ``collision3d.frag``'s step for living particles: the random kick, sub-steps of
at most half a voxel relative to the object, exact Stokes drag, the chapter's response against the
voxel field (``VoxelField.sample``) in the moving surface's frame, and the floor. The tests' and
the report's independent reference (no emission: tests keep lifetimes long)."""

import numpy as np

from . import motion
from .drag import exact_drag
from .life import step_hash


def flight_random(uv, step, state_size):
    """``flight_random``: four numbers in [0, 1) per particle (float32, as the GPU)."""
    texel = np.floor(np.asarray(uv, np.float32) * np.asarray(state_size, np.float32))
    return step_hash(texel, step, 53).astype(np.float64)


def random_tangent(n, turn):
    up = np.where((np.abs(n[:, 1]) < 0.99)[:, None], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    side = np.cross(n, up)
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    angle = 2 * np.pi * turn
    return side * np.cos(angle)[:, None] + np.cross(n, side) * np.sin(angle)[:, None]


def respond(x, v, a, d, n, hit, p, turn, moved):
    vn = np.sum(v * n, axis=1)
    speed = np.linalg.norm(v, axis=1)
    along = v - vn[:, None] * n
    along_len = np.linalg.norm(along, axis=1)
    has_tangent = along_len > 1e-6 * speed
    t = np.where(has_tangent[:, None], along / np.where(has_tangent, along_len, 1)[:, None],
                 random_tangent(n, turn))
    turned = speed[:, None] * (n * p.sliding + t * (1 - p.sliding)) * p.bounce
    v = np.where((hit & (vn < 0))[:, None], turned, v)
    x = np.where(hit[:, None], x - d[:, None] * n, x)
    v2 = np.sum(v * v, axis=1)
    an = n @ a
    # turned: over the depth its own move explains, at most the normal speed's share less what
    # the response took; over any deeper part, the whole work (collision3d.frag)
    ours = np.maximum(d, np.minimum(moved, 0))
    capped = np.minimum(2 * ours * an, np.maximum(vn * vn - (speed * speed - v2), 0)) \
        + 2 * (d - ours) * an
    work = np.where(hit & (vn < 0), capped, 2 * d * an)
    scale = np.sqrt(np.maximum(v2 - work, 0) / np.where(v2 > 0, v2, 1))
    return x, np.where((hit & (v2 > 0))[:, None], v * scale[:, None], v)


class Object:
    """The object's pose at a time, and its field seen from the world."""

    def __init__(self, field, p):
        self.field, self.p = field, p

    def at(self, t):
        return motion.pose(self.p.motion(self.field.pivot), t)

    def to_object(self, x, pose):
        centre, r, _ = pose
        return (x - centre) @ r / self.p.scale  # R^T (x - c) / s, row vectors

    def surface_velocity(self, x, pose):
        centre, _, velocity = pose
        return velocity + np.cross(self.p.spin_axis * self.p.spin_rate, x - centre)


def collide(x, v, a, q_before, obj, pose, p, turn, decoded=None, x_before=None):
    field = obj.field
    q = obj.to_object(x, pose)
    d, n = field.sample(q, decoded)
    moved = q - q_before
    back = ((d < 0) & (np.sum(moved * n, axis=1) > 0) & (d > -2 * field.voxel)
            & (d < -0.25 * field.voxel))  # from a quarter voxel deep (see collision3d.frag)
    if np.any(back):  # and from where the surface faces the other way
        came_from = field.sample(q_before[back], decoded)[1]
        back[back] = np.sum(came_from * n[back], axis=1) < 0
    n = np.where(back[:, None], -n, n)
    d = np.where(back, np.sum(moved * n, axis=1), d)
    hit = d < 0
    surface = obj.surface_velocity(x, pose)
    x, relative = respond(x, v - surface, a, d * p.scale, n @ pose[1].T, hit, p, turn,
                          np.sum(moved * n, axis=1) * p.scale)
    v = relative + surface
    x, v = respond(x, v, a, x[:, 1], np.tile([0.0, 1.0, 0.0], (len(x), 1)), x[:, 1] < 0, p, turn,
                   x[:, 1] - x_before[:, 1])
    return x, v


def step_reference(x, v, field, p, step, substep, surface_speed, random=None, decoded=None,
                   max_substeps=4096):
    """One step of living particles (N, 3) at step number ``step``; ``random`` (N, 4) are
    ``flight_random``'s numbers (None: no kick, a fixed tangent turn of 0); sub-step counts
    are clamped to ``max_substeps`` (the shader's MAX_SUBSTEPS)."""
    x, v = np.array(x, np.float64), np.array(v, np.float64)
    r = np.zeros((len(x), 4)) if random is None else np.asarray(random, np.float64)
    if random is not None:
        v = v + p.jitter * np.sqrt(p.dt) * (2 * r[:, 1:] - 1)
    a = p.acceleration
    reach = (np.linalg.norm(v, axis=1) + np.linalg.norm(a) * p.dt + surface_speed) * p.dt
    n = np.clip(np.ceil(reach / substep), 1, max_substeps)
    h = p.dt / n
    decay, gain = exact_drag(p.drag, h)
    obj = Object(field, p)
    t0 = step * p.dt
    q_before = obj.to_object(x, obj.at(t0))
    for i in range(int(n.max()) if len(n) else 0):
        active = i < n
        xa, va, ha = x[active], v[active], h[active]
        pose_t = t0 + (i + 1) * ha
        xn, vn, qn = np.empty_like(xa), np.empty_like(va), np.empty_like(xa)
        for t in np.unique(pose_t):  # particles of one sub-step length share the pose
            m = pose_t == t
            pose = obj.at(t)
            vm = np.clip(va[m] * decay[active][m][:, None] + a * gain[active][m][:, None],
                         -p.max_speed, p.max_speed)
            xm = xa[m] + vm * ha[m][:, None]
            xm, vm = collide(xm, vm, a, q_before[active][m], obj, pose, p, r[active][m, 0],
                             decoded, xa[m])
            xn[m], vn[m] = xm, np.clip(vm, -p.max_speed, p.max_speed)
            qn[m] = obj.to_object(xn[m], pose)
        x[active], v[active] = xn, vn
        q_before[active] = qn
    return x, v
