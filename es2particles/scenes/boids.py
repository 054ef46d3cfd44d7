"""Boids (Reynolds 1987) in 2D or 3D (``--dimensions``): separation, alignment and cohesion, each
within its own radius, through a neighbour grid (``frame/neighbours.py``; in 3D its 3 x 3 x 3
cells): the first scene whose particles see each other. GLSL: ``boids/boids.frag`` (a velocity
pass, then a position pass). 2D boids are drawn as density points over the box; 3D boids as
sprites seen from a camera outside the box.

Each boid sums, over the others within a radius: separation, the away directions weighted by
1 / distance (within --radii's first); alignment, the mean velocity less its own (second);
cohesion, the direction to the mean position (third). The velocity changes by dt times their
--weights, its speed is held in --speed's [MIN, MAX], and a boid nearer a wall than the
cohesion radius turns away from it. The flock's order parameter (the norm of the mean unit
velocity: 0 for random headings, 1 for one heading) is said at the end of a run.
"""

from dataclasses import dataclass, replace

import numpy as np

from ..errors import ParameterError
from ..frame.graph import PassGraph
from ..frame.settings import Defaults
from ..params import Params, param
from ..render.camera import looking_at
from ..render.sprites import Sprites
from .base import Scene


POINT_SIZE_3D = 12.0  # 3D boids are darts 12 pixels across in a picture 1024 high: their heading shows


@dataclass(frozen=True)
class BoidsParams(Params):
    """The flock's parameters (world units: the box's)."""

    dimensions: int = param(2, 2, 3, integer=True, help="2 or 3")
    box: tuple = param(None, 0.01, 1e4, count=(2, 3), optional=True, metavar="W,H[,D]",
                       help="the box from the origin (none: 4,4 in 2D, 1,1,1 in 3D, the "
                            "default flock's density of about 8 within the radii; in 3D D "
                            "defaults to H)")
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

    @property
    def extent(self):
        """The box's sides, one a dimension (none given: 4 x 4, or 1 x 1 x 1; 3D: D is H
        unless given)."""
        if self.box is None:
            return (4.0, 4.0) if self.dimensions == 2 else (1.0, 1.0, 1.0)
        box = tuple(float(v) for v in self.box)
        return box if len(box) == self.dimensions else box + (box[1],)

    def check(self):
        if self.dimensions == 2 and self.box is not None and len(self.box) == 3:
            raise ParameterError(f"--box has a depth ({self.box[2]:g}) but --dimensions is 2: "
                                 "give W,H, or --dimensions 3")
        lo, hi = self.speed
        if not 0 <= lo <= hi or hi <= 0:
            raise ParameterError(f"--speed must be MIN,MAX with 0 <= MIN <= MAX and MAX > 0, "
                                 f"got {lo:g},{hi:g}")
        reach = max(self.radii)
        if reach > min(self.extent) / 2:
            raise ParameterError(f"--radii: the largest, {reach:g}, must be at most half the "
                                 f"--box's shorter side ({min(self.extent) / 2:g}): every boid "
                                 "would see the whole box")


class Boids(Scene):
    """A flock: separation, alignment and cohesion through a neighbour grid."""

    name = "boids"
    Params = BoidsParams
    defaults = Defaults(particles=2 ** 14, point_size=2.0, steps=300)

    def __init__(self, params=None, **given):
        super().__init__(params, **given)
        box = self.params.extent
        self.view = (0.0, 0.0, box[0], box[1])
        if self.params.dimensions == 3:
            self.defaults = replace(self.defaults, point_size=POINT_SIZE_3D)

    @classmethod
    def default_text(cls, setting):
        if setting == "point_size":
            return f"{cls.defaults.point_size:g} (3D: {POINT_SIZE_3D:g})"
        if setting == "gradient":  # 3D boids are sprites, drawn in colour
            return f"{cls.defaults.gradient} (3D: none)"
        return super().default_text(setting)

    @classmethod
    def at_density(cls, count, dimensions=2):
        """The flock of ``count`` boids at the defaults' density (16,384 in 4 x 4, or in the unit
        cube): the box grown or shrunk with the count."""
        side = (4.0 if dimensions == 2 else 1.0) * (count / cls.defaults.particles) ** (
            1 / dimensions)
        return cls(dimensions=dimensions, box=(side,) * dimensions)

    def graph(self, caps=None):
        p = self.params
        box, top, d = p.extent, p.speed[1], p.dimensions
        g = PassGraph()
        g.quantity("position", (0.0,) * d, box)
        g.quantity("velocity", -top, top, components=d)
        g.neighbours("flock", "position", cell=max(p.radii), bound=p.bound,
                     sets="the largest of --radii")
        rules = {"u_radii": tuple(map(float, p.radii)), "u_weights": tuple(map(float, p.weights)),
                 "u_speed": tuple(map(float, p.speed)), "u_box": box, "u_dt": float(p.dt)}
        defines = {"BOIDS_3D": None} if d == 3 else {}
        g.add("velocity", "boids/boids.frag", writes="velocity", reads=["position", "velocity"],
              neighbours="flock", uniforms=rules, defines={**defines, "WRITE_VELOCITY": None})
        g.add("position", "boids/boids.frag", writes="position", reads=["position"],
              reads_new=["velocity"], uniforms={"u_box": box, "u_dt": rules["u_dt"]},
              defines=defines)
        return g

    def start(self, count, rng):
        """Random places in the box, random headings (uniform over the circle, or the sphere)
        at speeds within --speed."""
        p = self.params
        if p.dimensions == 2:
            angle = rng.uniform(0, 2 * np.pi, count)
            heading = np.stack([np.cos(angle), np.sin(angle)], 1)
        else:
            heading = rng.normal(size=(count, 3))
            heading /= np.maximum(np.linalg.norm(heading, axis=1, keepdims=True), 1e-300)
        speed = rng.uniform(*p.speed, count)
        return {"position": rng.random((count, p.dimensions)) * p.extent,
                "velocity": heading * speed[:, None]}

    def rendering(self):
        if self.params.dimensions == 2:
            return super().rendering()
        # Darts turned the way each boid flies, as it looks from the camera.
        return Sprites(sprite="arrow", size_spread=0.0,
                       attenuation=(0.0, 0.0, 1.0 / self._distance ** 2), blend="add",
                       tint=(0.55, 0.75, 1.0, 1.0), opacity=0.6, background=(0.02, 0.03, 0.05),
                       roles={"position": "position", "heading": "velocity"})

    @property
    def _distance(self):
        box = np.array(self.params.extent)
        return 1.9 * float(box.max())

    def camera_at(self, frame, frames):
        """3D: the box's centre seen from in front, a little above and to the right."""
        return looking_at(np.array(self.params.extent) / 2, (0.35, 0.3, 1.0), self._distance)

    def after_run(self, sim):
        return super().after_run(sim) + [f"order parameter |mean unit velocity|: {order_parameter(sim.download('velocity')):.3f} "
                f"after {sim.steps_done} steps (0: random headings, 1: one heading)"]


def order_parameter(velocity):
    """The norm of the mean of the unit velocities (float64)."""
    v = np.asarray(velocity, np.float64)
    speed = np.linalg.norm(v, axis=1, keepdims=True)
    return float(np.linalg.norm((v / np.maximum(speed, 1e-300)).mean(axis=0)))
