"""Weakly compressible SPH (Monaghan 1994, 2005) in 2D, SI units: a dam break. A column of water
(``--column W,H`` metres in the lower left of a ``--box``) is released at t = 0 under gravity
9.81 m/s^2 along -y. GLSL: ``sph/sph.frag``.

A step: each particle's density by summation (the Wendland C2 kernel, support 2h, h = 1.3
``--spacing``), the acceleration from the Tait pressure p = B ((rho / rho0)^7 - 1) (B = rho0
c0^2 / 7, c0 = 10 sqrt(g H): density varies by about 1%), held at 0 or above (a free surface's
particles lack neighbours, their summed density falls below rho0, and the tension that gives
pulls them into chains and voids: the first runs showed them) and Monaghan's artificial viscosity,
symplectic Euler, and walls that turn a particle's outward velocity back. The time step follows
the CFL condition, dt = 0.25 h / c0, unless ``--dt`` gives one. One neighbour grid a step, cells
of the support 2h. The water's particles start on a square lattice of ``--spacing``; their count
follows from it (``--particles`` is refused beside it). ``--save-state`` holds each particle's
density recomputed in float64 from the saved positions, the steps and the simulated time.
"""

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..frame.graph import PassGraph
from ..frame.settings import Defaults
from ..params import Params, param
from .base import Scene

SHADER = "sph/sph.frag"
G = 9.81
RHO0 = 1000.0  # water, kg/m^3
SMOOTHING = 1.3  # h over the particle spacing


@dataclass(frozen=True)
class SphParams(Params):
    """The dam break's parameters (SI units)."""

    dimensions: int = param(2, 2, 3, integer=True, help="2 (3 is not built yet: refused)")
    box: tuple = param((4.0, 3.0), 0.01, 1e3, count=2, unit="m", metavar="W,H",
                       help="the container from (0, 0)")
    column: tuple = param((1.0, 2.0), 1e-3, 1e3, count=2, unit="m", metavar="W,H",
                          help="the water's starting block, in the container's lower left")
    spacing: float = param(0.025, 1e-4, 1.0, unit="m",
                           help="the particles' starting spacing (the particle count follows)")
    dt: float = param(None, 1e-7, 0.1, unit="s", optional=True,
                      help="time step (default: CFL, 0.25 h / c0)")
    viscosity: float = param(0.1, 0.0, 10.0, help="Monaghan's artificial viscosity alpha")
    restitution: float = param(0.5, 0.0, 1.0,
                               help="the share of its normal speed a particle keeps off a wall")
    bound: int = param(2048, 1, 2 ** 16, integer=True,
                       help="the most particles a loop visits in a row of 3 cells")

    def check(self):
        if self.dimensions == 3:
            raise ParameterError("--dimensions 3: 3D SPH is not built yet (the neighbour grid "
                                 "is 2D so far); use --dimensions 2")
        if self.column[0] > self.box[0] or self.column[1] > self.box[1]:
            raise ParameterError(f"--column {self.column[0]:g},{self.column[1]:g} must fit in the "
                                 f"--box {self.box[0]:g},{self.box[1]:g}")
        if 2 * SMOOTHING * self.spacing > min(self.box) / 2:
            raise ParameterError(f"--spacing {self.spacing:g}: the kernel's support, "
                                 f"{2 * SMOOTHING * self.spacing:g} m, is more than half the "
                                 "--box's shorter side")
        if self.spacing > min(self.column) / 2:
            raise ParameterError(f"--spacing {self.spacing:g} m leaves the --column fewer than "
                                 "2 particles a side")

    @property
    def lattice(self):
        """(nx, ny): the water's particles along each side."""
        return tuple(int(math.floor(c / self.spacing + 1e-9)) for c in self.column)

    @property
    def count(self):
        nx, ny = self.lattice
        return nx * ny

    @property
    def h(self):
        return SMOOTHING * self.spacing

    @property
    def sound(self):
        """c0 = 10 sqrt(g H): the column's fastest free-surface flow, ten times over."""
        return 10.0 * math.sqrt(G * self.column[1])

    @property
    def step(self):
        return self.dt if self.dt is not None else 0.25 * self.h / self.sound


class Sph(Scene):
    """A dam break in weakly compressible SPH, 2D, SI units."""

    name = "sph"
    Params = SphParams
    defaults = Defaults(particles=3200, point_size=2.0, steps=2000, rounding="dither")

    def __init__(self, params=None, **given):
        super().__init__(params, **given)
        w, h = self.params.box
        self.view = (0.0, 0.0, w, h)
        self.defaults = Defaults(particles=self.params.count, point_size=2.0, steps=2000,
                                 rounding="dither")

    def graph(self, caps=None, count=None):
        p = self.params
        if count is not None and count != p.count:
            raise ParameterError(f"--particles {count}: the particle count follows from "
                                 f"--column and --spacing ({p.lattice[0]} x {p.lattice[1]} = "
                                 f"{p.count}); give --spacing instead")
        (w, hb), h, c0 = p.box, p.h, p.sound
        top = 2.0 * math.sqrt(2.0 * G * hb) + c0 * 0.1  # a fall from the box's top, and more
        g = PassGraph()
        g.quantity("position", (0.0, 0.0), (w, hb), clamps="none")  # the walls are its edges
        g.quantity("velocity", -top, top)
        g.quantity("rho", 0.0, 2.0 * RHO0, components=1)  # kg/m^3
        g.neighbours("water", "position", cell=2.0 * h, bound=p.bound)
        kernel = {"u_h": float(h), "u_mass": float(RHO0 * p.spacing ** 2)}
        g.add("density", SHADER, writes="rho", reads=["position"], neighbours="water",
              defines={"DENSITY": None}, uniforms=kernel)
        g.add("acceleration", SHADER, writes="velocity", reads=["position", "velocity"],
              reads_new=["rho"], neighbours="water", defines={"ACCELERATION": None},
              uniforms={**kernel, "u_dt": float(p.step), "u_gravity": (0.0, -G),
                        "u_fluid": (RHO0, RHO0 * c0 * c0 / 7.0, c0),
                        "u_viscosity": float(p.viscosity),
                        "u_restitution": float(p.restitution), "u_box": (float(w), float(hb))})
        g.add("position", SHADER, writes="position", reads=["position"], reads_new=["velocity"],
              defines={"POSITION": None},
              uniforms={"u_dt": float(p.step), "u_box": (float(w), float(hb))})
        return g

    def time_step(self, count):
        return self.params.step

    def start(self, count, rng):
        """The column on a square lattice of --spacing, at rest, each particle moved by up to
        1% of the spacing (from --seed: a lattice's symmetry would otherwise hold)."""
        p = self.params
        nx, ny = p.lattice
        i, j = np.meshgrid(np.arange(nx), np.arange(ny))
        lattice = (np.stack([i.ravel(), j.ravel()], 1) + 0.5) * p.spacing
        jitter = 0.0 if rng is None else rng.uniform(-0.01, 0.01, lattice.shape) * p.spacing
        return {"position": lattice + jitter, "velocity": np.zeros((p.count, 2))}

    def derived(self, state, count):
        """``density`` recomputed in float64 from the saved positions (the same kernel)."""
        from ..twins.neighbours import pairs_within

        p = self.params
        x = state["position"]
        i, j, r = pairs_within(x, 2.0 * p.h)
        w = wendland(r, p.h) * RHO0 * p.spacing ** 2
        self_weight = wendland(np.zeros(1), p.h)[0] * RHO0 * p.spacing ** 2
        n = len(x)
        return {"density": (np.bincount(i, w, n) + np.bincount(j, w, n) + self_weight)[:, None]}

    def describe(self):
        p = self.params
        nx, ny = p.lattice
        return [f"sph: {nx} x {ny} = {p.count} particles {p.spacing:g} m apart, h = {p.h:.4g} m, "
                f"c0 = {p.sound:.3g} m/s, dt = {p.step:.3g} s"
                + (" (CFL 0.25 h / c0)" if p.dt is None else "")] + super().describe()


def wendland(r, h):
    """The Wendland C2 kernel in 2D, support 2h (float64)."""
    q = np.asarray(r, np.float64) / h
    t = np.clip(1.0 - 0.5 * q, 0.0, None)
    return 7.0 / (4.0 * np.pi * h * h) * t ** 4 * (2.0 * q + 1.0)
