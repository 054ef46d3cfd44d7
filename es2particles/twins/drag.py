"""numpy twin of ``lib/drag.glsl``: linear drag integrated exactly over a step."""

import numpy as np


def exact_drag(k, h):
    """(decay, gain) with which a step h of v' = a - k v takes v to v * decay + a * gain; h may
    be an array (one step per particle)."""
    kh = k * np.asarray(h, dtype=np.float64)
    decay = np.exp(-kh)
    return decay, np.where(kh < 1e-3, h * (1 - 0.5 * kh), (1 - decay) / max(k, 1e-300))
