"""float64 twin of a rigid object's turn: ``rotate`` of ``lib/field3d.glsl`` (Rodrigues)."""

import numpy as np


def rotation(axis, angle):
    """3x3 rotation about a unit axis (Rodrigues), the twin of ``rotate``."""
    k = np.asarray(axis, float)
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) * np.cos(angle) + cross * np.sin(angle) + np.outer(k, k) * (1 - np.cos(angle))
