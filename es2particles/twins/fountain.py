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
        # Met the floor within the step: back onto it, rising with the bounce's share of the
        # speed it had there (v^2 + 2 g depth, g < 0: what falling the depth below added is
        # taken off), so no bounce gives energy and a resting particle stays at rest.
        depth = -x[below, 1]
        x[below, 1] = 0.0
        v[below, 1] = p.bounce * np.sqrt(np.maximum(v[below, 1] ** 2 + 2 * p.gravity[1] * depth, 0))
        below = np.zeros(len(x), bool)
    return x, v, below | outside
