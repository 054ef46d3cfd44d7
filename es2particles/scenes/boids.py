"""Boids (Reynolds 1987) in 2D: separation, alignment and cohesion, each within its own radius,
through a neighbour grid (``frame/neighbours.py``): the first scene whose particles see each
other. GLSL: ``boids/boids.frag`` (a velocity pass, then a position pass).

Each boid sums, over the others within a radius: separation, the away directions weighted by
1 / distance (within --radii's first); alignment, the mean velocity less its own (second);
cohesion, the direction to the mean position (third). The velocity changes by dt times their
--weights, its speed is held in --speed's [MIN, MAX], and a boid nearer a wall than the
cohesion radius turns away from it. The flock's order parameter (the norm of the mean unit
velocity: 0 for random headings, 1 for one heading) is said at the end of a run.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..frame.graph import PassGraph
from ..frame.settings import Defaults
from ..params import Params, param
from .base import Scene


@dataclass(frozen=True)
class BoidsParams(Params):
    """The flock's parameters (world units: the box's)."""

    dimensions: int = param(2, 2, 3, integer=True, help="2 (3 is not built yet: refused)")
    box: tuple = param((4.0, 4.0), 0.01, 1e4, count=2, metavar="W,H",
                       help="the box from (0, 0)")
    radii: tuple = param((0.025, 0.05, 0.05), 1e-4, 1e3, count=3,
                         metavar="SEPARATION,ALIGNMENT,COHESION",
                         help="the distance each rule looks (the grid's cells are the largest)")
    weights: tuple = param((0.05, 0.8, 0.6), 0.0, 1e3, count=3, metavar="S,A,C",
                           help="each rule's weight, 1/s")
    speed: tuple = param((0.1, 0.3), 0.0, 1e3, count=2, metavar="MIN,MAX",
                         help="the speeds a boid keeps")
    dt: float = param(1 / 30, 1e-5, 1.0, unit="s", help="time step")
    bound: int = param(2048, 1, 2 ** 16, integer=True,
                       help="the most boids a loop visits in a row of 3 cells (a run refuses "
                            "a crowded row beyond it)")

    def check(self):
        if self.dimensions == 3:
            raise ParameterError("--dimensions 3: 3D boids are not built yet (the neighbour "
                                 "grid is 2D so far); use --dimensions 2")
        lo, hi = self.speed
        if not 0 <= lo <= hi or hi <= 0:
            raise ParameterError(f"--speed must be MIN,MAX with 0 <= MIN <= MAX and MAX > 0, "
                                 f"got {lo:g},{hi:g}")
        reach = max(self.radii)
        if reach > min(self.box) / 2:
            raise ParameterError(f"--radii: the largest, {reach:g}, must be at most half the "
                                 f"--box's shorter side ({min(self.box) / 2:g}): every boid "
                                 "would see the whole box")


class Boids(Scene):
    """A flock: separation, alignment and cohesion through a neighbour grid."""

    name = "boids"
    Params = BoidsParams
    defaults = Defaults(particles=2 ** 14, point_size=2.0, steps=300)

    def __init__(self, params=None, **given):
        super().__init__(params, **given)
        w, h = self.params.box
        self.view = (0.0, 0.0, w, h)

    def graph(self, caps=None):
        p = self.params
        (w, h), top = p.box, p.speed[1]
        g = PassGraph()
        g.quantity("position", (0.0, 0.0), (w, h))
        g.quantity("velocity", -top, top)
        g.neighbours("flock", "position", cell=max(p.radii), bound=p.bound)
        rules = {"u_radii": tuple(map(float, p.radii)), "u_weights": tuple(map(float, p.weights)),
                 "u_speed": tuple(map(float, p.speed)), "u_box": (float(w), float(h)),
                 "u_dt": float(p.dt)}
        g.add("velocity", "boids/boids.frag", writes="velocity", reads=["position", "velocity"],
              neighbours="flock", uniforms=rules, defines={"WRITE_VELOCITY": None})
        g.add("position", "boids/boids.frag", writes="position", reads=["position"],
              reads_new=["velocity"], uniforms={"u_box": rules["u_box"], "u_dt": rules["u_dt"]})
        return g

    def start(self, count, rng):
        """Random places in the box, random headings at speeds within --speed."""
        p = self.params
        angle = rng.uniform(0, 2 * np.pi, count)
        speed = rng.uniform(*p.speed, count)
        return {"position": rng.random((count, 2)) * p.box,
                "velocity": np.stack([np.cos(angle), np.sin(angle)], 1) * speed[:, None]}

    def after_run(self, sim):
        return super().after_run(sim) + [f"order parameter |mean unit velocity|: {order_parameter(sim.download('velocity')):.3f} "
                f"after {sim.steps_done} steps (0: random headings, 1: one heading)"]


def order_parameter(velocity):
    """The norm of the mean of the unit velocities (float64)."""
    v = np.asarray(velocity, np.float64)
    speed = np.linalg.norm(v, axis=1, keepdims=True)
    return float(np.linalg.norm((v / np.maximum(speed, 1e-300)).mean(axis=0)))
