"""Clavet, Beaudoin and Poulin 2005 ("Particle-based Viscoelastic Fluid Simulation"), 2D, in
float64 with the paper's own sequential loops: the reference the liquid scene's GPU gather form is
measured against (docs/scenes/liquid.md, tests/test_liquid.py). Written from the paper's
algorithms 1, 2 and 5 (viscosity impulses, prediction, double density relaxation, velocities from
the position change), with the scene's walls and obstacle circle; neighbours from scipy's k-d
tree (each loop reads the positions as the loop has left them, as the paper's does).

    python tests/clavet_reference.py   # prints the settled state's measures for 900 particles
"""

import numpy as np
from scipy.spatial import cKDTree


def step(x, v, p, h, dt):
    """One step of the paper's algorithm 1 for positions ``x`` and velocities ``v`` (n, 2),
    parameters ``p`` (LiquidParams), interaction radius ``h``, time step ``dt``; returns new
    (x, v)."""
    k, k_near = p.stiffness * h, p.near_stiffness * h  # as the scene scales them
    sigma, beta = p.viscosity
    v = v + dt * np.asarray(p.gravity, float)
    pairs = cKDTree(x).query_pairs(h, output_type="ndarray")
    for i, j in pairs:  # algorithm 5: each pair once, in order, seeing the impulses before it
        d = x[j] - x[i]
        r = np.hypot(*d)
        if 0 < r < h:
            n = d / r
            u = (v[i] - v[j]) @ n
            if u > 0:
                impulse = dt * (1 - r / h) * (sigma * u + beta * u * u) * n
                v[i] -= impulse / 2
                v[j] += impulse / 2
    previous = x.copy()
    x = x + dt * v
    tree = cKDTree(x)
    near = tree.query_ball_point(x, h)
    for i in range(len(x)):  # algorithm 2: each particle in turn, moving its neighbours
        js = np.asarray([j for j in near[i] if j != i], dtype=np.int64)
        if not len(js):
            continue
        d = x[js] - x[i]
        r = np.hypot(d[:, 0], d[:, 1])
        inside = (r < h) & (r > 0)
        js, d, r = js[inside], d[inside], r[inside]
        a = 1 - r / h
        rho, rho_near = (a * a).sum(), (a ** 3).sum()
        pressure, pressure_near = k * (rho - p.rest_density), k_near * rho_near
        moves = (dt * dt * (pressure * a + pressure_near * a * a) / r)[:, None] * d
        x[js] += moves / 2
        x[i] -= moves.sum(axis=0) / 2
    ox, oy, radius = p.obstacle
    c = x - (ox, oy)
    r = np.hypot(c[:, 0], c[:, 1])
    inside = r < radius
    x[inside] = (ox, oy) + c[inside] / np.maximum(r[inside], 1e-300)[:, None] * radius
    x = np.clip(x, 0.0, np.asarray(p.box, float))
    return x, (x - previous) / dt


def densities(x, h):
    """Each particle's density and near density (float64) over the others within h."""
    pairs = cKDTree(x).query_pairs(h, output_type="ndarray")
    d = x[pairs[:, 1]] - x[pairs[:, 0]]
    a = 1 - np.hypot(d[:, 0], d[:, 1]) / h
    out = np.zeros((len(x), 2))
    for column, power in ((0, 2), (1, 3)):
        np.add.at(out[:, column], pairs[:, 0], a ** power)
        np.add.at(out[:, column], pairs[:, 1], a ** power)
    return out


def measures(x, h, p):
    """(mean density of the particles deeper than 2 h below the surface, relative to rho0; the
    surface's height: the mean of each column of width h's highest particle; its flatness: their
    standard deviation), in box units."""
    rho = densities(x, h)[:, 0]
    columns = np.floor(x[:, 0] / h).astype(int)
    tops = np.array([x[columns == c, 1].max() for c in np.unique(columns)])
    height = float(np.median(tops))
    deep = x[:, 1] < height - 2 * h
    return float(rho[deep].mean() / p.rest_density) if deep.any() else float("nan"), height, \
        float(tops.std())


if __name__ == "__main__":
    import sys
    import time

    sys.path.insert(0, ".")
    from es2particles.scenes.liquid import Liquid

    scene = Liquid()
    n = 900
    h = scene.radius_for(n)
    rng = np.random.default_rng(1)
    x = scene.start(n, rng)["position"]
    v = np.zeros_like(x)
    start = time.time()
    for s in range(1, 601):
        x, v = step(x, v, scene.params, h, scene.dt_for(n))
        if s % 60 == 0:
            print(s, [round(m, 3) for m in measures(x, h, scene.params)],
                  f"|v| {np.hypot(v[:, 0], v[:, 1]).mean():.3f}", f"{time.time() - start:.0f} s")
