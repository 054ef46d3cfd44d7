"""Cameras for 3D scenes: look-at, perspective or orthographic projection, and camera paths.

Pure numpy, no GL. World units: y is up and the floor is the plane y = 0. ``Camera.matrix`` is
what the shaders get (``u_view_projection``, column-major as GL wants it), and ``Camera.project``
is its float64 twin: the pixel where a point lands and its eye distance, so tests can check a
rendered sprite's place and size without trusting the GPU.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range


def _unit(v, name):
    v = np.asarray(v, dtype=np.float64)
    n = np.linalg.norm(v)
    if not n > 0:
        raise ParameterError(f"camera: {name} must not be zero")
    return v / n


@dataclass(frozen=True)
class Camera:
    """A camera at ``eye`` looking at ``target``, ``up`` roughly up.

    ``fov`` is the vertical field of view in degrees (perspective); ``ortho`` a half-height in
    world units makes the projection orthographic instead. ``near``/``far`` clip depth.
    """

    eye: tuple = (0.0, 2.0, 6.0)
    target: tuple = (0.0, 1.0, 0.0)
    up: tuple = (0.0, 1.0, 0.0)
    fov: float = 45.0
    near: float = 0.1
    far: float = 100.0
    ortho: float = None

    def __post_init__(self):
        for name in ("eye", "target", "up"):
            value = tuple(float(check_range(f"camera {name}", v)) for v in getattr(self, name))
            if len(value) != 3:
                raise ParameterError(f"camera {name} must be three numbers, got {value}")
            object.__setattr__(self, name, value)
        check_range("camera fov", self.fov, 1.0, 179.0)
        check_range("camera near", self.near, 1e-6, self.far)
        check_range("camera far", self.far, self.near, 1e9)
        if not self.far > self.near:
            raise ParameterError(f"camera far must be greater than near, got near {self.near} "
                                 f"and far {self.far}")
        if self.ortho is not None:
            check_range("camera ortho half-height", self.ortho, 1e-6, 1e9)
        forward = _unit(np.subtract(self.target, self.eye), "target - eye")
        if abs(np.dot(forward, _unit(self.up, "up"))) > 1 - 1e-9:
            raise ParameterError("camera: up must not be parallel to the viewing direction")

    @property
    def forward(self):
        """The unit viewing direction, target - eye normalised."""
        return _unit(np.subtract(self.target, self.eye), "target - eye")

    def view(self):
        """World to eye space, 4x4 (row-major numpy)."""
        eye = np.asarray(self.eye)
        f = self.forward
        s = _unit(np.cross(f, self.up), "side")
        u = np.cross(s, f)
        m = np.eye(4)
        m[0, :3], m[1, :3], m[2, :3] = s, u, -f
        m[:3, 3] = -m[:3, :3] @ eye
        return m

    def focal_pixels(self, height):
        """Pixels a unit length covers at depth 1 in a viewport ``height`` pixels tall
        (perspective): height / 2 / tan(fov / 2)."""
        return height / 2 / np.tan(np.radians(self.fov) / 2)

    def projection(self, aspect):
        """Eye to clip space, 4x4, for a viewport of width / height ``aspect``."""
        n, f = self.near, self.far
        m = np.zeros((4, 4))
        if self.ortho is None:
            t = 1 / np.tan(np.radians(self.fov) / 2)
            m[0, 0], m[1, 1] = t / aspect, t
            m[2, 2], m[2, 3] = (f + n) / (n - f), 2 * f * n / (n - f)
            m[3, 2] = -1
        else:
            h = self.ortho
            m[0, 0], m[1, 1] = 1 / (h * aspect), 1 / h
            m[2, 2], m[2, 3] = -2 / (f - n), -(f + n) / (f - n)
            m[3, 3] = 1
        return m

    def matrix(self, aspect):
        """Projection times view, 4x4 row-major float64."""
        return self.projection(aspect) @ self.view()

    def uniform(self, aspect):
        """``matrix`` as the 16 floats of a GLSL mat4 (column-major)."""
        return tuple(float(v) for v in self.matrix(aspect).T.ravel())

    def project(self, points, size):
        """float64 twin of the vertex shader: for world points (N, 3) and an image (w, h), the
        pixel coordinates (N, 2) (x right, y down from the top row), the eye distance (N,) and
        whether each point is in front of the camera and inside the depth range."""
        w, h = size
        p = np.concatenate([np.asarray(points, float), np.ones((len(points), 1))], 1)
        clip = p @ self.matrix(w / h).T
        ndc = clip[:, :3] / clip[:, 3:4]
        pixels = np.stack([(ndc[:, 0] + 1) / 2 * w, (1 - ndc[:, 1]) / 2 * h], 1)
        distance = np.linalg.norm(np.asarray(points, float) - self.eye, axis=1)
        visible = (clip[:, 3] > 0) & (np.abs(ndc[:, 2]) <= 1)
        return pixels, distance, visible


def looking_at(target, direction, distance, fov=45.0):
    """A camera ``distance`` from ``target`` along ``direction`` (any length), looking at it;
    its near and far planes from the distance (a hundredth, four times)."""
    direction = np.asarray(direction, float) / np.linalg.norm(direction)
    eye = np.asarray(target, float) + distance * direction
    return Camera(eye=tuple(map(float, eye)), target=tuple(map(float, target)), fov=fov,
                  near=0.01 * distance, far=4.0 * distance)


def orbit(frame, frames, radius=6.0, height=2.5, target=(0.0, 1.0, 0.0), fov=45.0, turns=1.0,
          phase=0.0):
    """The camera of frame ``frame`` of ``frames`` on a circle of ``radius`` around ``target``
    at ``height``: ``turns`` full turns over the animation, starting ``phase`` radians from +z
    towards +x."""
    angle = phase + 2 * np.pi * turns * (frame / max(frames, 1))
    eye = (target[0] + radius * np.sin(angle), height, target[2] + radius * np.cos(angle))
    return Camera(eye=eye, target=target, fov=fov)


def keyframes(cameras, frame, frames):
    """The camera of frame ``frame`` of ``frames`` on a path through ``cameras`` (a list of
    Camera, spread evenly over the animation): eye, target and field of view interpolated
    linearly between neighbouring keys."""
    if not cameras:
        raise ParameterError("keyframes needs at least one camera")
    if len(cameras) == 1 or frames <= 1:
        return cameras[0]
    t = frame / (frames - 1) * (len(cameras) - 1)
    k = min(int(t), len(cameras) - 2)
    a, b, u = cameras[k], cameras[k + 1], t - k
    mix = lambda p, q: tuple((1 - u) * np.asarray(p) + u * np.asarray(q))  # noqa: E731
    return Camera(eye=mix(a.eye, b.eye), target=mix(a.target, b.target), up=a.up,
                  fov=(1 - u) * a.fov + u * b.fov, near=a.near, far=a.far, ortho=a.ortho)
