"""The collision scene: a fountain of particles under gravity that hit objects, bounce or slide
off, age, fade and are emitted again.

Three quantities, each one RGBA8 texture of two 16-bit values: ``position`` (the scene
rectangle), ``velocity`` and ``life`` (age, lifetime; age < 0 means not yet born). Three passes,
one per quantity, run the same ``particle_step()`` of ``lib/particle.glsl`` on last step's state:

- forces: gravity, drag (exact exponential: stable for any k dt) and an optional spring towards a
  point, evaluated at every sub-step inside the integrator. There is no acceleration pass: a
  texture of accelerations would freeze the force at the step's start and cost a pass and a
  texture, for no gain in a scene whose forces are a few uniforms.
- integration: semi-implicit Euler in sub-steps of at most half a field cell (no tunnelling);
- collision: the chapter's response (Listing 2.3) and a push-out by the penetration depth;
- life: age, and respawn at the emitter from a hash of the particle's texel and the step number,
  computed alike in every pass, so the three agree without extra state.

``twins/particle.py``: ``step_reference`` is the float64 numpy twin of ``particle_step``.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range
from ..fields.field2d import CollisionField, cell_size, parse_shape
from ..frame.graph import PassGraph
from ..twins.life import LIFE_STEPS, life_range, longest_life, staggered_births
from .base import Defaults, Scene, steady_steps

RECT = (-1.0, -1.0, 1.0, 1.0)
# The most sub-steps a particle's step may take: a loop bound compiled into the shader (ES 1.00
# loops need a constant one). A scene whose particles could need more is refused.
SUBSTEP_LIMIT = 4096


@dataclass(frozen=True)
class Physics:
    """The scene's parameters (SI-like units: scene units, seconds)."""

    dt: float = 1 / 60
    gravity: tuple = (0.0, -3.0)
    drag: float = 0.05
    spring: tuple = (0.0, 0.0, 0.0)  # centre x, y and omega^2
    sliding: float = 0.5  # the chapter's mass as sliding factor, in [0, 1]
    bounce: float = 0.6
    emit: bool = True
    emitter: tuple = (-0.7, -0.95)
    direction: float = np.radians(68)
    spread: float = 0.3
    speed: tuple = (2.6, 3.2)
    lifetime: tuple = (3.0, 5.0)
    max_speed: float = 8.0  # velocity range is [-max_speed, max_speed]

    def __post_init__(self):
        check_range("dt", self.dt, 1e-6, 1.0)
        check_range("drag", self.drag, 0, 1e6)
        check_range("spring omega^2", self.spring[2], 0, 1e6)
        check_range("sliding", self.sliding, 0, 1)
        check_range("bounce", self.bounce, 0, 2)
        check_range("spread", self.spread, 0, 2 * np.pi)
        check_range("max_speed", self.max_speed, 1e-3, 1e4)
        lo, hi = (check_range("speed", v, 0, self.max_speed) for v in self.speed)
        if hi < lo:
            raise ParameterError(f"speed range must have min <= max, got {self.speed}")
        longest = longest_life(self.dt)
        if self.lifetime[1] > longest:
            raise ParameterError(
                f"lifetime up to {self.lifetime[1]:g} s is {self.lifetime[1] / self.dt:.0f} steps "
                f"of dt {self.dt:g}; the life clock counts whole steps in 16 bits, at most "
                f"{LIFE_STEPS} ({longest:.4g} s at this dt): shorten --lifetime or raise --dt")
        lo, hi = (check_range("lifetime", v, self.dt, longest) for v in self.lifetime)
        if hi < lo:
            raise ParameterError(f"lifetime range must have min <= max, got {self.lifetime}")
        for name, value in (("gravity", self.gravity), ("emitter", self.emitter)):
            for v in value:
                check_range(name, v, -1e4, 1e4)

    @property
    def max_age(self):
        """The longest age the life clock holds (LIFE_STEPS steps): a particle given this
        lifetime lives as long as a run can tell."""
        return longest_life(self.dt)

    def max_substeps(self, cell):
        """The most sub-steps of at most half a field cell that any particle can need in a step,
        the shader's loop bound. The velocity range is enforced at every sub-step (not only when
        the velocity is stored), so no particle is faster than the range's corner, max_speed
        sqrt 2, at any time; a spring's fixed count is at least this."""
        reach = self.max_speed * np.sqrt(2) * self.dt
        return int(max(1, np.ceil(reach / (0.5 * cell)), self.fixed_substeps(cell)))

    def check_substeps(self, cell):
        """Refuse parameters whose particles could move more than half a field cell in one
        sub-step of the most the shader allows (SUBSTEP_LIMIT): "no tunnelling" holds or the
        scene is not made."""
        need = self.max_substeps(cell)
        if need > SUBSTEP_LIMIT:
            raise ParameterError(
                f"dt {self.dt:g} with max speed {self.max_speed:g} and field cells of "
                f"{cell:.3g} needs up to {need} sub-steps of half a cell to rule out "
                f"tunnelling; at most {SUBSTEP_LIMIT}: lower --dt or use a coarser "
                f"--field-resolution")
        return need

    def fixed_substeps(self, cell):
        """0 (each particle picks its sub-step count from its speed), or one count for all.

        With gravity alone, semi-implicit Euler loses g^2 h^2 / 2 of energy per sub-step whatever
        h is, so each particle may choose its count from its own speed. With a spring, a count
        that follows the phase (few sub-steps at the centre, many at the turning points) pumps
        energy: measured, 4.3x in 100 steps at omega dt = 10. So a spring fixes the count from
        the fastest possible particle, and omega h <= 0.5 keeps symplectic Euler's energy within
        a few percent. The fastest possible particle is one at the velocity range's edge.
        """
        if self.spring[2] == 0:
            return 0.0
        omega = np.sqrt(self.spring[2])
        return float(np.ceil(max(self.max_speed * np.sqrt(2) * self.dt / (0.5 * cell),
                                 2 * omega * self.dt)))

    def life_uniforms(self):
        """Uniforms of the life cycle (age, respawn): every pass uses them."""
        return {
            "u_dt": float(self.dt), "u_emit": 1.0 if self.emit else 0.0,
            "u_emitter": (*map(float, self.emitter), float(self.direction), float(self.spread)),
            "u_speed": tuple(map(float, self.speed)), "u_lifetime": tuple(map(float, self.lifetime)),
        }

    def motion_uniforms(self, field):
        """Uniforms of forces, integration and collision: the velocity and position passes."""
        x0, y0, x1, y1 = field.rect
        return {
            "u_fixed_substeps": self.fixed_substeps(field.cell),
            "u_gravity": tuple(map(float, self.gravity)), "u_drag": float(self.drag),
            "u_max_speed": float(self.max_speed),
            "u_spring": tuple(map(float, self.spring)), "u_sliding": float(self.sliding),
            "u_bounce": float(self.bounce), "u_cell": float(field.cell),
            "u_field_rect": (x0, y0, x1 - x0, y1 - y0),
            "u_field_cells": tuple(map(float, field.resolution)),
            "u_field_range": tuple(map(float, field.range)),
        }


class Collision(Scene):
    """A fountain bouncing off objects described by a distance/normal field."""

    name = "collision"
    view = RECT
    render_reads = ("position", "life")  # life: fade with age; unborn and dead are not drawn

    def __init__(self, shape="circle", physics=Physics(), field_resolution=(256, 256), field=None):
        self.physics = physics
        if field is None:
            # Refuse what the sub-steps cannot honour before the (costly) field is made.
            physics.check_substeps(cell_size(RECT, field_resolution))
            shapes, mask = parse_shape(shape, RECT)
            field = CollisionField(RECT, shapes, mask, field_resolution)
        self.field = field
        self.max_substeps = physics.check_substeps(field.cell)
        # Steady from the first frame: run one longest lifetime before it (see start). 2^17
        # particles: the sub-stepped passes cost ~20x de Jong's per particle. Dithered rounding:
        # a slow particle's sub-code moves are kept on average.
        steps = steady_steps(physics) if physics.emit else 0
        self.defaults = Defaults(particles=2 ** 17, point_size=2.0, steps=steps, rounding="dither")

    @classmethod
    def add_arguments(cls, parser):
        add = parser.add_argument
        add("--shape", default="circle", help="circle, box, capsule, a union such as circle+box, "
            "or a PNG mask (dark or opaque pixels are solid) stretched over the scene (default "
            "circle)")
        add("--field-resolution", type=int, default=256,
            help="collision field cells per side (default 256)")
        add("--dt", type=float, default=1 / 60, help="time step in seconds (default 1/60)")
        add("--gravity", type=float, default=3.0, help="downward acceleration (default 3)")
        add("--drag", type=float, default=0.05, help="drag coefficient k (default 0.05)")
        add("--sliding", type=float, default=0.5,
            help="sliding factor (mass) in [0, 1] (default 0.5)")
        add("--bounce", type=float, default=0.6, help="bouncing resistance r (default 0.6)")
        add("--lifetime", type=float, nargs=2, default=(3.0, 5.0), metavar=("MIN", "MAX"),
            help="lifetime range in seconds (default 3 5; at most 32512 steps of --dt)")
        add("--speed", type=float, nargs=2, default=(2.6, 3.2), metavar=("MIN", "MAX"),
            help="emission speed range (default 2.6 3.2)")

    @classmethod
    def from_args(cls, args):
        if args.lifetime[0] < 0 or args.lifetime[1] < 0:
            raise ParameterError(f"lifetime must be positive, got {tuple(args.lifetime)}")
        check_range("gravity", args.gravity, -1e4, 1e4)  # before the sign turns: name what was typed
        physics = Physics(dt=args.dt, gravity=(0.0, -args.gravity), drag=args.drag,
                          sliding=args.sliding, bounce=args.bounce, lifetime=tuple(args.lifetime),
                          speed=tuple(args.speed))
        res = int(check_range("field-resolution", args.field_resolution, 8, 4096, integer=True))
        return cls(args.shape, physics, (res, res))

    def graph(self):
        p = self.physics
        g = PassGraph()
        g.quantity("position", RECT[:2], RECT[2:])
        g.quantity("velocity", -p.max_speed, p.max_speed)
        g.quantity("life", *life_range(p.dt), storage="rgba8")
        g.texture("field", self.field.texels())
        state = ("position", "velocity", "life")
        motion = {**p.life_uniforms(), **p.motion_uniforms(self.field)}
        for name in ("velocity", "position"):
            g.add(name, "collision.frag", writes=name, reads=state, textures=["field"],
                  uniforms=motion, defines={f"WRITE_{name.upper()}": None,
                                            "MAX_SUBSTEPS": self.max_substeps})
        # The life pass only ages and respawns: no forces, no field.
        g.add("life", "collision.frag", writes="life", reads=state, uniforms=p.life_uniforms(),
              defines={"WRITE_LIFE": None})
        return g

    def start(self, count, rng):
        p = self.physics
        if p.emit:
            life = staggered_births(count, p.lifetime, rng)
        else:  # born now, living as long as the range allows
            life = np.tile([0.0, p.max_age], (count, 1))
        return {"life": life, "position": np.tile(p.emitter, (count, 1))}

    def describe(self):
        from ..fields.field2d import memory_table

        f, p = self.field, self.physics
        w, h = f.resolution
        lines = [f"collision field: {w}x{h} cells of {f.cell:.4g} (RGBA8: packed distance within "
                 f"+-{f.max_distance:g}, 8-bit normal), {w * h * 4} bytes; made once in numpy",
                 f"physics: dt {p.dt:.4g}, sub-steps of at most half a cell (<= {self.max_substeps}), "
                 f"gravity {p.gravity}, drag {p.drag:g} (exact), sliding {p.sliding:g}, "
                 f"bounce {p.bounce:g}"]
        if p.spring[2] == 0:
            lines.append("no acceleration pass: forces are uniforms evaluated at every sub-step")
        lines.append("field memory by format (bytes): " + "; ".join(
            f"{res}: " + ", ".join(f"{fmt} {b}" for fmt, b in sizes.items())
            for res, sizes in memory_table()))
        return lines

    def background(self):
        """An RGBA image of the objects (h, w, 4), drawn under the particles."""
        shade = np.zeros(self.field.solid.shape + (4,), np.uint8)
        shade[self.field.solid] = (46, 58, 84, 255)
        edge = self.field.solid & (self.field.distance > -2 * self.field.cell)
        shade[edge] = (110, 130, 170, 255)
        return shade
