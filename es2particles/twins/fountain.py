"""float64 twin of ``fountain.frag``'s step for living particles (no emission): exact drag,
gravity, semi-implicit Euler, the velocity range, and the floor (kill or bounce)."""

import numpy as np

from .drag import exact_drag


def fountain_step(x, v, p, box=((-6.0, -1.0, -6.0), (6.0, 7.0, 6.0))):
    """One step of particles at positions x and velocities v (N, 3) under FountainParams p.
    Returns (x, v, died): ``died`` marks particles that left ``box`` (the position range) or went
    through the floor with floor kill (the GPU re-emits them)."""
    x, v = np.array(x, dtype=np.float64), np.array(v, dtype=np.float64)
    decay, gain = exact_drag(p.drag, p.dt)
    v = np.clip(v * decay + np.asarray(p.gravity, float) * gain, -p.max_speed, p.max_speed)
    x = x + v * p.dt
    lo, hi = np.asarray(box[0], float), np.asarray(box[1], float)
    outside = np.any(x[:, [0, 2]] < lo[[0, 2]], axis=1) | np.any(x > hi, axis=1)
    below = (x[:, 1] < 0) & ~outside
    if p.floor == "bounce":
        x[below, 1] *= -p.bounce
        v[below, 1] *= -p.bounce
        below = np.zeros(len(x), bool)
    return x, v, below | outside
