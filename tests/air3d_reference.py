"""A float64 numpy reference of the 3D air's step (the flame's wind source), written from the
equations: Stam's stable fluids on a MAC grid of W x H x D cells, pressure and divergence at the
cell centres, u, v and w on the x, y and z faces; a fire (density, temperature) carried at the
centres; buoyancy and vorticity confinement as forces; walls and obstacles as blocked faces and
ghost pressures. Vectorised over whole grids; it shares no code with the shaders or the scene
(``wind_reference.py`` is the 2D one).

Arrays are indexed [k, j, i] (z, y, x), as ``Simulation.download`` gives a 3D grid: u (D, H,
W + 1), v (D, H + 1, W), w (D + 1, H, W), cells (D, H, W), the fire (D, H, W, 2).
"""

from dataclasses import dataclass

import numpy as np

OPEN = 2


@dataclass
class Air3:
    """The box from ``lo`` to ``hi``, ``solid`` (D, H, W) cells, ``walls`` (x0, x1, y0, y1, z0,
    z1) kinds (2: open, else closed)."""

    solid: np.ndarray
    lo: tuple
    hi: tuple
    walls: tuple

    @property
    def shape(self):  # (D, H, W)
        return self.solid.shape

    @property
    def cell(self):  # (dx, dy, dz)
        d, h, w = self.shape
        return tuple((b - a) / n for a, b, n in zip(self.lo, self.hi, (w, h, d)))

    def blocked(self):
        """(u, v, w) faces held at 0: beside a solid cell, or on a closed side."""
        out = []
        for axis in range(3):  # x, y, z: array axes 2, 1, 0
            along = 2 - axis
            faces = np.zeros(tuple(n + (a == along) for a, n in enumerate(self.shape)), bool)
            lower = [slice(None)] * 3
            upper = [slice(None)] * 3
            lower[along], upper[along] = slice(None, -1), slice(1, None)
            faces[tuple(lower)] |= self.solid  # the face before a solid cell's far side
            faces[tuple(upper)] |= self.solid
            first = [slice(None)] * 3
            last = [slice(None)] * 3
            first[along], last[along] = 0, -1
            faces[tuple(first)] |= self.walls[2 * axis] != OPEN
            faces[tuple(last)] |= self.walls[2 * axis + 1] != OPEN
            out.append(faces)
        return out

    def origin(self, which):
        """The world point of grid ``which``'s value [0, 0, 0] (x, y, z): "u", "v", "w" or
        "c" (the cells)."""
        half = np.asarray(self.cell) / 2
        o = np.asarray(self.lo, float) + half
        if which != "c":
            o["uvw".index(which)] -= half["uvw".index(which)]
        return o

    def points(self, which, shape):
        """World points (..., 3) of every value of grid ``which`` of array ``shape``."""
        k, j, i = np.meshgrid(*(np.arange(n) for n in shape), indexing="ij")
        return self.origin(which) + np.stack([i, j, k], -1) * np.asarray(self.cell)


def sample(air, field, which, points):
    """Trilinear ``field`` (D', H', W'[, C]) of grid ``which`` at world ``points`` (..., 3),
    edge values extended."""
    g = (points - air.origin(which)) / np.asarray(air.cell)
    i0 = np.floor(g)
    t = g - i0
    i0 = i0.astype(int)
    d, h, w = field.shape[:3]
    out = 0.0
    for ox in (0, 1):
        for oy in (0, 1):
            for oz in (0, 1):
                weight = ((t[..., 0] if ox else 1 - t[..., 0])
                          * (t[..., 1] if oy else 1 - t[..., 1])
                          * (t[..., 2] if oz else 1 - t[..., 2]))
                value = field[np.clip(i0[..., 2] + oz, 0, d - 1),
                              np.clip(i0[..., 1] + oy, 0, h - 1),
                              np.clip(i0[..., 0] + ox, 0, w - 1)]
                out = out + (weight[..., None] if value.ndim > weight.ndim else weight) * value
    return out


def wind_at(air, u, v, w, points):
    return np.stack([sample(air, u, "u", points), sample(air, v, "v", points),
                     sample(air, w, "w", points)], -1)


def corners(air, field, moved):
    """The least and the greatest of the 8 values of ``field`` among which each of its points
    lands when moved by ``moved`` (..., 3 world units): its own index less the move in cells,
    so a still point's are its own and the next ones (edge values extended)."""
    index = np.stack(np.meshgrid(*(np.arange(n) for n in field.shape[:3]),
                                 indexing="ij")[::-1], -1)  # (i, j, k) of [k, j, i]
    i0 = np.floor(index + moved / np.asarray(air.cell)).astype(int)
    values = [clamped(field, i0[..., 2] + oz, i0[..., 1] + oy, i0[..., 0] + ox)
              for ox in (0, 1) for oy in (0, 1) for oz in (0, 1)]
    return np.min(values, axis=0), np.max(values, axis=0)


def carried(air, field, which, wind, hold, maccormack):
    """``field`` (grid ``which``) carried a step along ``wind`` (a function of world points):
    from where it was, field(x - dt u(x)); by MacCormack's scheme, that value corrected by half
    the error of carrying it back, ahead + (field - behind) / 2, limited to the 8 values the
    backtrace falls among. ``hold``: where the values are 0 at every stage."""
    x = air.points(which, field.shape[:3])
    back, forth = x - wind(x), x + wind(x)
    ahead = np.where(hold, 0.0, sample(air, field, which, back))
    if not maccormack:
        return ahead
    behind = np.where(hold, 0.0, sample(air, ahead, which, forth))
    lo, hi = corners(air, field, back - x)
    return np.where(hold, 0.0, np.clip(ahead + 0.5 * (field - behind), lo, hi))


def advect(air, u, v, w, dt, maccormack=False):
    def wind(x):
        return dt * wind_at(air, u, v, w, x)
    return [carried(air, own, which, wind, blocked, maccormack)
            for which, own, blocked in zip("uvw", (u, v, w), air.blocked())]


def carry(air, fire, u, v, w, dt, keep, maccormack=False):
    """The fire carried from where it was a step ago, keeping ``keep`` of itself (the burner's
    feed is checked apart: it is noise)."""
    def wind(x):
        return dt * wind_at(air, u, v, w, x)
    return carried(air, fire, "c", wind, air.solid[..., None], maccormack) * np.asarray(keep)


def clamped(field, k, j, i):
    d, h, w = field.shape[:3]
    return field[np.clip(k, 0, d - 1), np.clip(j, 0, h - 1), np.clip(i, 0, w - 1)]


def centre_wind(u, v, w):
    """The wind at the cell centres (D, H, W, 3): the mean of each cell's two faces an axis."""
    return np.stack([(u[:, :, 1:] + u[:, :, :-1]) / 2, (v[:, 1:] + v[:, :-1]) / 2,
                     (w[1:] + w[:-1]) / 2], -1)


def curl(air, u, v, w):
    """The curl of the centred wind by central differences, the edge cells repeated."""
    c = centre_wind(u, v, w)
    d, h, wd = air.shape
    k, j, i = np.meshgrid(np.arange(d), np.arange(h), np.arange(wd), indexing="ij")
    dx, dy, dz = (2 * s for s in air.cell)

    def diff(axis, component):
        step = [(0, 0, 1), (0, 1, 0), (1, 0, 0)][axis]
        ahead = clamped(c, k + step[0], j + step[1], i + step[2])[..., component]
        behind = clamped(c, k - step[0], j - step[1], i - step[2])[..., component]
        return (ahead - behind) / (dx, dy, dz)[axis]
    return np.stack([diff(1, 2) - diff(2, 1), diff(2, 0) - diff(0, 2), diff(0, 1) - diff(1, 0)],
                    -1)


def confinement(air, omega, epsilon):
    """epsilon h (N x omega) at every cell, N the unit gradient of |omega| (central
    differences, edge cells repeated), h the smallest side of a cell."""
    d, h, w = air.shape
    k, j, i = np.meshgrid(np.arange(d), np.arange(h), np.arange(w), indexing="ij")
    size = np.linalg.norm(omega, axis=-1)
    grad = np.stack([
        (clamped(size, k, j, i + 1) - clamped(size, k, j, i - 1)) / (2 * air.cell[0]),
        (clamped(size, k, j + 1, i) - clamped(size, k, j - 1, i)) / (2 * air.cell[1]),
        (clamped(size, k + 1, j, i) - clamped(size, k - 1, j, i)) / (2 * air.cell[2])], -1)
    n = grad / (np.linalg.norm(grad, axis=-1, keepdims=True) + 1e-6)
    return epsilon * min(air.cell) * np.cross(n, omega)


def forces(air, u, v, w, fire, dt, force, gusts, step, buoyancy, vorticity):
    """The body force with its gusts, the confinement (the mean of the two cells a face lies
    between) and, on the y faces, the buoyancy of the mean temperature there."""
    f = np.asarray(force, float) * (1 + gusts[0] * np.sin(2 * np.pi * step * dt / gusts[1]))
    conf = confinement(air, curl(air, u, v, w), vorticity) if vorticity else None
    out = []
    for axis, (own, blocked) in enumerate(zip((u, v, w), air.blocked())):
        k, j, i = np.meshgrid(*(np.arange(n) for n in own.shape), indexing="ij")
        before = [k, j, i]
        before[2 - axis] = before[2 - axis] - 1
        push = np.full(own.shape, f[axis])
        if conf is not None:
            push = push + 0.5 * (clamped(conf, *before)[..., axis]
                                 + clamped(conf, k, j, i)[..., axis])
        if axis == 1:
            push = push + buoyancy * 0.5 * (clamped(fire, *before)[..., 1]
                                            + clamped(fire, k, j, i)[..., 1])
        out.append(np.where(blocked, 0.0, own + dt * push))
    return out


def divergence(air, u, v, w):
    dx, dy, dz = air.cell
    div = ((u[:, :, 1:] - u[:, :, :-1]) / dx + (v[:, 1:] - v[:, :-1]) / dy
           + (w[1:] - w[:-1]) / dz)
    return np.where(air.solid, 0.0, div)


def neighbours(air, p):
    """For each axis and way, the pressure beyond each cell's face: the neighbour's in fluid,
    p across a closed side or at an obstacle, -p across an open side."""
    out = []
    for axis in range(3):
        along = 2 - axis
        for way, side in ((1, 2 * axis + 1), (-1, 2 * axis)):
            shifted = np.roll(p, -way, axis=along)
            solid = np.roll(air.solid, -way, axis=along)
            n = np.where(solid, p, shifted)
            edge = [slice(None)] * 3
            edge[along] = -1 if way > 0 else 0
            n[tuple(edge)] = -p[tuple(edge)] if air.walls[side] == OPEN else p[tuple(edge)]
            out.append(n)
    return out


def jacobi(air, p, div, iterations):
    """Jacobi iterations of the 7-point Poisson equation sum (n+ + n- - 2p) / d^2 = div."""
    k = [1 / c ** 2 for c in air.cell]
    for _ in range(iterations):
        n = neighbours(air, p)
        total = sum(k[a] * (n[2 * a] + n[2 * a + 1]) for a in range(3))
        p = np.where(air.solid, 0.0, (total - div) / (2 * sum(k)))
    return p


def project(air, u, v, w, p):
    """Each face's velocity less the pressure difference across it (beyond an open side the
    ghost -p); blocked faces stay 0."""
    out = []
    for axis, (own, blocked) in enumerate(zip((u, v, w), air.blocked())):
        along = 2 - axis
        first = [slice(None)] * 3
        last = [slice(None)] * 3
        first[along], last[along] = slice(0, 1), slice(-1, None)
        before = np.concatenate([-p[tuple(first)], p], along)
        after = np.concatenate([p, -p[tuple(last)]], along)
        out.append(np.where(blocked, 0.0, own - (after - before) / air.cell[axis]))
    return out


def step(air, u, v, w, p, fire, dt, keep, force, gusts, step_number, buoyancy, vorticity,
         iterations, warm=1.0, maccormack=False):
    """One step of the 3D air: (u, v, w, fire, divergence, pressure) after it."""
    moved = carry(air, fire, u, v, w, dt, keep, maccormack)
    u1, v1, w1 = advect(air, u, v, w, dt, maccormack)
    u2, v2, w2 = forces(air, u1, v1, w1, moved, dt, force, gusts, step_number, buoyancy,
                        vorticity)
    div = divergence(air, u2, v2, w2)
    p = jacobi(air, warm * p, div, iterations)
    u3, v3, w3 = project(air, u2, v2, w2, p)
    return u3, v3, w3, moved, div, p
