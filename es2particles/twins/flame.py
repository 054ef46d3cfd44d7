"""float64 twin of the noise flame's march (``shaders/glsl100/flame/march.frag``): the field,
the rays, the segments and the tone curve, vectorised over pixels. The benchmark's numpy peer
(``benchmarks/flame.py``)."""

import numpy as np

from .flow import simplex3


def noise_field(p, shape, offset):
    """(density, temperature) of points ``p`` (n, 3): march.frag's ``field`` under SOURCE_NOISE,
    ``offset`` the noise's rise so far (u_rise u_step)."""
    radius, height, flicker, frequency = shape
    rise = np.clip(p[:, 1] / height, 0, 1)
    centre = height / 3
    axis = np.where(p[:, 1] < centre, centre, height - centre)
    q = np.stack([p[:, 0] / radius, (p[:, 1] - centre) / axis, p[:, 2] / radius], axis=1)
    d = (np.linalg.norm(q, axis=1) - 1) * radius
    near = d <= 1.5 * flicker * rise
    n = np.stack([p[near, 0], 0.5 * (p[near, 1] - offset), p[near, 2]], axis=1) * frequency
    d[near] += flicker * rise[near] * (simplex3(n)[0] + 0.5 * simplex3(2 * n + 7)[0])
    density = np.where(near, np.clip(-d / (0.3 * radius), 0, 1), 0.0)
    return density, np.clip(density * (1.2 - 0.8 * rise), 0, 1)


def march(eye, rays, lo, hi, steps, field, medium, ramp, background, start=0.5):
    """The picture (n, 3) of rays (n, 3) from ``eye`` through the box [lo, hi]: ``steps``
    segments, each sampled at ``start`` of its length, ``field(points)`` -> (density,
    temperature), ``medium`` (K, E / K), ``ramp`` (256, 3) the blackbody colours."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = (np.asarray(lo) - eye) / rays, (np.asarray(hi) - eye) / rays
    t0 = np.maximum(np.nanmax(np.minimum(a, b), axis=1), 0)
    t1 = np.nanmin(np.maximum(a, b), axis=1)
    inside = t1 > t0
    h = np.where(inside, t1 - t0, 0) / steps
    light, through = np.zeros_like(rays), np.ones(len(rays))
    for i in range(steps):
        points = eye + (t0 + (i + start) * h)[:, None] * rays
        density, temperature = field(points[inside])
        a = np.zeros(len(rays))
        a[inside] = 1 - np.exp(-medium[0] * density * h[inside])
        colour = np.zeros_like(rays)
        colour[inside] = ramp[np.clip(np.round(temperature * 255), 0, 255).astype(int)]
        light += (through * a)[:, None] * colour
        through *= 1 - a
    return 1 - np.exp(-(light * medium[1] + through[:, None] * np.asarray(background)))
