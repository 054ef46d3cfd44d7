"""A moving object's rigid motion as data, and model matrices as GLSL takes them.

A scene whose object moves (a spinning or swaying obstacle, the smoke's sphere) declares its
:class:`Motion`; the frame plan carries it, and both executors evaluate it each frame: the EGL
executor here in float64, the WebGL page in its own (``export/webpage/executor.js``).
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..twins.motion import rotation

IDENTITY = tuple(float(v) for v in np.eye(4).ravel())


def model_uniform(model):
    """A model matrix (4x4 numpy, column vectors: world = model @ [x, y, z, 1]) as the 16 floats
    of a GLSL mat4, column-major like ``Camera.uniform``. Only rotation, uniform scale and
    translation: the mesh shader turns normals by the same matrix, right only for those."""
    try:
        m = np.asarray(model, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"model must be a 4x4 matrix, got {model!r}") from None
    if m.shape != (4, 4) or not np.all(np.isfinite(m)):
        raise ParameterError(f"model must be a finite 4x4 matrix, got shape {m.shape}")
    gram = m[:3, :3].T @ m[:3, :3]
    scale = np.trace(gram) / 3  # the squared scale
    if not (scale > 0 and np.allclose(gram, scale * np.eye(3), rtol=0, atol=1e-6 * scale)
            and np.array_equal(m[3], [0, 0, 0, 1])):
        raise ParameterError("model must be a rotation, a uniform scale and a translation "
                             "(last row 0 0 0 1): normals are turned by the same matrix")
    return tuple(float(v) for v in m.T.ravel())


@dataclass(frozen=True)
class Motion:
    """The rigid motion of a scene's moving object (and its meshes, ``Mesh.moves``), as data, so
    both executors (EGL and the WebGL page) evaluate it: ``t = step * dt`` seconds after the
    start, a point p of the rest pose goes to

        pivot + offset + sway sin(2 pi t / period) + R(axis, rate t) scale (p - pivot)

    (``rate`` in radians per second about the unit ``axis``; no sway where ``period`` is 0)."""

    dt: float
    pivot: tuple = (0.0, 0.0, 0.0)
    offset: tuple = (0.0, 0.0, 0.0)
    axis: tuple = (0.0, 0.0, 1.0)
    rate: float = 0.0
    sway: tuple = (0.0, 0.0, 0.0)
    period: float = 0.0
    scale: float = 1.0

    def matrix(self, step):
        """The model matrix (4x4, column vectors) after ``step`` steps."""
        t = step * self.dt
        m = np.eye(4)
        m[:3, :3] = rotation(self.axis, self.rate * t) * self.scale
        sway = (np.asarray(self.sway, float) * np.sin(2 * np.pi / self.period * t)
                if self.period > 0 else np.zeros(3))
        pivot = np.asarray(self.pivot, float)
        m[:3, 3] = np.asarray(self.offset, float) + pivot + sway - m[:3, :3] @ pivot
        return m

    def uniform(self, step):
        """:meth:`matrix` as the 16 floats of a GLSL mat4."""
        return model_uniform(self.matrix(step))
