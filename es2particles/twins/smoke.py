"""float64 twin of the smoke's passes (``shaders/glsl100/smoke.frag``) for particles alive through
the steps (emission is the fountain's clock, ``twins/life.py``): the air at a point and time, the
inertial step (acceleration, then velocity and position from it) and the tracers' midpoint step.
"""

import numpy as np

from . import flow, motion


def sphere(physics, t, drift=(0.0, 0.0, 0.0)):
    """(centre (3,), velocity (3,)) of the swaying sphere at time ``t`` (the scene's motion:
    ``twins/motion.py``); ``drift``: the rest centre's own velocity (a hand dragging it)."""
    centre, _, velocity = motion.pose(physics.motion(), t)
    return centre, velocity + np.asarray(drift, float)


def air(physics, x, t, drift=(0.0, 0.0, 0.0)):
    """The air's velocity (n, 3) at points ``x`` (n, 3) and time ``t`` (``drift``: as for
    :func:`sphere`)."""
    p = physics
    centre, velocity = sphere(p, t, drift)
    offset = -p.noise[1] * p.noise[3] * np.asarray(p.wind, float) * t  # frozen turbulence,
    skewed = offset + offset.sum() / 3  # wrapped on the noise's period, into +-144.5 cells
    skewed -= 289.0 * np.floor(skewed / 289.0 + 0.5)
    offset = skewed - skewed.sum() / 6
    return flow.air_velocity(np.asarray(x, float), centre, p.sphere[3], np.asarray(p.wind, float),
                             velocity, np.asarray(p.noise, float), offset)


def outside_sphere(physics, x, t):
    """Points inside the sphere of time ``t`` moved out onto its surface."""
    centre, _ = sphere(physics, t)
    d = x - centre
    r = np.linalg.norm(d, axis=1, keepdims=True)
    inside = (r < physics.sphere[3]) & (r > 0)
    return np.where(inside, centre + d * (physics.sphere[3] / np.where(r > 0, r, 1)), x)


def relaxation(dt, tau):
    """(phi, tau (dt - phi)) with phi = tau (1 - exp(-dt / tau)): what a step's acceleration
    a = (u - v) / tau + g adds to the velocity and, besides v dt, to the position, for the exact
    solution of v' = a with u and g held over the step. In float64 and without cancellation (the
    passes get them as uniforms: in float32, tau (dt - phi) is noise once tau / dt passes ~100)."""
    if tau <= 0:
        return 0.0, 0.0
    x = dt / tau
    phi = tau * -np.expm1(-x)
    # dt - phi = tau (x - 1 + exp(-x)), x^2 / 2 - x^3 / 6 + ... for small x
    rest = x * x * (0.5 - x / 6 + x * x / 24 - x ** 3 / 120) if x < 1e-2 else x + np.expm1(-x)
    return phi, tau * tau * rest


def relax(x, v, air_velocity, physics):
    """One exact step of v' = (u - v) / tau + g for the air ``air_velocity`` held over it:
    (acceleration, velocity, position) as the three passes compute them."""
    p = physics
    a = (air_velocity - v) / p.tau + np.asarray(p.gravity, float)
    phi, lag = relaxation(p.dt, p.tau)
    return a, v + a * phi, x + v * p.dt + a * lag


def inertial_step(physics, x, v, t):
    """One step of inertial particles from time ``t``: (acceleration, velocity, position)."""
    a, v_new, x_new = relax(x, v, air(physics, x, t), physics)
    return a, v_new, outside_sphere(physics, x_new, t + physics.dt)


def tracer_step(physics, x, t):
    """One midpoint step of tracers (tau = 0) from time ``t``."""
    p = physics
    middle = x + air(p, x, t) * (0.5 * p.dt)
    return outside_sphere(p, x + air(p, middle, t + 0.5 * p.dt) * p.dt, t + p.dt)
