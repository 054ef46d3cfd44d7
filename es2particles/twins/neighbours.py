"""Pairs of points within a distance, in float64 numpy (no scipy): a cell list of side h, every
pair of points in the same or neighbouring cells tested. What a saved state's densities are
recomputed with (the liquid's ``--save-state``), independent of the GPU's neighbour grid."""

import numpy as np


def pairs_within(points, h):
    """(i, j, r) of every unordered pair i < j of ``points`` (n, 2) with distance r < h."""
    x = np.asarray(points, np.float64)
    n = len(x)
    cells = np.floor((x - x.min(axis=0)) / h).astype(np.int64)
    width = int(cells[:, 0].max()) + 3 if n else 3
    key = (cells[:, 1] + 1) * width + cells[:, 0] + 1
    order = np.argsort(key, kind="stable")
    sorted_keys = key[order]
    out = []
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            wanted = key + dy * width + dx
            lo = np.searchsorted(sorted_keys, wanted, "left")
            hi = np.searchsorted(sorted_keys, wanted, "right")
            counts = hi - lo
            i = np.repeat(np.arange(n), counts)
            starts = np.repeat(lo - np.cumsum(counts) + counts, counts)
            j = order[np.arange(counts.sum()) + starts]
            keep = i < j
            out.append((i[keep], j[keep]))
    i = np.concatenate([a for a, _ in out])
    j = np.concatenate([b for _, b in out])
    r = np.hypot(*(x[j] - x[i]).T) if len(i) else np.zeros(0)
    inside = r < h
    return i[inside], j[inside], r[inside]


def clavet_densities(points, h):
    """Clavet 2005's density sum (1 - r/h)^2 and near density sum (1 - r/h)^3 of each point
    over the others within h (float64, (n,) each)."""
    i, j, r = pairs_within(points, h)
    a = 1.0 - r / h
    n = len(points)
    density = np.bincount(i, a ** 2, n) + np.bincount(j, a ** 2, n)
    near = np.bincount(i, a ** 3, n) + np.bincount(j, a ** 3, n)
    return density, near
