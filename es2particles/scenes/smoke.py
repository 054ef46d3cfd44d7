"""The Mali sample's smoke in ES 2.0 passes: particles leave an emitter flying in a circle, ride a
divergence-free air flow (ideal flow around a moving sphere plus curl noise, ``lib/flow.glsl``)
and are drawn back to front as soft sprites shadowed by an opacity shadow map.

Inertial particles (``tau`` > 0) have an acceleration pass, a = (u_air - v) / tau + g, then a
velocity and a position pass that read this step's acceleration; tracers (``tau`` = 0) follow the
air, and their position pass reads the flow itself, so the plan leaves acceleration and velocity
out. A member of the emitter family (``emitter.py``), with its own passes. World units: metres,
y up, the floor y = 0. float64 twin of the passes: ``twins/smoke.py``.
"""

from dataclasses import dataclass, replace

import numpy as np

from ..errors import ParameterError
from ..frame.settings import Defaults
from ..params import param
from ..render.shadow import OpacityShadow
from ..render.sort import SortParams
from .base import Grip
from .emitter import Emitter, EmitterParams, blend, eye, lifetimes, sprite, target

HALF = 4.0  # x and z of the position range: [-4, 4]
LOW, HIGH = -0.5, 7.5  # its y range: 8 m
SHADOW = (0.0, 2.4, 0.0), 3.6  # the sphere (centre, radius) the shadow map's layers divide


@dataclass(frozen=True)
class SmokeParams(SortParams, EmitterParams):
    """The smoke's parameters, SI units. ``tau`` is the particles' relaxation time (0: tracers
    that move with the air); ``gravity`` the acceleration besides the air's pull (up: buoyancy)."""

    lifetime: tuple = lifetimes((4.0, 6.0))
    eye: tuple = eye((0.0, 2.6, 7.8))
    target: tuple = target((0.0, 2.4, 0.0))
    blend: str = blend("over")
    sprite: str = sprite("smoke")
    tau: float = param(0.3, 0.0, 100.0, unit="s", help="the particles' relaxation time towards "
                       "the air; 0: tracers, with no acceleration or velocity pass")
    gravity: tuple = param((0.0, 0.3, 0.0), -50.0, 50.0, count=3, unit="m/s^2",
                           help="acceleration besides the air's pull (a vector, as in every "
                                "scene; up: buoyancy)")
    wind: tuple = param((0.0, 0.7, 0.0), -50.0, 50.0, count=3, unit="m/s",
                        help="the air's velocity far from the sphere")
    noise: tuple = param((0.3, 0.9, 0.6, 1.0), (0.0, 1e-3, 1e-3, 0.0), (20.0, 100.0, 10.0, 10.0),
                         count=4, metavar="AMP,FREQ,RAMP,DRIFT",
                         help="curl noise: amplitude (m/s), spatial frequency (1/m), ramp "
                              "distance near the sphere (m), drift with the wind")
    sphere: tuple = param((0.0, 2.4, 0.0, 0.7), (-HALF, LOW, -HALF, 0.05), (HALF, HIGH, HALF, 2.0),
                          count=4, unit="m", metavar="X,Y,Z,R",
                          help="the sphere's rest centre and radius")
    sway: tuple = param((1.1, 0.0, 0.3, 7.0), (-HALF, -HALF, -HALF, 0.1), (HALF, HALF, HALF, 1e4),
                        count=4, unit="m, s", metavar="AX,AY,AZ,PERIOD",
                        help="the sphere's motion: amplitude x,y,z and period")
    emitter: tuple = param((0.0, 0.45, 0.0, 0.6), (-HALF, LOW, -HALF, 0.0),
                           (HALF, HIGH, HALF, HALF), count=4, unit="m", metavar="X,Y,Z,R",
                           help="the emitter's orbit: centre and radius")
    emission: tuple = param((5.0, 0.25), (0.1, 0.0), (1e4, 1.0), count=2, unit="s, m",
                            metavar="PERIOD,RADIUS", help="orbit period and spawn ball radius")
    colour: tuple = param((0.82, 0.84, 0.88), 0.0, 1.0, count=3, metavar="R,G,B",
                          help="the smoke's colour")
    light: tuple = param((-3.0, 8.0, 3.0), -100.0, 100.0, count=3, unit="m",
                         help="the light's position")
    shadows: str = param("on", choices=("on", "off"),
                         help="self-shadowing by an opacity shadow map")
    opacity: float = param(0.35, 0.0, 1.0, help="a sprite's opacity at its centre")

    def check(self):
        super().check()
        if self.size_law == "jogl" and self.shadows == "on":
            raise ParameterError("--size-law jogl needs --shadows off: the seed's law gives every "
                                 "sprite one size a frame, and a shadow map needs sprites that "
                                 "shrink with their distance")
        reach = np.abs(self.sphere[:3]) + np.abs(self.sway[:3]) + self.sphere[3]
        if np.any(reach[[0, 2]] > HALF) or self.sphere[1] - self.sphere[3] - abs(self.sway[1]) < LOW \
                or self.sphere[1] + self.sphere[3] + abs(self.sway[1]) > HIGH:
            raise ParameterError(f"--sphere and --sway: the swaying sphere must stay within x, z "
                                 f"in [-{HALF:g}, {HALF:g}] and y in [{LOW:g}, {HIGH:g}]")
        e = np.asarray(self.emitter[:3])
        if np.any(np.abs(e[[0, 2]]) + self.emitter[3] + self.emission[1] > HALF) or \
                not LOW < e[1] < HIGH:
            raise ParameterError(f"--emitter and --emission: the emitter's orbit must stay within "
                                 f"x, z in [-{HALF:g}, {HALF:g}] and y in ({LOW:g}, {HIGH:g})")

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

        return {"u_dt": self.dt, "u_tau": self.tau, "u_relax": tuple(map(float, relaxation(self.dt, self.tau))),
                "u_gravity": self.gravity, "u_wind": self.wind, "u_noise": self.noise,
                "u_sphere_radius": float(self.sphere[3]), "u_sphere_drift": (0.0, 0.0, 0.0),
                **self.motion().uniforms(), "u_emitter": self.emitter,
                "u_emission": self.emission, "u_lifetime": self.lifetime}

    def motion(self):
        """The sphere's sway about its rest centre (``lib/motion.glsl``)."""
        from ..frame.motion import Motion

        return Motion(self.dt, offset=tuple(map(float, self.sphere[:3])),
                      sway=tuple(map(float, self.sway[:3])), period=float(self.sway[3]))


class Smoke(Emitter):
    """Smoke curling around a moving sphere, sorted and self-shadowed."""

    name, step, Params = "smoke", "smoke.frag", SmokeParams
    defaults = Defaults(particles=2 ** 15, point_size=16.0, rounding="dither")

    def declare(self, g, caps):
        p = self.params
        g.quantity("position", (-HALF, LOW, -HALF), (HALF, HIGH, HALF))
        # Declared in both cases; tracers read neither, so the plan leaves both out (and their
        # range, unbounded as tau -> 0, is never stored).
        bound = p.acceleration_bound if p.tau > 0 else 1.0
        g.quantity("velocity", -p.speed_bound, p.speed_bound, components=3)
        g.quantity("acceleration", -bound, bound, components=3)

    def uniforms(self, caps):
        return self.params.uniforms()

    def passes(self, g, uniforms, defines):
        """Life; then acceleration, and velocity and position from this step's acceleration;
        tracers' position reads the air alone."""
        def add(name, reads, reads_new=(), **more):
            g.add(name, self.step, writes=name, reads=reads, reads_new=reads_new,
                  uniforms=uniforms, defines={f"WRITE_{name.upper()}": None, **more})

        add("life", "life")
        add("acceleration", ("position", "velocity"))
        add("velocity", ("velocity", "life"), "acceleration")
        if self.params.tau > 0:
            add("position", ("position", "velocity", "life"), "acceleration")
        else:
            add("position", ("position", "life"), TRACER=None)

    def begin(self, count, rng):
        p = self.params
        start = {"position": np.tile(np.asarray(p.emitter[:3]), (count, 1))}
        if p.tau > 0:
            start["velocity"] = np.tile(np.asarray(p.wind), (count, 1))
        return start

    def meshes(self):
        from ..render import meshes as shapes

        ball = shapes.sphere((0.0, 0.0, 0.0), self.params.sphere[3], colour=(0.35, 0.62, 0.36))
        return [shapes.floor(HALF, cell=0.5), replace(ball, moves=True)]

    def motion(self):
        """The sphere's sway about its rest centre."""
        return self.params.motion()

    def grip(self):
        """The sphere, which a hand drags over the floor in a live view or the page: its rest
        centre is the motion's offset (u_motion_offset) and its drag velocity u_sphere_drift;
        the swaying sphere stays within the position range's x and z (as ``check`` asks of
        --sphere and --sway)."""
        p = self.params
        reach = [HALF - abs(a) - p.sphere[3] for a in (p.sway[0], p.sway[2])]
        return Grip("u_motion_offset", "u_sphere_drift", p.sphere[:3], p.sphere[3],
                    (-reach[0], reach[0]), (-reach[1], reach[1]))

    def sprites(self):
        p = self.params
        shadow = None
        if p.shadows == "on":  # OpacityShadow checks that the light is outside its sphere
            shadow = OpacityShadow(light=p.light, centre=SHADOW[0], radius=SHADOW[1],
                                   extinction=0.6, ambient=0.3)
        return {"size_spread": 0.35, "tint": (*p.colour, 1.0), "opacity": p.opacity,
                "light": p.light, "background": (0.11, 0.12, 0.15), "sort": p.depth_sort(),
                "shadow": shadow, "growth": 2.5}

    def describe(self):
        p = self.params
        motion = (f"inertial particles, tau {p.tau:g} s: acceleration a = (u_air - v) / tau + g, "
                  f"then velocity and position from this step's a (exact over the step); "
                  f"velocity range +-{p.speed_bound:.3g} m/s (a bound of the air's speed), "
                  f"acceleration +-{p.acceleration_bound:.3g} m/s^2"
                  if p.tau > 0 else
                  "tracers (tau 0): the position pass reads the air itself (midpoint rule); "
                  "no acceleration or velocity")
        return super().describe() + [
            f"air: ideal flow of wind {p.wind} around a sphere of radius {p.sphere[3]:g} "
            f"swaying {p.sway[:3]} over {p.sway[3]:g} s, plus curl noise (amplitude "
            f"{p.noise[0]:g} m/s, frequency {p.noise[1]:g}/m, ramped over {p.noise[2]:g} m "
            f"from the sphere); divergence-free", f"physics: dt {p.dt:.4g}; {motion}"]
