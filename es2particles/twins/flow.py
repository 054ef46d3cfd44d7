"""float64 numpy twin of ``lib/noise.glsl`` and ``lib/flow.glsl``: the smoke scene's air velocity,
ideal flow around a moving sphere plus curl noise, both exactly divergence-free.

Each function has the name, the arguments and the formulas of its GLSL peer, line for line, but in
float64 and vectorised over (n, 3) points, so it is the tests' independent reference (the GPU's
float32 arithmetic is what is being checked against it). One difference of form: GLSL's
``simplex3`` returns vec4(gradient, value); here it returns (value, gradient). ``potential``
(the ramped vector potential psi') has no GLSL peer: the shader needs only its curl, which it
writes in closed form; the tests take psi' by finite differences to check that closed form.
"""

import numpy as np

F3, G3 = 1 / 3, 1 / 6  # simplex skew and unskew factors in 3D
# Scales the sum of the four corners' kernels to about [-1, 1]. The largest |sum| is 0.0130072
# (gradient ascent from 20,000 random starts; a million random points reach 0.0130005): one
# kernel's peak, (4/9)^4 |g| |d| = (4/9)^4 / 3 = 0.0130062 at |d| = sqrt(2)/6 along its gradient
# (|g| = sqrt(2)), plus a
# trace of its neighbours'. 76 maps the extremes to +-0.9885 (standard deviation 0.39);
# tests/test_flow.py checks the range.
NOISE_SCALE = 76.0
# Bounds of the scaled noise's derivatives, for error and speed bounds: the largest |gradient| and
# Hessian spectral norm found (Nelder-Mead climbs from the 40 largest of 400,000 random points)
# are 6.887 and 47.70. tests/test_flow.py checks them.
NOISE_GRADIENT_BOUND = 6.9
NOISE_HESSIAN_BOUND = 48.0
# Where the 2nd and 3rd noises of the vector potential are read, relative to the 1st: far apart
# on the lattice (tens of cells), so the three components are independent.
PSI_OFFSET_Y = np.array([31.4, 47.2, 11.9])
PSI_OFFSET_Z = np.array([-23.7, 13.3, 59.1])


# --- lib/noise.glsl ----------------------------------------------------------------------------

def mod289(x):
    """x mod 289 of integer-valued x (see the GLSL for why floor((x + 0.5) / 289) is exact)."""
    return x - 289.0 * np.floor((x + 0.5) / 289.0)


def permute289(h):
    """(34 h^2 + h) mod 289 of an integer 0 <= h < 578, reduced in two products."""
    return mod289(mod289(34.0 * h + 1.0) * h)


def lattice_hash(i):
    """0..288 for lattice points (n, 3) of coordinates 0..289."""
    return permute289(permute289(permute289(i[:, 2]) + i[:, 1]) + i[:, 0])


def edge_gradient(h):
    """One of Perlin's 12 cube-edge directions (n, 3), picked by h mod 12."""
    k = h - 12.0 * np.floor((h + 0.5) / 12.0)
    axis = np.floor((k + 0.5) / 4.0)
    b = k - 4.0 * axis
    high = np.floor((b + 0.5) / 2.0)
    u = 1.0 - 2.0 * (b - 2.0 * high)
    v = 1.0 - 2.0 * high
    e0 = (axis <= 0.5).astype(np.float64)  # GLSL step(axis, 0.5)
    e2 = (axis >= 1.5).astype(np.float64)  # GLSL step(1.5, axis)
    return np.stack([u * (1.0 - e2), v * e0 + u * e2, v * (1.0 - e0)], axis=-1)


def simplex_corner(d, g):
    """One corner's kernel t^4 (g.d), t = max(0.5 - |d|^2, 0): (value (n,), gradient (n, 3))."""
    t = np.maximum(0.5 - np.sum(d * d, axis=-1), 0.0)
    t2 = t * t
    t3 = t2 * t
    t4 = t2 * t2
    gd = np.sum(g * d, axis=-1)
    return t4 * gd, t4[:, None] * g - (8.0 * t3 * gd)[:, None] * d


def simplex3(p):
    """3D simplex noise of points p (n, 3): (value (n,), gradient (n, 3)), value in about
    [-1, 1]; the twin of GLSL ``vec4 simplex3(vec3 p)``."""
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    cell = np.floor(p + np.sum(p, axis=-1, keepdims=True) * F3)
    d0 = p - cell + np.sum(cell, axis=-1, keepdims=True) * G3
    x, y, z = d0[:, 0], d0[:, 1], d0[:, 2]
    xy = (x >= y).astype(np.float64)  # GLSL step(d0.y, d0.x)
    yz = (y >= z).astype(np.float64)
    xz = (x >= z).astype(np.float64)
    first = np.stack([xy * xz, (1.0 - xy) * yz, (1.0 - xz) * (1.0 - yz)], axis=-1)
    last = np.stack([(1.0 - xy) * (1.0 - xz), xy * (1.0 - yz), xz * yz], axis=-1)
    second = 1.0 - last
    d1 = d0 - first + G3
    d2 = d0 - second + 2.0 * G3
    d3 = d0 - 1.0 + 3.0 * G3
    i = mod289(cell)
    value = np.zeros(len(p))
    gradient = np.zeros((len(p), 3))
    for d, corner_offset in ((d0, 0.0), (d1, first), (d2, second), (d3, 1.0)):
        v, g = simplex_corner(d, edge_gradient(lattice_hash(i + corner_offset)))
        value += v
        gradient += g
    return NOISE_SCALE * value, NOISE_SCALE * gradient


# --- lib/flow.glsl -----------------------------------------------------------------------------

def _points(x):
    return np.asarray(x, dtype=np.float64).reshape(-1, 3)


def sphere_flow(x, centre, radius, wind, sphere_velocity):
    """Ideal flow (n, 3) at points x (n, 3) of air moving at ``wind`` far away around a sphere
    moving at ``sphere_velocity``: wind + grad(R^3 / (2 r^3) (wind - V).(x - c)); inside the
    sphere, its velocity."""
    x = _points(x)
    y = x - centre
    r = np.linalg.norm(y, axis=-1)
    inside = r < radius
    r = np.where(inside, 1.0, r)  # kept finite where the result is V anyway
    n = y / r[:, None]
    a = np.asarray(wind, np.float64) - sphere_velocity
    q = radius / r
    k = 0.5 * q * q * q
    u = wind + k[:, None] * (a - 3.0 * (n @ a)[:, None] * n)
    return np.where(inside[:, None], np.asarray(sphere_velocity, np.float64), u)


def flow_ramp(q):
    """Bridson's ramp of q clamped to [0, 1]: (value, derivative) = (15/8 q - 10/8 q^3 + 3/8 q^5,
    15/8 (1 - q^2)^2)."""
    q = np.clip(q, 0.0, 1.0)
    q2 = q * q
    w = 1.0 - q2
    return q * (15.0 / 8.0 - q2 * (10.0 / 8.0 - 3.0 / 8.0 * q2)), 15.0 / 8.0 * w * w


def _noises(x, offset, scale):
    """The three noises of psi at x: values (n, 3) and gradients (n, 3, 3) (w.r.t. their
    argument, row i the i-th noise's)."""
    p = scale * x + offset
    a, ga = simplex3(p)
    b, gb = simplex3(p + PSI_OFFSET_Y)
    c, gc = simplex3(p + PSI_OFFSET_Z)
    return np.stack([a, b, c], axis=-1), np.stack([ga, gb, gc], axis=1)


def _sphere_frame(x, centre, radius, ramp):
    y = x - centre
    r = np.linalg.norm(y, axis=-1)
    n = y / np.where(r > 0, r, 1.0)[:, None]
    width = max(ramp, 1e-6)
    alpha, slope = flow_ramp((r - radius) / width)
    return r, n, alpha, slope / width


def potential(x, offset, scale, centre, radius, ramp):
    """psi' (n, 3): the curl noise's vector potential psi with its tangential part ramped down
    near the sphere, alpha psi + (1 - alpha)(n.psi) n (alpha = 0 inside). No GLSL peer."""
    x = _points(x)
    psi, _ = _noises(x, offset, scale)
    _, n, alpha, _ = _sphere_frame(x, centre, radius, ramp)
    normal = np.sum(n * psi, axis=-1)
    return alpha[:, None] * psi + ((1.0 - alpha) * normal)[:, None] * n


def curl_noise(x, offset, scale, centre, radius, ramp):
    """curl(psi') (n, 3) in closed form from the noises' gradients (``potential`` is psi'):
    alpha curl(psi) + alpha' n x psi + (1 - alpha)(psi / r + J^T n) x n, J_ij = d psi_i / d x_j;
    zero inside the sphere."""
    x = _points(x)
    r, n, alpha, alpha_slope = _sphere_frame(x, centre, radius, ramp)
    psi, g = _noises(x, offset, scale)
    ga, gb, gc = g[:, 0], g[:, 1], g[:, 2]
    curl = scale * np.stack([gc[:, 1] - gb[:, 2], ga[:, 2] - gc[:, 0], gb[:, 0] - ga[:, 1]],
                            axis=-1)
    jtn = scale * (n[:, :1] * ga + n[:, 1:2] * gb + n[:, 2:] * gc)
    r_safe = np.where(r > 0, r, 1.0)[:, None]
    u = (alpha[:, None] * curl + alpha_slope[:, None] * np.cross(n, psi)
         + (1.0 - alpha)[:, None] * np.cross(psi / r_safe + jtn, n))
    return np.where((r < radius)[:, None], 0.0, u)


def air_velocity(x, centre, radius, wind, sphere_velocity, noise, offset):
    """The air's velocity (n, 3): sphere_flow + amplitude * curl_noise, with ``noise`` =
    (amplitude, spatial frequency, ramp distance, unused)."""
    amplitude, scale, ramp = noise[0], noise[1], noise[2]
    return (sphere_flow(x, centre, radius, wind, sphere_velocity)
            + amplitude * curl_noise(x, offset, scale, centre, radius, ramp))
