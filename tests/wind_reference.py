"""A float64 numpy reference of the wind scene's fluid step, written from the equations (Stam's
stable fluids on a MAC grid: pressure and divergence at cell centres, u on the x faces, v on the
y faces; walls and obstacles as blocked faces and ghost values), for the tests to hold the GPU's
step against. Vectorised over whole grids; it shares no code with the shaders or the scene.

Arrays have row 0 at the bottom, as ``--save-state`` writes them: u (H, W + 1), v (H + 1, W),
pressure and divergence (H, W).
"""

from dataclasses import dataclass

import numpy as np

SLIP, NOSLIP, OPEN, MOVING = 0, 1, 2, 3


@dataclass
class Air:
    """The grid, its obstacles and walls: ``solid`` (H, W) bool; ``cell`` (dx, dy); ``walls``
    (left, right, bottom, top) kinds and ``speeds`` (m/s, +y on the left and right, +x on the
    bottom and top)."""

    solid: np.ndarray
    cell: tuple
    walls: tuple = (OPEN, OPEN, SLIP, SLIP)
    speeds: tuple = (0.0, 0.0, 0.0, 0.0)

    @property
    def shape(self):
        return self.solid.shape

    def blocked(self):
        """The x faces (H, W + 1) and y faces (H + 1, W) held at zero: on a closed wall or
        beside an obstacle."""
        h, w = self.shape
        closed = [k != OPEN for k in self.walls]
        x = np.zeros((h, w + 1), bool)
        x[:, 1:] |= self.solid
        x[:, :-1] |= self.solid
        x[:, 0] |= closed[0]
        x[:, -1] |= closed[1]
        y = np.zeros((h + 1, w), bool)
        y[1:] |= self.solid
        y[:-1] |= self.solid
        y[0] |= closed[2]
        y[-1] |= closed[3]
        return x, y

    def faces(self, which):
        """World positions (..., 2) of the x faces ("u") or the y faces ("v")."""
        h, w = self.shape
        dx, dy = self.cell
        if which == "u":
            x, y = np.meshgrid(np.arange(w + 1) * dx, (np.arange(h) + 0.5) * dy)
        else:
            x, y = np.meshgrid((np.arange(w) + 0.5) * dx, np.arange(h + 1) * dy)
        return np.stack([x, y], -1)

    def origin(self, which):
        """The world position of grid ``which``'s first value ("u", "v" or "p")."""
        dx, dy = self.cell
        return {"u": (0.0, 0.5 * dy), "v": (0.5 * dx, 0.0), "p": (0.5 * dx, 0.5 * dy)}[which]


def sample(air, field, which, points):
    """Bilinear ``field`` of grid ``which`` at world ``points`` (..., 2), edge values extended."""
    h, w = field.shape
    g = (points - np.asarray(air.origin(which))) / np.asarray(air.cell)
    i = np.floor(g)
    t = g - i
    i = i.astype(int)

    def at(ox, oy):
        return field[np.clip(i[..., 1] + oy, 0, h - 1), np.clip(i[..., 0] + ox, 0, w - 1)]
    tx, ty = t[..., 0], t[..., 1]
    return ((at(0, 0) * (1 - tx) + at(1, 0) * tx) * (1 - ty)
            + (at(0, 1) * (1 - tx) + at(1, 1) * tx) * ty)


def wind_at(air, u, v, points):
    return np.stack([sample(air, u, "u", points), sample(air, v, "v", points)], -1)


def advect(air, u, v, dt):
    out = []
    for which, own, blocked in zip("uv", (u, v), air.blocked()):
        x = air.faces(which)
        value = sample(air, own, which, x - dt * wind_at(air, u, v, x))
        out.append(np.where(blocked, 0.0, value))
    return out


def maccormack(air, u, v, dt):
    """Ahead (forward advection), behind (the ahead field carried back), and the correction
    ahead + (own - behind) / 2 limited to the four values the backtrace lands among."""
    out = []
    for which, own, blocked in zip("uv", (u, v), air.blocked()):
        x = air.faces(which)
        wind = wind_at(air, u, v, x)
        ahead = np.where(blocked, 0.0, sample(air, own, which, x - dt * wind))
        behind = np.where(blocked, 0.0, sample(air, ahead, which, x + dt * wind))
        h, w = own.shape
        # the backtrace in cells: the face's own index less the step's move (exact when still)
        index = np.stack(np.meshgrid(np.arange(w), np.arange(h)), -1)
        i = np.floor(index - dt * wind / np.asarray(air.cell)).astype(int)
        corners = [own[np.clip(i[..., 1] + oy, 0, h - 1), np.clip(i[..., 0] + ox, 0, w - 1)]
                   for ox, oy in ((0, 0), (1, 0), (0, 1), (1, 1))]
        value = np.clip(ahead + 0.5 * (own - behind), np.min(corners, 0), np.max(corners, 0))
        out.append(np.where(blocked, 0.0, value))
    return out


def force(air, u, v, dt, wind, gusts, step):
    f = np.asarray(wind) * (1 + gusts[0] * np.sin(2 * np.pi * step * dt / gusts[1]))
    xb, yb = air.blocked()
    return np.where(xb, 0.0, u + dt * f[0]), np.where(yb, 0.0, v + dt * f[1])


def _tangent(kind, speed, t):
    if kind in (SLIP, OPEN):
        return t
    if kind == NOSLIP:
        return -t
    return 2 * speed - t


def viscosity(air, u, v, dt, nu, iterations):
    """Jacobi iterations of (1 + 2ax + 2ay) w - ax (l + r) - ay (d + t) = held, per face grid:
    beyond the walls a component runs along, their tangential ghost; beyond the others, the
    last face's value."""
    dx, dy = air.cell
    ax, ay = nu * dt / dx ** 2, nu * dt / dy ** 2
    out = []
    for which, own, blocked in zip("uv", (u, v), air.blocked()):
        held = own
        for _ in range(iterations):
            q = np.pad(own, 1, mode="edge")
            if which == "u":  # past the bottom and top, u runs along the wall
                q[0, 1:-1] = _tangent(air.walls[2], air.speeds[2], own[0])
                q[-1, 1:-1] = _tangent(air.walls[3], air.speeds[3], own[-1])
            else:  # past the left and right, v does
                q[1:-1, 0] = _tangent(air.walls[0], air.speeds[0], own[:, 0])
                q[1:-1, -1] = _tangent(air.walls[1], air.speeds[1], own[:, -1])
            around = ax * (q[1:-1, 2:] + q[1:-1, :-2]) + ay * (q[2:, 1:-1] + q[:-2, 1:-1])
            own = np.where(blocked, 0.0, (held + around) / (1 + 2 * ax + 2 * ay))
        out.append(own)
    return out


def divergence(air, u, v):
    dx, dy = air.cell
    div = (u[:, 1:] - u[:, :-1]) / dx + (v[1:] - v[:-1]) / dy
    return np.where(air.solid, 0.0, div)


def pressure_neighbours(air, p):
    """(right, left, up, down) pressures of each cell's neighbours (H, W): p's own across a
    closed wall or at an obstacle, -p across an open side."""
    h, w = air.shape
    out = []
    for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        n = np.zeros_like(p)
        dst = (slice(max(-dy, 0), h + min(-dy, 0)), slice(max(-dx, 0), w + min(-dx, 0)))
        src = (slice(max(dy, 0), h + min(dy, 0)), slice(max(dx, 0), w + min(dx, 0)))
        n[dst] = np.where(air.solid[src], p[dst], p[src])
        if dx:
            col, side = (w - 1, 1) if dx > 0 else (0, 0)
            n[:, col] = -p[:, col] if air.walls[side] == OPEN else p[:, col]
        else:
            row, side = (h - 1, 3) if dy > 0 else (0, 2)
            n[row] = -p[row] if air.walls[side] == OPEN else p[row]
        out.append(n)
    return out


def jacobi(air, p, div, iterations):
    """Jacobi iterations of (l + r - 2p)/dx^2 + (d + t - 2p)/dy^2 = div."""
    dx, dy = air.cell
    kx, ky = 1 / dx ** 2, 1 / dy ** 2
    for _ in range(iterations):
        r, l, t, b = pressure_neighbours(air, p)
        p = np.where(air.solid, 0.0, (kx * (r + l) + ky * (t + b) - div) / (2 * kx + 2 * ky))
    return p


def project(air, u, v, p):
    """The faces' velocities less the pressure difference across them (beyond an open side the
    ghost -p); blocked faces stay 0."""
    dx, dy = air.cell
    xb, yb = air.blocked()
    left = np.concatenate([-p[:, :1], p], 1)  # the cell before each x face
    right = np.concatenate([p, -p[:, -1:]], 1)  # and after it
    below = np.concatenate([-p[:1], p], 0)
    above = np.concatenate([p, -p[-1:]], 0)
    return (np.where(xb, 0.0, u - (right - left) / dx),
            np.where(yb, 0.0, v - (above - below) / dy))


def centres(air, u, v):
    """The wind at the cell centres (H, W, 2): the mean of each cell's faces."""
    wind = np.stack([(u[:, 1:] + u[:, :-1]) / 2, (v[1:] + v[:-1]) / 2], -1)
    return np.where(air.solid[..., None], 0.0, wind)


def poisson_matrix(air):
    """The sparse matrix of the pressure's discrete Poisson problem over the fluid cells (the
    stencil the Jacobi iterations solve, ghosts included), and the fluid cells' indices."""
    from scipy import sparse

    h, w = air.shape
    dx, dy = air.cell
    kx, ky = 1 / dx ** 2, 1 / dy ** 2
    fluid = np.flatnonzero(~air.solid.ravel())
    index = -np.ones(h * w, int)
    index[fluid] = np.arange(len(fluid))
    rows, cols, vals = [], [], []
    for k, cell in enumerate(fluid):
        y, x = divmod(cell, w)
        diagonal = -2 * kx - 2 * ky
        for ox, oy, kk in ((1, 0, kx), (-1, 0, kx), (0, 1, ky), (0, -1, ky)):
            nx, ny = x + ox, y + oy
            if not (0 <= nx < w and 0 <= ny < h):
                side = (1 if ox > 0 else 0) if ox else (3 if oy > 0 else 2)
                diagonal += -kk if air.walls[side] == OPEN else kk
            elif air.solid[ny, nx]:
                diagonal += kk
            else:
                rows.append(k)
                cols.append(index[ny * w + nx])
                vals.append(kk)
        rows.append(k)
        cols.append(k)
        vals.append(diagonal)
    return sparse.csr_matrix((vals, (rows, cols)), shape=(len(fluid),) * 2), fluid


def exact_pressure(air, div):
    """The pressure solving the discrete Poisson problem exactly (scipy's sparse solve)."""
    from scipy.sparse.linalg import spsolve

    matrix, fluid = poisson_matrix(air)
    p = np.zeros(air.shape)
    p.ravel()[fluid] = spsolve(matrix.tocsc(), div.ravel()[fluid])
    return p


def step(air, u, v, p, dt, wind, gusts, step_number, iterations, warm=1.0, nu=0.0,
         viscosity_iterations=20, advection="semi-lagrangian"):
    """One fluid step: (u, v, divergence, pressure) after it."""
    u, v = (advect if advection == "semi-lagrangian" else maccormack)(air, u, v, dt)
    u, v = force(air, u, v, dt, wind, gusts, step_number)
    if nu > 0:
        u, v = viscosity(air, u, v, dt, nu, viscosity_iterations)
    div = divergence(air, u, v)
    p = jacobi(air, warm * p, div, iterations)
    u, v = project(air, u, v, p)
    return u, v, div, p
