"""The Clifford attractor: x' = sin(a y) + c cos(a x), y' = sin(b x) + d cos(b y). The map sends
the plane into [-1 - |c|, 1 + |c|] x [-1 - |d|, 1 + |d|], the position range and the view.
GLSL: attractors/clifford.frag."""

import numpy as np

from .attractor import Attractor, AttractorParams


def clifford_map(p, k, iterations=1):
    """numpy twin of ``attractor_map`` in ``attractors/clifford.frag``."""
    a, b, c, d = k
    for _ in range(iterations):
        x, y = p[..., 0], p[..., 1]
        p = np.stack([np.sin(a * y) + c * np.cos(a * x), np.sin(b * x) + d * np.cos(b * y)], axis=-1)
    return p


CliffordParams = AttractorParams.with_coefficients("CliffordParams", (-1.4, 1.6, 1.0, 0.7))


class Clifford(Attractor):
    """The Clifford attractor (Clifford Pickover's map)."""

    name = "clifford"
    shader = "attractors/clifford.frag"
    Params = CliffordParams
    map = staticmethod(clifford_map)

    @classmethod
    def bounds(cls, k):
        x, y = 1 + abs(k[2]), 1 + abs(k[3])
        return (-x, -y, x, y)
