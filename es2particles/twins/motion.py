"""float64 twin of a moving object's rigid motion, ``lib/motion.glsl`` (the one place the
formula is written in GLSL); :class:`~es2particles.frame.motion.Motion` is its data."""

import numpy as np


def rotation(axis, angle):
    """3x3 rotation about a unit axis (Rodrigues), the twin of ``motion_rotate``."""
    k = np.asarray(axis, float)
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) * np.cos(angle) + cross * np.sin(angle) + np.outer(k, k) * (1 - np.cos(angle))


def pose(motion, t, drag=(0.0, 0.0, 0.0)):
    """(centre (3,), rotation (3, 3), velocity (3,)) of ``motion`` at ``t`` seconds, the twin of
    ``motion_pose``: where its pivot is, how it is turned, and how fast the pivot moves;
    ``drag``: a hand's displacement of the rest offset."""
    centre = (np.asarray(motion.pivot, float) + np.asarray(motion.offset, float)
              + np.asarray(drag, float))
    velocity = np.zeros(3)
    if motion.period > 0:
        w = 2 * np.pi / motion.period
        amplitude = np.asarray(motion.sway, float)
        centre = centre + amplitude * np.sin(w * t)
        velocity = amplitude * w * np.cos(w * t)
    return centre, rotation(motion.axis, motion.rate * t), velocity


def matrix(motion, t, drag=(0.0, 0.0, 0.0)):
    """The 4x4 model matrix (column vectors) taking the rest pose to ``motion``'s at ``t``:
    ``motion_place`` as a matrix."""
    centre, r, _ = pose(motion, t, drag)
    m = np.eye(4)
    m[:3, :3] = r * motion.scale
    m[:3, 3] = centre - m[:3, :3] @ np.asarray(motion.pivot, float)
    return m
