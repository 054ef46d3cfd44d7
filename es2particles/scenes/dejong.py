"""The Peter de Jong attractor of the ES 2.0 article: x' = sin(a y) - cos(b x), y' = sin(c x) -
cos(d y). The map sends the plane into [-2, 2]^2, the position range, so +2 sits on the top code
of the packed range (and stays there). GLSL: attractors/dejong.frag."""

import numpy as np

from .attractor import Attractor, AttractorParams

ARTICLE_COEFFICIENTS = (1.4, -2.3, 2.4, -2.1)


def dejong_map(p, k, iterations=1):
    """numpy twin of ``attractor_map`` in ``attractors/dejong.frag``."""
    a, b, c, d = k
    for _ in range(iterations):
        x, y = p[..., 0], p[..., 1]
        p = np.stack([np.sin(a * y) - np.cos(b * x), np.sin(c * x) - np.cos(d * y)], axis=-1)
    return p


DeJongParams = AttractorParams.with_coefficients("DeJongParams", ARTICLE_COEFFICIENTS)


class DeJong(Attractor):
    """The Peter de Jong attractor (the ES 2.0 article's scene)."""

    name = "dejong"
    shader = "attractors/dejong.frag"
    Params = DeJongParams
    map = staticmethod(dejong_map)

    @classmethod
    def bounds(cls, k):
        return (-2.0, -2.0, 2.0, 2.0)
