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

from ..errors import ParameterError
from ..fields.field2d import CollisionField, cell_size, parse_shape
from ..frame.graph import PassGraph
from ..frame.settings import Defaults
from ..params import Params, param
from ..twins.life import LIFE_STEPS, life_range, longest_life, staggered_births
from .base import Scene

RECT = (-1.0, -1.0, 1.0, 1.0)
# The most sub-steps a particle's step may take: a loop bound compiled into the shader (ES 1.00
# loops need a constant one). A scene whose particles could need more is refused.
SUBSTEP_LIMIT = 4096
SUBSTEPS, FIELD_CELLS = "sub-steps a step", "field cells"  # costs named in base.COSTS


@dataclass(frozen=True)
class CollisionParams(Params):
    """The scene's parameters (scene units: the view is [-1, 1]^2; seconds). Fields declared
    with ``option=False`` are the report's and the tests' knobs."""

    shape: str = param("circle", text=True, metavar="SHAPE[+SHAPE...]|MASK.png",
                       help="circle, box, capsule, a union such as circle+box, or a PNG mask "
                            "(dark or opaque pixels are solid) stretched over the scene")
    field_resolution: int = param(256, 8, 4096, integer=True,
                                  help="collision field cells per side")
    dt: float = param(1 / 60, 1e-6, 1.0, unit="s", help="time step")
    gravity: tuple = param((0.0, -3.0), -1e4, 1e4, count=2, unit="units/s^2",
                           help="the acceleration of gravity (a vector, as in every scene)")
    drag: float = param(0.05, 0.0, 1e6, unit="1/s", help="drag k of v' = -k v (exact)")
    sliding: float = param(0.5, 0.0, 1.0, help="the chapter's sliding factor (its mass): 1 "
                                               "bounces along the normal, 0 slides")
    bounce: float = param(0.6, 0.0, 2.0, help="the chapter's bouncing resistance r")
    lifetime: tuple = param((3.0, 5.0), 1e-6, None, count=2, unit="s", metavar="MIN,MAX",
                            help="lifetime range (at most 32512 steps of --dt)")
    speed: tuple = param((2.6, 3.2), 0.0, 8.0, count=2, unit="units/s", metavar="MIN,MAX",
                         help="emission speed range (at most the velocity range's 8 units/s)")
    emitter: tuple = param((-0.7, -0.95), -1.0, 1.0, count=2, help="the emitter's place")
    direction: float = param(68.0, -360.0, 360.0, unit="degrees",
                             help="the emission's direction, from +x towards +y")
    spread: float = param(float(np.degrees(0.3)), 0.0, 360.0, unit="degrees",
                          help="the emission's angular spread about its direction")
    spring: tuple = param((0.0, 0.0, 0.0), (-1e4, -1e4, 0.0), (1e4, 1e4, 1e6), count=3,
                          option=False, help="a spring towards x, y of omega^2")
    emit: bool = param(True, flag=True, option=False,
                       help="emit (else every particle is born now and lives on)")
    max_speed: float = param(8.0, 1e-3, 1e4, unit="units/s", option=False,
                             help="the velocity range's bound")

    def check(self):
        lo, hi = self.speed
        if not lo <= hi <= self.max_speed:
            raise ParameterError(f"--speed must be MIN,MAX with 0 <= MIN <= MAX <= "
                                 f"{self.max_speed:g} (the velocity range), got {lo:g},{hi:g}")
        longest = longest_life(self.dt)
        if self.lifetime[1] > longest:
            raise ParameterError(
                f"--lifetime up to {self.lifetime[1]:g} s is {self.lifetime[1] / self.dt:.0f} "
                f"steps of dt {self.dt:g}; the life clock counts whole steps in 16 bits, at most "
                f"{LIFE_STEPS} ({longest:.4g} s at this dt): shorten --lifetime or raise --dt")
        lo, hi = self.lifetime
        if not self.dt <= lo <= hi:
            raise ParameterError(f"--lifetime must be MIN,MAX with dt {self.dt:g} <= MIN <= MAX, "
                                 f"got {lo:g},{hi:g}")

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
            "u_emitter": (*self.emitter, float(np.radians(self.direction)),
                          float(np.radians(self.spread))),
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
    defaults = Defaults(particles=2 ** 17, point_size=2.0, rounding="dither")
    view = RECT
    render_reads = ("position", "life")  # life: fade with age; unborn and dead are not drawn

    Params = CollisionParams
    typical_cost = {FIELD_CELLS: 256 ** 2, SUBSTEPS: 49}

    def cost(self):
        return {FIELD_CELLS: self.params.field_resolution ** 2,
                SUBSTEPS: getattr(self, "max_substeps", 0)}

    def __init__(self, params=None, field=None, **given):
        """``field``: a :class:`~es2particles.fields.field2d.CollisionField` made already, in
        place of the one ``shape`` and ``field_resolution`` make."""
        super().__init__(params, **given)
        p = self.params
        if field is None:
            # Refuse what the sub-steps cannot honour before the (costly) field is made.
            resolution = (p.field_resolution, p.field_resolution)
            p.check_substeps(cell_size(RECT, resolution))
            self.warn_of_cost(FIELD_CELLS)
            shapes, mask = parse_shape(p.shape, RECT)
            field = CollisionField(RECT, shapes, mask, resolution)
        self.field = field
        self.max_substeps = p.check_substeps(field.cell)
        self.warn_of_cost(SUBSTEPS)
        # Steady from the first frame: run one longest lifetime before it (see start). 2^17
        # particles: the sub-stepped passes cost ~20x de Jong's per particle. Dithered rounding:
        # a slow particle's sub-code moves are kept on average.
        steps = int(np.ceil(p.lifetime[1] / p.dt)) if p.emit else 0
        self.defaults = Defaults(particles=2 ** 17, point_size=2.0, steps=steps, rounding="dither")

    @classmethod
    def default_text(cls, setting):
        if setting == "steps":
            return "one longest lifetime (--lifetime MAX / --dt)"
        return super().default_text(setting)

    def graph(self):
        p = self.params
        g = PassGraph()
        g.quantity("position", RECT[:2], RECT[2:], clamps="none")  # the walls are its edges
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
        p = self.params
        if p.emit:
            life = staggered_births(count, p.lifetime, rng)
        else:  # born now, living as long as the range allows
            life = np.tile([0.0, p.max_age], (count, 1))
        return {"life": life, "position": np.tile(p.emitter, (count, 1))}

    def describe(self):
        from ..fields.field2d import memory_table

        f, p = self.field, self.params
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
