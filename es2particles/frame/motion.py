"""A moving object's rigid motion as data.

A scene whose object moves (a spinning or swaying obstacle, the smoke's sphere) declares its
:class:`Motion`; its passes and the frame plan's moving meshes take :meth:`Motion.uniforms`,
and ``lib/motion.glsl`` places the object at each pass's time: the formula is written once in
GLSL (and in its float64 twin, ``twins/motion.py``). Both executors, EGL's and the page's
(``export/webpage/executor.js``), only give it the time and a hand's drag.
"""

from dataclasses import dataclass

from ..twins import motion as twin


@dataclass(frozen=True)
class Motion:
    """The rigid motion of a scene's moving object (and its meshes, ``Mesh.moves``), as data:
    ``lib/motion.glsl`` evaluates it where the object is used (the physics, the meshes' vertex
    shader), on EGL and in the page alike, and ``twins/motion.py`` is its float64 twin. ``t =
    step * dt`` seconds after the start, a point p of the rest pose goes to

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

    def uniforms(self, drag=(0.0, 0.0, 0.0)):
        """``lib/motion.glsl``'s uniforms; ``drag``: a hand's displacement of the rest offset."""
        return {"u_motion_pivot": (*map(float, self.pivot), float(self.scale)),
                "u_motion_spin": (*map(float, self.axis), float(self.rate)),
                "u_motion_sway": (*map(float, self.sway), float(self.period)),
                "u_motion_offset": tuple(float(o + d) for o, d in zip(self.offset, drag))}

    def matrix(self, step, drag=(0.0, 0.0, 0.0)):
        """The model matrix (4x4, column vectors) after ``step`` steps (the float64 twin)."""
        return twin.matrix(self, step * self.dt, drag)
