"""What a person's keys and mouse do to a scene, as plain numbers: no window, no GL.

- :class:`ViewCamera`: the camera a person moves. It starts as the scene's camera. The mouse
  orbits it about the camera's up axis through the target and the wheel moves it nearer or
  farther, as the WebGL page does (``export/webpage/executor.js``: 0.01 radian a pixel, the
  elevation within +-1.45 radians, the distance within [0.5, 50] m). The keys move it as the JOGL
  fountain's KeyCamera does: turn on the spot, move along the floor, rise and sink.
- :func:`hit_sphere` and :func:`dragged_centre`: a scene's grip (the smoke's sphere) found under
  the pointer by a ray from the camera, and moved over the floor by a drag.
- :class:`Bindings`: which key does what; a TOML file can change them (``--keys``).

Every operation is a float64 formula a test can check on its own.
"""

import math
from dataclasses import replace

import numpy as np

from ..errors import ParameterError

ORBIT_RATE = 0.01  # radians a pixel of drag (the page takes these four with its camera)
ELEVATION_LIMIT = 1.45  # radians from the level, either way (the page's)
DISTANCE_LIMITS = (0.5, 50.0)  # metres from the target (the page's)
WHEEL_STEP = 0.1  # a wheel notch scales the distance by exp(0.1) (the page: a notch is deltaY 100)
TURN_STEP = math.radians(5.0)  # a key press turns the camera 5 degrees on the spot
MOVE_STEP = 0.25  # and moves it a quarter metre along the floor
RISE_STEP = 0.1  # or raises it a tenth of a metre


def _unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def rotate(v, axis, angle):
    """``v`` turned by ``angle`` radians about the unit ``axis`` (Rodrigues; right-handed)."""
    v, k = np.asarray(v, float), _unit(axis)
    c, s = math.cos(angle), math.sin(angle)
    return v * c + np.cross(k, v) * s + k * np.dot(k, v) * (1 - c)


class ViewCamera:
    """The live camera of a 3D scene, starting as ``camera`` (a
    :class:`~es2particles.render.camera.Camera`); :meth:`camera` is the camera now."""

    def __init__(self, camera):
        self.start = camera
        self.eye = np.asarray(camera.eye, float)
        self.target = np.asarray(camera.target, float)
        self.up = _unit(camera.up)
        self.distance0 = float(np.linalg.norm(self.eye - self.target))

    def camera(self):
        # An orthographic camera's half-height follows the distance, as the wheel zooms it.
        ortho = None if self.start.ortho is None else \
            self.start.ortho * self.distance / self.distance0
        return replace(self.start, eye=tuple(self.eye), target=tuple(self.target), ortho=ortho)

    @property
    def distance(self):
        return float(np.linalg.norm(self.eye - self.target))

    # -- the mouse (the page's) ------------------------------------------------------------------

    def orbit(self, dx, dy):
        """A drag of (dx, dy) pixels: the eye turns about the up axis through the target by
        -0.01 dx radians and climbs by 0.01 dy radians of elevation (kept within +-1.45)."""
        offset = self.eye - self.target
        r = np.linalg.norm(offset)
        height = float(np.dot(offset, self.up))
        level = offset - height * self.up
        if np.linalg.norm(level) < 1e-9 * r:  # looking along the up axis: any side will do
            level = np.cross(self.up, [1.0, 0, 0] if abs(self.up[0]) < 0.9 else [0, 0, 1.0])
        level = rotate(_unit(level), self.up, -ORBIT_RATE * dx)
        elevation = math.asin(max(-1.0, min(1.0, height / r))) + ORBIT_RATE * dy
        elevation = max(-ELEVATION_LIMIT, min(ELEVATION_LIMIT, elevation))
        self.eye = self.target + r * (math.cos(elevation) * level + math.sin(elevation) * self.up)

    def zoom(self, notches):
        """``notches`` of the wheel (positive: towards the scene): the distance to the target
        times exp(-0.1 notches), kept within [0.5, 50] m."""
        offset = self.eye - self.target
        r = np.linalg.norm(offset)
        new = min(max(r * math.exp(-WHEEL_STEP * notches), DISTANCE_LIMITS[0]),
                  DISTANCE_LIMITS[1])
        self.eye = self.target + offset * (new / r)

    # -- the keys (the JOGL KeyCamera's) ---------------------------------------------------------

    def turn(self, presses):
        """Turn on the spot: the target swings about the up axis through the eye, 5 degrees a
        press (positive: to the left, counter-clockwise seen from above)."""
        self.target = self.eye + rotate(self.target - self.eye, self.up, TURN_STEP * presses)

    def move(self, presses):
        """Walk: eye and target move a quarter metre a press along the viewing direction
        projected on the floor (positive: forwards)."""
        forward = self.target - self.eye
        level = forward - np.dot(forward, self.up) * self.up
        if np.linalg.norm(level) < 1e-12:  # looking straight down or up: no way along the floor
            return
        step = MOVE_STEP * presses * _unit(level)
        self.eye, self.target = self.eye + step, self.target + step

    def rise(self, presses):
        """Eye and target move a tenth of a metre a press along the up axis (positive: up)."""
        step = RISE_STEP * presses * self.up
        self.eye, self.target = self.eye + step, self.target + step

    # -- pointing ----------------------------------------------------------------------------------

    def ray(self, pixel, size):
        """The ray (origin, unit direction) through ``pixel`` (x right, y down from the top row,
        pixel centres at +0.5) of a picture of ``size`` (w, h): the inverse of
        :meth:`~es2particles.render.camera.Camera.project`."""
        cam = self.camera()
        w, h = size
        x = (2 * pixel[0] / w - 1) * w / h
        y = 1 - 2 * pixel[1] / h
        f = cam.forward
        s = _unit(np.cross(f, cam.up))
        u = np.cross(s, f)
        if cam.ortho is None:
            t = math.tan(math.radians(cam.fov) / 2)
            return np.asarray(cam.eye, float), _unit(f + t * (x * s + y * u))
        return np.asarray(cam.eye, float) + cam.ortho * (x * s + y * u), f


def hit_sphere(origin, direction, centre, radius):
    """Where the ray (origin, unit direction) first meets the sphere (centre, radius) in front
    of its origin, or None."""
    oc = np.asarray(origin, float) - np.asarray(centre, float)
    b = float(np.dot(oc, direction))
    disc = b * b - (float(np.dot(oc, oc)) - radius ** 2)
    if disc < 0:
        return None
    t = -b - math.sqrt(disc)
    if t < 0:
        t = -b + math.sqrt(disc)
    return None if t < 0 else np.asarray(origin, float) + t * np.asarray(direction, float)


def dragged_centre(grip, start, grabbed, origin, direction):
    """The rest centre of ``grip`` (a :class:`~es2particles.scenes.base.Grip`) after a drag that
    took its sphere at point ``grabbed`` while the rest centre was ``start``, the pointer now
    along the ray (origin, direction): the grabbed point follows the pointer over the level plane
    through it, and the centre moves with it, its x and z kept within the grip's ranges. A ray
    that never meets that plane in front (level, or pointing away) leaves the centre at
    ``start``."""
    start = np.asarray(start, float)
    if abs(direction[1]) < 1e-9:
        return start
    t = (grabbed[1] - origin[1]) / direction[1]
    if t <= 0:
        return start
    moved = start + (np.asarray(origin, float) + t * np.asarray(direction, float)
                     - np.asarray(grabbed, float))
    return np.array([min(max(moved[0], grip.x_range[0]), grip.x_range[1]), start[1],
                     min(max(moved[2], grip.z_range[0]), grip.z_range[1])])


# -- key bindings ----------------------------------------------------------------------------------

# Keys by the names a bindings file uses: letters, digits and these, each also as "shift+KEY".
NAMED_KEYS = ("left", "right", "up", "down", "page_up", "page_down", "space", "escape", "period",
              "comma", "minus", "equal", "tab", "enter", "backspace", "home", "end")
KEYS = NAMED_KEYS + tuple("abcdefghijklmnopqrstuvwxyz") + tuple("0123456789")
KEYS += tuple(f"shift+{key}" for key in KEYS)

# action -> the keys that do it: the JOGL KeyCamera's arrows, W/S and page up/down; a capital S
# (shift+s) writes a screenshot, as s alone moves back.
DEFAULT_BINDINGS = {
    "turn_left": ("left",), "turn_right": ("right",),
    "forward": ("up", "w"), "back": ("down", "s"),
    "rise": ("page_up",), "sink": ("page_down",),
    "pause": ("space",), "step": ("period",), "screenshot": ("shift+s",), "quit": ("escape", "q"),
    "next_control": ("tab",), "increase": ("equal",), "decrease": ("minus",),
    "reset": ("home",),
}
ACTIONS = tuple(DEFAULT_BINDINGS)


class Bindings:
    """Which key does which action. ``changes``: action -> a key name or a list of them, over the
    defaults (a key given to a new action leaves its old one)."""

    def __init__(self, changes=None, where="key bindings"):
        bound = {action: list(keys) for action, keys in DEFAULT_BINDINGS.items()}
        given = {}  # key -> the action this file gives it
        for action, keys in (changes or {}).items():
            if action not in bound:
                raise ParameterError(f"{where}: unknown action {action!r} (actions: "
                                     f"{', '.join(ACTIONS)})")
            keys = [keys] if isinstance(keys, str) else keys
            if not isinstance(keys, list) or not keys or \
                    not all(isinstance(k, str) for k in keys):
                raise ParameterError(f"{where}: {action} must be a key name or a list of them, "
                                     f"got {keys!r}")
            for key in keys:
                if key.lower() not in KEYS:
                    raise ParameterError(f"{where}: {action} = {key!r} is not a key name (keys: "
                                         f"a-z, 0-9, {', '.join(NAMED_KEYS)}, each also as "
                                         "shift+KEY)")
            keys = [k.lower() for k in keys]
            for key in keys:
                if given.setdefault(key, action) != action:
                    raise ParameterError(f"{where}: {key!r} is given to both {given[key]} and "
                                         f"{action}; a key does one thing")
            for other in bound.values():
                other[:] = [k for k in other if k not in keys]
            bound[action] = keys
        keyless = [action for action, keys in bound.items() if not keys]
        if keyless:
            taker = {a: next(b for b, ks in bound.items()
                             if any(k in ks for k in DEFAULT_BINDINGS[a])) for a in keyless}
            raise ParameterError(f"{where}: " + "; ".join(
                f"{a} is left with no key (its {', '.join(DEFAULT_BINDINGS[a])} went to "
                f"{taker[a]})" for a in keyless) + ": give it another")
        self.actions = {key: action for action, keys in bound.items() for key in keys}
        self.keys = bound

    @classmethod
    def read(cls, path):
        """Bindings from a TOML file: a ``[keys]`` table of action = "key" or ["key", ...]."""
        from ..run import read_toml

        where = f"--keys {str(path)!r}"
        data = read_toml(path, "--keys", "a TOML bindings file")
        unknown = [k for k in data if k != "keys"]
        if unknown or not isinstance(data.get("keys"), dict):
            raise ParameterError(f"{where}: a bindings file holds one [keys] table of action = "
                                 f"\"key\" (found {', '.join(map(repr, unknown or data)) or 'nothing'})")
        return cls(data["keys"], where)

    def action(self, key, shift=False):
        """The action of key ``key`` (a name of :data:`KEYS` without "shift+"), pressed with
        shift or not: shift+KEY's where it has one, else KEY's; or None."""
        return (shift and self.actions.get(f"shift+{key}")) or self.actions.get(key)
