"""The liquid: the article's second repository demo, Clavet, Beaudoin and Poulin's
"Particle-based Viscoelastic Fluid Simulation" (2005) in 2D, here on the GPU (the article's
author runs it on the CPU and draws with the GPU). GLSL: ``liquid/liquid.frag``.

A step, in passes: gravity and the pairwise viscosity impulses (sigma, beta), the predicted
positions, each particle's density and near density from its neighbours at the predicted
positions, the double density relaxation, the walls and the obstacle circle, and the velocity
from the position change. The paper's loop is sequential (each pair moves both particles at
once, later pairs seeing earlier moves); here each particle gathers what every pair would give it
from the same predicted positions (a Jacobi form of the paper's Gauss-Seidel one), which the
docs measure against a float64 run of the paper's own loop (``tests/clavet_reference.py``).
Two neighbour grids a step: one of the positions (viscosity), one of the predicted positions
(densities, relaxation), cells of side h.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..frame.graph import PassGraph
from ..frame.settings import Defaults
from ..params import Params, param
from ..render.metaballs import MetaballLook, Metaballs
from .base import Control, Push, Scene

SHADER = "liquid/liquid.frag"
# The share of the pairs' summed displacements a particle takes in the gather form. The paper's
# loop moves one particle's pairs at a time, each seeing the moves before it; here all move at
# once from the same predicted positions, and the whole sum overshoots: at the paper's loop's
# stiffness, 900 particles in a box never settled (float64 gather form, 600 steps: mean speed
# 0.36 box/s, surface spread 0.25 box). At 0.7 they settle (0.03 box/s, spread 0.02).
GATHER_SHARE = 0.7
AUTHOR_COUNT = 900  # the author's largest scene: h = 2 sqrt(area / 900), dt = 1/60 s
GRAVITY_TILT = 8.0  # box/s^2: the gravity sliders and keys reach this each way (4 x the default)


@dataclass(frozen=True)
class LiquidPhysics(Params):
    """The liquid's physics (lengths in box units, time in seconds)."""

    box: tuple = param((1.0, 1.0), 0.01, 1e3, count=2, metavar="W,H",
                       help="the container from (0, 0)")
    radius: float = param(None, 1e-4, 1e3, optional=True,
                          help="Clavet's interaction radius h (default: the author's "
                               "2 sqrt(area / particles))")
    rest_density: float = param(5.0, 0.0, 1e3, help="rho0 of the pressure k (rho - rho0)")
    stiffness: float = param(20.0, 0.0, 1e6, unit="1/s^2 per unit density",
                             help="k: the pressure's stiffness (displacement dt^2 k ... x h)")
    near_stiffness: float = param(60.0, 0.0, 1e6, unit="1/s^2",
                                  help="k_near: the near pressure's stiffness")
    viscosity: tuple = param((0.5, 0.3), 0.0, 1e3, count=2, metavar="SIGMA,BETA",
                             help="the linear and quadratic viscosity of the pairwise impulses")
    gravity: tuple = param((0.0, -2.0), -1e3, 1e3, count=2, unit="box/s^2", metavar="X,Y",
                           help="gravity (tilt it: the author's wallpaper follows the "
                                "accelerometer)")
    obstacle: tuple = param((0.5, 0.3, 0.08), -1e3, 1e3, count=3, metavar="X,Y,R",
                            help="the obstacle circle (R 0: none)")
    fill: tuple = param((0.0, 0.0, 0.5, 1.0), 0.0, 1.0, count=4, metavar="X0,Y0,X1,Y1",
                        help="where the liquid starts, as shares of the box")
    dt: float = param(None, 1e-5, 1.0, unit="s", optional=True,
                      help="time step (default: 1/60 s at the author's 900 particles, shorter "
                           "in proportion to h: the liquid holds its depth in h at any count)")
    max_speed: float = param(8.0, 1e-3, 1e4, unit="box/s",
                             help="the velocity range: faster is clamped")
    bound: int = param(2048, 1, 2 ** 16, integer=True,
                       help="the most particles a loop visits in a row of 3 cells")

    def check(self):
        x0, y0, x1, y1 = self.fill
        if not (x1 > x0 and y1 > y0):
            raise ParameterError(f"--fill must be X0,Y0,X1,Y1 with X1 > X0 and Y1 > Y0, got "
                                 f"{self.fill}")
        if self.radius is not None and self.radius > min(self.box) / 2:
            raise ParameterError(f"--radius {self.radius:g} is more than half the --box's "
                                 f"shorter side ({min(self.box) / 2:g}): every particle would "
                                 "see the whole box")


@dataclass(frozen=True)
class LiquidParams(MetaballLook, LiquidPhysics):
    """The liquid's physics, then its metaballs' look (declared by the rendering)."""


class Liquid(Scene):
    """Clavet 2005's liquid: double density relaxation through neighbour grids."""

    name = "liquid"
    Params, renders = LiquidParams, Metaballs
    defaults = Defaults(particles=2 ** 14, steps=600)
    saves = ("rho",)  # the GPU's own densities, at the predicted positions of the last step

    def __init__(self, params=None, **given):
        super().__init__(params, **given)
        w, h = self.params.box
        self.view = (0.0, 0.0, w, h)

    def rendering(self):
        """The author's metaballs over the box."""
        return Metaballs(self.view, self.params.buffer, self.params.colour)

    def radius_for(self, count):
        """h: --radius, or the author's 2 sqrt(area / N)."""
        p = self.params
        if p.radius is not None:
            return p.radius
        return 2.0 * float(np.sqrt(p.box[0] * p.box[1] / (count or self.defaults.particles)))

    def dt_for(self, count):
        """The time step: --dt, or 1/60 s scaled by h over the author's h at 900 particles
        (the compression a column needs, g dt^2 / (k h^2) per layer, stays the same)."""
        p = self.params
        if p.dt is not None:
            return p.dt
        return (1 / 60) * self.radius_for(count) / self.radius_for(AUTHOR_COUNT)

    def graph(self, caps=None, count=None):
        p = self.params
        (w, hb), h, top = p.box, self.radius_for(count), p.max_speed
        if h > min(p.box) / 2:
            raise ParameterError(f"the interaction radius h = {h:.4g} is more than half the "
                                 "--box's shorter side: give --radius or more --particles")
        count = count or self.defaults.particles
        if np.pi * h * h * count / (w * hb) < 1.0:
            raise ParameterError(f"the interaction radius h = {h:.4g} gives {count} particles "
                                 "fewer than one neighbour each even spread over the whole "
                                 "--box: nothing would hold the liquid together; raise --radius "
                                 "or --particles")
        g = PassGraph()
        g.quantity("position", (0.0, 0.0), (w, hb), clamps="none")  # the walls are its edges
        g.quantity("velocity", -top, top)
        # Predictions may leave the box (the walls act after the relaxation, and the velocity
        # follows from the change): a range symmetric about 0 holds the floor exactly.
        g.quantity("predicted", (-2 * w, -2 * hb), (2 * w, 2 * hb))
        # density, near density: 64 is ~13 rho0 at the default, a liquid crushed flat (clamped
        # beyond, said at the end of a run); the codes are 0.001 apart
        g.quantity("rho", 0.0, 64.0, components=2, clamps="hi")  # a lone particle's near is 0
        sets = "h: --radius, or fewer --particles"
        g.neighbours("here", "position", cell=h, bound=p.bound, sets=sets)
        g.neighbours("ahead", "predicted", cell=h, box=((0.0, 0.0), (w, hb)), bound=p.bound,
                     this_step=True, sets=sets)
        dt = {"u_dt": float(self.dt_for(count))}
        g.add("viscosity", SHADER, writes="velocity", reads=["position", "velocity"],
              neighbours="here", defines={"VISCOSITY": None},
              uniforms={**dt, "u_h": h, "u_gravity": tuple(map(float, p.gravity)),
                        "u_viscosity": tuple(map(float, p.viscosity))})
        g.add("predict", SHADER, writes="predicted", reads=["position"], reads_new=["velocity"],
              defines={"PREDICT": None}, uniforms=dt)
        g.add("density", SHADER, writes="rho", reads_new=["predicted"], neighbours="ahead",
              defines={"DENSITY": None}, uniforms={"u_h": h})
        g.add("relax", SHADER, writes="position", reads_new=["predicted", "rho"],
              neighbours="ahead", defines={"RELAX": None},
              uniforms={**dt, "u_h": h, "u_rest": float(p.rest_density),
                        "u_stiffness": (float(p.stiffness) * h, float(p.near_stiffness) * h),
                        "u_share": GATHER_SHARE,
                        "u_obstacle": tuple(map(float, p.obstacle)),
                        "u_push": (0.0, 0.0, 1.0, 0.0), "u_push_velocity": (0.0, 0.0),
                        "u_box": (float(w), float(hb))})
        g.add("velocity", SHADER, writes="velocity", reads_new=["velocity", "position",
                                                                "predicted"],
              defines={"VELOCITY": None}, uniforms=dt)
        return g

    def time_step(self, count):
        return self.dt_for(count)

    def push(self):
        """A hand's drag (the live view, the widget) carries the obstacle: a circle of the
        obstacle's radius (0.08 of the box where --obstacle has none) under the pointer."""
        radius = self.params.obstacle[2] or 0.08 * min(self.params.box)
        return Push("u_push", "u_push_velocity", float(radius))

    def derived(self, state, count):
        """``density`` and ``near_density`` (Clavet's sums over the others within h),
        recomputed in float64 from the saved positions."""
        from ..twins.neighbours import clavet_densities

        density, near = clavet_densities(state["position"], self.radius_for(count))
        return {"density": density[:, None], "near_density": near[:, None]}

    def start(self, count, rng):
        """A block of liquid at rest in --fill's share of the box, on a jittered lattice of
        the author's spacing."""
        p = self.params
        x0, y0, x1, y1 = np.asarray(p.fill) * np.tile(p.box, 2)
        return {"position": np.stack([rng.uniform(x0, x1, count), rng.uniform(y0, y1, count)], 1)}

    def controls(self):
        """Gravity's two components as sliders of the page and keys of a live view (tab picks
        one, +/- tilt it), as the author's wallpaper tilts its gravity with the phone."""
        reach = max(GRAVITY_TILT, *map(abs, self.params.gravity))  # a --gravity beyond: its own
        return super().controls() + [Control(f"gravity {axis}", "u_gravity", k, -reach, reach)
                                     for k, axis in enumerate("xy")]

    def describe(self):
        p = self.params
        h = "2 sqrt(area / N)" if p.radius is None else f"{p.radius:g}"
        return [f"liquid: h = {h}, rho0 {p.rest_density:g}, k {p.stiffness:g}, k_near "
                f"{p.near_stiffness:g}, viscosity sigma {p.viscosity[0]:g} beta "
                f"{p.viscosity[1]:g}, gravity {p.gravity}"] + super().describe()
