"""Pairs of points within a distance, in float64 numpy (no scipy): a cell list of side h, every
pair of points in the same or neighbouring cells tested. What a saved state's densities are
recomputed with (the liquid's ``--save-state``), independent of the GPU's neighbour grid."""

import numpy as np


def pairs_within(points, h):
    """(i, j, r) of every unordered pair i < j of ``points`` (n, 2) or (n, 3) with distance
    r < h."""
    import itertools

    x = np.asarray(points, np.float64)
    n, dims = x.shape
    cells = np.floor((x - x.min(axis=0)) / h).astype(np.int64) + 1  # a cell of margin
    sides = (cells.max(axis=0) + 2) if n else np.full(dims, 3)
    strides = np.cumprod(np.concatenate([[1], sides[:-1]]))
    key = cells @ strides
    order = np.argsort(key, kind="stable")
    sorted_keys = key[order]
    out = []
    for offset in itertools.product((-1, 0, 1), repeat=dims):
        wanted = key + np.asarray(offset) @ strides
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
    r = np.linalg.norm(x[j] - x[i], axis=1) if len(i) else np.zeros(0)
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
