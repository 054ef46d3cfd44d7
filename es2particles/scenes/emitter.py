"""The emitter family: 3D scenes whose particles are born, live and die, drawn as sprites.

The family owns what such scenes share, so a member is its parameters, its particle step in GLSL,
its quantities and its meshes: the ``life`` quantity (the exact step clock of ``twins/life.py``)
and the births staggered over the first lifetime; the pass fan-out, one pass per written quantity
running the member's one shader with ``WRITE_<QUANTITY>`` defined; the warm-up (one longest
lifetime, so the first frame is steady); the camera (fixed, or orbiting its target over an
animation, from the ``eye``, ``target`` and ``fov`` parameters); and the rendering, sprites whose
inputs are roles (``Sprites.roles``) mapped to the member's quantities.

A member's :class:`EmitterParams` subclass declares its parameters with their defaults (its own
``dt``, ``lifetime``, ``eye`` and ``target`` among them; the sprites' look is the rendering's,
``SpriteLook``, and a member drawn otherwise takes :class:`EmitterPhysics` and its rendering's); its ``step`` names the GLSL file;
``declare(g, caps)`` adds its quantities (and scene textures) to the graph; ``uniforms(caps)``
gives the passes' uniforms; ``begin(count, rng)`` the start of its own quantities.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..frame.graph import PassGraph
from ..frame.settings import Defaults
from ..params import Params, param
from ..render.camera import Camera, orbit
from ..render.shafts import backlight
from ..render.sprites import SpriteLook, Sprites, blend_param, sprite_param
from ..twins.life import life_range, longest_life, staggered_births
from .base import Scene

CAMERAS = ("fixed", "orbit")


def time_step(default, hi=0.25):
    return param(default, 1e-4, hi, unit="s", help="time step")


def lifetimes(default):
    return param(default, 1e-4, None, count=2, unit="s", metavar="MIN,MAX", help="lifetime range")


def eye(default):
    return param(default, -1e3, 1e3, count=3, unit="m", help="the camera's place")


def target(default):
    return param(default, -1e3, 1e3, count=3, unit="m", help="the point the camera looks at")


# A member re-declares the sprites' look with these (render/sprites.py: SpriteLook).
blend, sprite = blend_param, sprite_param


@dataclass(frozen=True)
class EmitterPhysics(Params):
    """What every member declares beside its look, each with its own defaults (the fountain's
    here; a member re-declares a field with :func:`time_step`, :func:`lifetimes`, :func:`eye` or
    :func:`target`): the time step, the lifetimes and the camera."""

    dt: float = time_step(1 / 30)
    lifetime: tuple = lifetimes((2.0, 2.5))
    camera: str = param("fixed", choices=CAMERAS,
                        help="fixed, or orbit: circle the target once over an animation")
    eye: tuple = eye((0.0, 3.0, 7.5))
    target: tuple = target((0.0, 1.4, 0.0))
    fov: float = param(45.0, 1.0, 179.0, unit="degrees", help="the camera's vertical field of view")

    def check(self):
        super().check()
        lo, hi = self.lifetime
        longest = longest_life(self.dt)
        if not (self.dt <= lo <= hi <= longest):
            raise ParameterError(f"--lifetime must be MIN,MAX with dt {self.dt:g} <= MIN <= MAX "
                                 f"<= {longest:.4g} s (the life clock counts 32512 steps of "
                                 f"--dt), got {lo:g},{hi:g}")
        if np.allclose(self.eye, self.target):
            raise ParameterError("--eye and --target must differ")


@dataclass(frozen=True)
class EmitterParams(SpriteLook, EmitterPhysics):
    """A member drawn as sprites: its physics and camera, then the sprites' look and the light
    shafts (declared by the rendering, ``SpriteLook``); a member drawn otherwise (confetti's
    quads) takes :class:`EmitterPhysics` and its own rendering's look."""


def camera_of(p, frame, frames):
    """The camera of frame ``frame`` of ``frames`` from parameters ``p``'s ``camera`` (fixed, or
    orbiting its target once over the animation), ``eye``, ``target`` and ``fov``."""
    if p.camera == "orbit":
        dx, dz = p.eye[0] - p.target[0], p.eye[2] - p.target[2]
        return orbit(frame, frames, radius=float(np.hypot(dx, dz)), height=p.eye[1],
                     target=p.target, fov=p.fov, phase=float(np.arctan2(dx, dz)))
    return Camera(eye=p.eye, target=p.target, fov=p.fov)


class Emitter(Scene):
    """Base of the emitter family (see the module's docstring)."""

    Params = EmitterParams
    renders = Sprites
    step = ""  # the particle step's GLSL file, a pass per written quantity
    writes = ("position", "velocity")  # the member's quantities its passes write, in order
    defaults = Defaults(particles=2 ** 14, point_size=9.0, rounding="dither")

    def __init__(self, params=None, **given):
        super().__init__(params, **given)
        # Steady from the first frame: one longest lifetime before it.
        steps = int(np.ceil(self.params.lifetime[1] / self.params.dt))
        self.defaults = Defaults(self.defaults.particles, self.defaults.point_size, steps,
                                 self.defaults.rounding)

    @classmethod
    def default_text(cls, setting):
        if setting == "steps":
            return "one longest lifetime (--lifetime MAX / --dt)"
        return super().default_text(setting)

    # -- what a member declares ------------------------------------------------------------------

    def declare(self, g, caps):
        """Add the member's quantities (and textures) to graph ``g``."""
        raise NotImplementedError

    def uniforms(self, caps):
        """The passes' uniforms: name -> value."""
        return {}

    def defines(self, caps):
        """The passes' defines (the family adds ``WRITE_<QUANTITY>``)."""
        return {}

    def begin(self, count, rng):
        """The start of the member's own quantities (``life`` is the family's)."""
        return {}

    def meshes(self):
        return []

    def sprites(self):
        """Keyword arguments of the :class:`~es2particles.render.sprites.Sprites` (the family
        adds the blend, the sprite, the meshes and the size law's distance)."""
        return {}

    # -- what the family does --------------------------------------------------------------------

    def graph(self, caps=None):
        g = PassGraph()
        self.declare(g, caps)
        g.quantity("life", *life_range(self.params.dt), storage="rgba8")
        self.passes(g, self.uniforms(caps), self.defines(caps))
        return g

    def passes(self, g, uniforms, defines):
        """One pass per written quantity and ``life``, each reading every one of them (last
        step's values) and the graph's textures."""
        state = self.writes + ("life",)
        for name in state:
            g.add(name, self.step, writes=name, reads=state, textures=tuple(g.textures),
                  uniforms=uniforms, defines={**defines, f"WRITE_{name.upper()}": None})

    def start(self, count, rng):
        return {"life": staggered_births(count, self.params.lifetime, rng),
                **self.begin(count, rng)}

    def camera_at(self, frame, frames):
        return camera_of(self.params, frame, frames)

    def rendering(self):
        # Sprite sizes are those at the declared camera's distance from its target (the seed
        # scales sizes by the camera's squared distance relative to its first): 1 / d^2
        # attenuation, so a sprite keeps its world size when --eye moves the camera.
        # Under the JOGL law, sizes follow the camera's xz distance to the target as a fraction
        # of the declared camera's.
        p, default = self.params, self.Params()
        d0 = float(np.linalg.norm(np.subtract(default.eye, default.target)))
        law = {} if p.size_law == "perspective" else {
            "size_law": "jogl", "law_anchor": (p.target[0], p.target[2]),
            "law_distance": float(np.hypot(default.eye[0] - default.target[0],
                                           default.eye[2] - default.target[2]))}
        sprites = self.sprites()
        lamp = sprites.get("lamp")
        shafts = p.shafts_declared(lamp.position if lamp is not None
                                   else backlight(p.eye, p.target))
        return Sprites(**{"attenuation": (0.0, 0.0, 1.0 / d0 ** 2), **p.sprite_look(),
                          "shafts": shafts, **sprites, **law,
                          "meshes": tuple(self.meshes())})


# --- point emitters: where a member's particles are born -----------------------------------------

@dataclass(frozen=True)
class PointEmitters:
    """Point emitters from their text, ``X,Y,Z[,DX,DY,DZ[,RATE]]`` separated by ``;``: each a
    point, a launch direction (default up) and a share of the births (default even), inside
    the box ``lo``..``hi``; at most 16."""

    points: np.ndarray
    directions: np.ndarray
    shares: np.ndarray

    @classmethod
    def parse(cls, text, lo, hi, option="--emitters"):
        try:
            rows = [tuple(float(v) for v in e.split(",")) for e in text.split(";") if e.strip()]
        except ValueError:
            raise ParameterError(f"{option} must be numbers X,Y,Z[,DX,DY,DZ[,RATE]] separated "
                                 f"by ';', got {text!r}") from None
        if not 1 <= len(rows) <= 16:
            raise ParameterError(f"{option} must be 1 to 16 emitters, got {len(rows)}")
        full = []
        for row in rows:
            if len(row) not in (3, 6, 7) or not np.all(np.isfinite(row)):
                raise ParameterError(f"{option}: an emitter is X,Y,Z or X,Y,Z,DX,DY,DZ or "
                                     f"X,Y,Z,DX,DY,DZ,RATE of finite numbers; got {row}")
            if np.any(np.less(row[:3], lo)) or np.any(np.greater(row[:3], hi)):
                raise ParameterError(f"{option}: an emitter's point must lie in {tuple(lo)} .. "
                                     f"{tuple(hi)}, got {row[:3]}")
            row = row + (0.0, 1.0, 0.0, 1.0)[len(row) - 3:]
            if not np.max(np.abs(row[3:6])) > 0:
                raise ParameterError(f"{option}: an emitter's direction must not be zero, got "
                                     f"{row[3:6]}")
            if not 1e-6 <= row[6] <= 1e6:
                raise ParameterError(f"{option}: an emitter's rate must be in [1e-06, 1e6], got "
                                     f"{row[6]}")
            full.append(row)
        table = np.array(full, dtype=float)
        # Scaled by the largest component first: the norm of (1e308, 0, 0) overflowed to inf
        # (a numpy warning), and every particle was launched along (0, 0, 0).
        directions = table[:, 3:6] / np.max(np.abs(table[:, 3:6]), axis=1, keepdims=True)
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        return cls(table[:, :3], directions, table[:, 6] / table[:, 6].sum())

    def uniform(self):
        """``u_emitters``: per emitter, (point, cumulative share) then (direction, 0)."""
        out = np.zeros((2 * len(self.points), 4))
        out[0::2, :3], out[0::2, 3] = self.points, np.cumsum(self.shares)
        out[1::2, :3] = self.directions
        return out


@dataclass(frozen=True)
class PointEmitterParams(EmitterParams):
    """The point emitters' parameters: where births happen and how fast particles leave."""

    emitters: str = param("0,0,0", text=True, metavar="X,Y,Z[,DX,DY,DZ[,RATE]];...",
                          help="emitters: a point, a launch direction (up), a share of births")
    speed_across: tuple = param((0.6, 1.4), 0.0, 100.0, count=2, unit="m/s", metavar="MIN,MAX",
                                help="launch speed across an emitter's direction")
    speed_up: tuple = param((5.0, 7.0), 0.0, 100.0, count=2, unit="m/s", metavar="MIN,MAX",
                            help="launch speed along an emitter's direction")

    def check(self):
        super().check()
        for name in ("speed_across", "speed_up"):
            lo, hi = getattr(self, name)
            if hi < lo:
                raise ParameterError(f"--{name.replace('_', '-')} must be MIN,MAX with MIN <= "
                                     f"MAX, got {lo:g},{hi:g}")


class PointEmitting(Emitter):
    """A member whose particles are born at point emitters (``lib/emitters.glsl`` launches
    them): the emitters' uniforms and their count's define, and a start with every particle at
    its emitter, at rest. ``box`` is (lo, hi), the position's range; emitters stand on or above
    the floor within it."""

    Params = PointEmitterParams
    box = ((-6.0, -1.0, -6.0), (6.0, 7.0, 6.0))

    def __init__(self, params=None, **given):
        super().__init__(params, **given)
        lo, hi = self.box
        self.emitters = PointEmitters.parse(self.params.emitters, (lo[0], 0.0, lo[2]), hi)

    def uniforms(self, caps):
        p = self.params
        return {"u_speed": (*p.speed_across, *p.speed_up), "u_emitters": self.emitters.uniform()}

    def defines(self, caps):
        return {"EMITTERS": len(self.emitters.points)}

    def begin(self, count, rng):
        points = self.emitters.points
        return {"position": points[np.arange(count) % len(points)],
                "velocity": np.zeros((count, 3))}
