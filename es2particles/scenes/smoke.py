"""The Mali sample's smoke in ES 2.0 passes: particles leave an emitter flying in a circle, ride a
divergence-free air flow (ideal flow around a moving sphere plus curl noise, ``lib/flow.glsl``)
and are drawn back to front as soft sprites shadowed by an opacity shadow map.

Inertial particles (``tau`` > 0) have an acceleration pass, a = (u_air - v) / tau + g, then a
velocity and a position pass that read this step's acceleration; tracers (``tau`` = 0) follow the
air, and their position pass reads the flow itself, so the plan leaves acceleration and velocity
out. ``life`` is the exact step clock of ``twins/life.py``. World units: metres, y up, the floor
y = 0. float64 twin of the passes: ``twins/smoke.py``.
"""

from dataclasses import dataclass, replace

import numpy as np

from ..render.camera import Camera, orbit
from ..errors import ParameterError, check_range
from ..frame.graph import PassGraph
from ..render.shadow import OpacityShadow
from ..twins.life import life_range, longest_life, staggered_births
from .base import Defaults, Scene, parse_numbers, steady_steps

HALF = 4.0  # x and z of the position range: [-4, 4]
LOW, HIGH = -0.5, 7.5  # its y range: 8 m
CAMERAS = ("fixed", "orbit")
SORTS = ("full", "off")  # or a number of merge passes per frame (Latta's spreading)
EYE, TARGET = (0.0, 2.6, 7.8), (0.0, 2.4, 0.0)
SHADOW_RADIUS = 3.6  # the sphere around TARGET that the shadow map's layers divide


@dataclass(frozen=True)
class SmokePhysics:
    """The smoke's parameters, SI units. ``tau`` is the particles' relaxation time (0: tracers
    that move with the air); ``gravity`` the acceleration besides the air's pull (up: buoyancy).
    ``noise`` is (amplitude m/s, spatial frequency 1/m, ramp distance m, drift with the wind)."""

    dt: float = 1 / 30
    tau: float = 0.3
    gravity: tuple = (0.0, 0.3, 0.0)
    wind: tuple = (0.0, 0.7, 0.0)
    noise: tuple = (0.3, 0.9, 0.6, 1.0)
    sphere: tuple = (0.0, 2.4, 0.0, 0.7)  # rest centre, radius
    sway: tuple = (1.1, 0.0, 0.3, 7.0)  # amplitude x, y, z, period s
    emitter: tuple = (0.0, 0.45, 0.0, 0.6)  # orbit centre, orbit radius
    emission: tuple = (5.0, 0.25)  # orbit period s, spawn ball radius m
    lifetime: tuple = (4.0, 6.0)

    def __post_init__(self):
        check_range("dt", self.dt, 1e-4, 0.25)
        check_range("tau", self.tau, 0.0, 100.0)
        for name, count in (("gravity", 3), ("wind", 3), ("noise", 4), ("sphere", 4),
                            ("sway", 4), ("emitter", 4), ("emission", 2), ("lifetime", 2)):
            value = getattr(self, name)
            if len(value) != count:
                raise ParameterError(f"{name} must be {count} numbers, got {value!r}")
            for v in value:
                check_range(name, v)
        for v in self.gravity + self.wind:
            check_range("gravity and wind components", v, -50.0, 50.0)
        check_range("noise amplitude", self.noise[0], 0.0, 20.0)
        check_range("noise frequency", self.noise[1], 1e-3, 100.0)
        check_range("noise ramp distance", self.noise[2], 1e-3, 10.0)
        check_range("noise drift", self.noise[3], 0.0, 10.0)
        check_range("sphere radius", self.sphere[3], 0.05, 2.0)
        check_range("sway period", self.sway[3], 0.1, 1e4)
        check_range("emitter orbit radius", self.emitter[3], 0.0, HALF)
        check_range("emission orbit period", self.emission[0], 0.1, 1e4)
        check_range("emission spawn radius", self.emission[1], 0.0, 1.0)
        lo, hi = (check_range("lifetime", v, self.dt, longest_life(self.dt))
                  for v in self.lifetime)
        if hi < lo:
            raise ParameterError(f"lifetime must have min <= max, got {self.lifetime}")
        reach = np.abs(self.sphere[:3]) + np.abs(self.sway[:3]) + self.sphere[3]
        if np.any(reach[[0, 2]] > HALF) or self.sphere[1] - self.sphere[3] - abs(self.sway[1]) < LOW \
                or self.sphere[1] + self.sphere[3] + abs(self.sway[1]) > HIGH:
            raise ParameterError(f"the sphere (swaying) must stay within x, z in [-{HALF:g}, "
                                 f"{HALF:g}] and y in [{LOW:g}, {HIGH:g}]")
        e = np.asarray(self.emitter[:3])
        if np.any(np.abs(e[[0, 2]]) + self.emitter[3] + self.emission[1] > HALF) or \
                not LOW < e[1] < HIGH:
            raise ParameterError(f"the emitter's orbit must stay within x, z in [-{HALF:g}, "
                                 f"{HALF:g}] and y in ({LOW:g}, {HIGH:g})")

    @property
    def speed_bound(self):
        """A bound of the particles' speed, the velocity's range: the air's speed bound plus the
        settling speed |g| tau. The air: the wind, the dipole (at most 1.5 |wind - V| at the
        sphere, V at most the sway's peak speed), and the curl noise, whose terms are bounded by
        the noise's gradient bound G (``twins/flow.py``) at frequency s: |curl psi| <= 2 sqrt(3)
        s G, the ramp's |alpha'| |psi| <= (15/8) sqrt(3) / ramp distance, and |psi / r + J^T n|
        <= sqrt(3) (1 / R + s G)."""
        from ..twins.flow import NOISE_GRADIENT_BOUND as G

        wind = np.linalg.norm(self.wind)
        sway = np.linalg.norm(self.sway[:3]) * 2 * np.pi / self.sway[3]
        amplitude, s, ramp, _ = self.noise
        root3 = np.sqrt(3)
        noise = amplitude * (2 * root3 * s * G + 15 / 8 * root3 / ramp
                             + root3 * (1 / self.sphere[3] + s * G))
        return float(wind + 1.5 * (wind + sway) + noise
                     + np.linalg.norm(self.gravity) * self.tau)

    @property
    def acceleration_bound(self):
        """|a| = |u_air - v| / tau + |g| <= 2 speed_bound / tau + |g| per component."""
        return 2 * self.speed_bound / self.tau + float(np.linalg.norm(self.gravity))

    def uniforms(self):
        from ..twins.smoke import relaxation

        f = lambda values: tuple(float(v) for v in values)  # noqa: E731
        return {"u_dt": float(self.dt), "u_tau": float(self.tau),
                "u_relax": f(relaxation(self.dt, self.tau)), "u_gravity": f(self.gravity),
                "u_wind": f(self.wind), "u_noise": f(self.noise), "u_sphere": f(self.sphere),
                "u_sway": f(self.sway), "u_emitter": f(self.emitter),
                "u_emission": f(self.emission), "u_lifetime": f(self.lifetime)}


class Smoke(Scene):
    """Smoke curling around a moving sphere, sorted and self-shadowed."""

    name = "smoke"

    def __init__(self, physics=SmokePhysics(), colour=(0.82, 0.84, 0.88), light=(-3.0, 8.0, 3.0),
                 shadows=True, sort="full", camera="fixed", opacity=0.35):
        if camera not in CAMERAS:
            raise ParameterError(f"camera must be one of {CAMERAS}, got {camera!r}")
        if sort not in SORTS:
            sort = int(check_range("sort (passes per frame)", sort, 1, 10 ** 4, integer=True))
        self.colour = tuple(check_range("colour", v, 0.0, 1.0) for v in colour)
        self.light = tuple(check_range("light", v, -100.0, 100.0) for v in light)
        if len(self.colour) != 3 or len(self.light) != 3:
            raise ParameterError("colour and light must be three numbers each")
        self.shadow = None
        if shadows:  # OpacityShadow checks that the light is outside the shadowed sphere
            self.shadow = OpacityShadow(light=self.light, centre=TARGET, radius=SHADOW_RADIUS,
                                        extinction=0.6, ambient=0.3)
        self.physics, self.sort, self.camera = physics, sort, camera
        self.opacity = check_range("opacity", opacity, 0.0, 1.0)
        # Steady from the first frame: one longest lifetime before it.
        steps = steady_steps(physics)
        self.defaults = Defaults(particles=2 ** 15, point_size=16.0, steps=steps,
                                 rounding="dither")

    @classmethod
    def add_arguments(cls, parser):
        add = parser.add_argument
        d = SmokePhysics()
        join = lambda v: ",".join(f"{x:g}" for x in v)  # noqa: E731
        add("--dt", type=float, default=d.dt, help="time step in seconds (default 1/30)")
        add("--tau", type=float, default=d.tau,
            help=f"the particles' relaxation time towards the air in seconds; 0: tracers, "
                 f"with no acceleration or velocity pass (default {d.tau:g})")
        add("--gravity", default=join(d.gravity),
            help=f"acceleration besides the air's pull, x,y,z (default {join(d.gravity)}: "
                 "a little buoyancy)")
        add("--wind", default=join(d.wind), help=f"the air's velocity far from the sphere "
            f"(default {join(d.wind)})")
        add("--noise", default=join(d.noise),
            help=f"curl noise: amplitude (m/s), spatial frequency (1/m), ramp distance near the "
                 f"sphere (m), drift with the wind (default {join(d.noise)})")
        add("--sphere", default=join(d.sphere), help=f"the sphere's rest centre and radius "
            f"x,y,z,r (default {join(d.sphere)})")
        add("--sway", default=join(d.sway), help=f"the sphere's motion: amplitude x,y,z and "
            f"period s (default {join(d.sway)})")
        add("--emitter", default=join(d.emitter), help=f"the emitter's orbit: centre x,y,z and "
            f"radius (default {join(d.emitter)})")
        add("--emission", default=join(d.emission), help=f"orbit period (s) and spawn ball "
            f"radius (m) (default {join(d.emission)})")
        add("--lifetime", type=float, nargs=2, default=d.lifetime, metavar=("MIN", "MAX"),
            help=f"lifetime range in seconds (default {join(d.lifetime)})")
        add("--colour", default="0.82,0.84,0.88", help="smoke colour r,g,b in [0, 1] "
            "(default 0.82,0.84,0.88)")
        add("--light", default="-3,8,3", help="the light's position x,y,z (default -3,8,3)")
        add("--shadows", choices=("on", "off"), default="on",
            help="self-shadowing by an opacity shadow map (default on)")
        add("--sort", default="full",
            help="back-to-front order: full (the whole sorting network every frame), off "
                 "(texel order), or a number of merge passes per frame (spread over frames, "
                 "Latta 2004) (default full)")
        add("--opacity", type=float, default=0.35, help="a sprite's opacity at its centre, "
            "[0, 1] (default 0.35)")
        add("--camera", choices=CAMERAS, default="fixed",
            help="fixed, or orbit: circle the scene once over an animation (default fixed)")

    @classmethod
    def from_args(cls, args):
        def numbers(option, count):
            return parse_numbers(option, getattr(args, option), (count,))

        physics = SmokePhysics(
            dt=args.dt, tau=args.tau, gravity=numbers("gravity", 3), wind=numbers("wind", 3),
            noise=numbers("noise", 4), sphere=numbers("sphere", 4), sway=numbers("sway", 4),
            emitter=numbers("emitter", 4), emission=numbers("emission", 2),
            lifetime=tuple(args.lifetime))
        sort = args.sort
        if sort not in SORTS:
            try:
                sort = int(sort)
            except ValueError:
                raise ParameterError(f"--sort must be full, off or a whole number of passes per "
                                     f"frame, got {args.sort!r}") from None
        return cls(physics, numbers("colour", 3), numbers("light", 3), args.shadows == "on", sort,
                   args.camera, args.opacity)

    def graph(self, caps=None):
        p = self.physics
        g = PassGraph()
        g.quantity("position", (-HALF, LOW, -HALF), (HALF, HIGH, HALF))
        g.quantity("life", *life_range(p.dt), storage="rgba8")
        uniforms = p.uniforms()
        g.add("life", "smoke.frag", writes="life", reads="life", uniforms=uniforms,
              defines={"WRITE_LIFE": None})
        # Declared in both cases; tracers read neither, so the plan leaves both out (and their
        # range, unbounded as tau -> 0, is never stored).
        bound = p.acceleration_bound if p.tau > 0 else 1.0
        g.quantity("velocity", -p.speed_bound, p.speed_bound, components=3)
        g.quantity("acceleration", -bound, bound, components=3)
        g.add("acceleration", "smoke.frag", writes="acceleration", reads=("position", "velocity"),
              uniforms=uniforms, defines={"WRITE_ACCELERATION": None})
        g.add("velocity", "smoke.frag", writes="velocity", reads=("velocity", "life"),
              reads_new="acceleration", uniforms=uniforms, defines={"WRITE_VELOCITY": None})
        if p.tau > 0:
            g.add("position", "smoke.frag", writes="position",
                  reads=("position", "velocity", "life"), reads_new="acceleration",
                  uniforms=uniforms, defines={"WRITE_POSITION": None})
        else:
            g.add("position", "smoke.frag", writes="position", reads=("position", "life"),
                  uniforms=uniforms, defines={"WRITE_POSITION": None, "TRACER": None})
        return g

    def start(self, count, rng):
        p = self.physics
        start = {"life": staggered_births(count, p.lifetime, rng),
                 "position": np.tile(np.asarray(p.emitter[:3]), (count, 1))}
        if p.tau > 0:
            start["velocity"] = np.tile(np.asarray(p.wind), (count, 1))
        return start

    # -- drawing -------------------------------------------------------------------------------

    def meshes(self):
        from ..render import meshes as shapes

        p = self.physics
        ball = shapes.sphere((0.0, 0.0, 0.0), p.sphere[3], colour=(0.35, 0.62, 0.36))
        return [shapes.floor(HALF, cell=0.5), replace(ball, moves=True)]

    def motion(self):
        """The sphere's sway about its rest centre (``twins/smoke.py``: ``sphere``)."""
        from ..frame.motion import Motion

        p = self.physics
        return Motion(p.dt, offset=tuple(map(float, p.sphere[:3])),
                      sway=tuple(map(float, p.sway[:3])), period=float(p.sway[3]))

    def camera_at(self, frame, frames):
        if self.camera == "orbit":
            return orbit(frame, frames, radius=np.hypot(EYE[0], EYE[2]), height=EYE[1],
                         target=TARGET)
        return Camera(eye=EYE, target=TARGET)

    def rendering(self):
        from ..render.sprites import Sprites

        d0 = np.linalg.norm(np.subtract(EYE, TARGET))
        return Sprites(sprite="smoke", size_spread=0.35, attenuation=(0.0, 0.0, 1.0 / d0 ** 2),
                       blend="over", tint=(*self.colour, 1.0), opacity=self.opacity,
                       light=self.light, background=(0.11, 0.12, 0.15),
                       sort=None if self.sort == "off" else self.sort, shadow=self.shadow,
                       growth=2.5, meshes=self.meshes())

    def describe(self):
        p = self.physics
        motion = (f"inertial particles, tau {p.tau:g} s: acceleration a = (u_air - v) / tau + g, "
                  f"then velocity and position from this step's a (exact over the step); "
                  f"velocity range +-{p.speed_bound:.3g} m/s (a bound of the air's speed), "
                  f"acceleration +-{p.acceleration_bound:.3g} m/s^2"
                  if p.tau > 0 else
                  "tracers (tau 0): the position pass reads the air itself (midpoint rule); "
                  "no acceleration or velocity")
        return [f"air: ideal flow of wind {p.wind} around a sphere of radius {p.sphere[3]:g} "
                f"swaying {p.sway[:3]} over {p.sway[3]:g} s, plus curl noise (amplitude "
                f"{p.noise[0]:g} m/s, frequency {p.noise[1]:g}/m, ramped over {p.noise[2]:g} m "
                f"from the sphere); divergence-free", f"physics: dt {p.dt:.4g}; {motion}"]
