"""Weakly compressible SPH (Monaghan 1994, 2005) in 2D or 3D (``--dimensions``), SI units: a dam
break. A column of water (``--column W,H[,D]`` metres in the lower left (and back) corner of a
``--box``) is released at t = 0 under gravity 9.81 m/s^2 along -y. GLSL: ``sph/sph.frag``. In
3D the tank is 1 m deep unless ``--box`` gives D, the column spans it unless ``--column`` gives
D, and the spacing is 5 cm unless given (2D: 2.5 cm); it is drawn as sprites from a camera.

A step: each particle's density by summation (the Wendland C2 kernel of the dimensions, support
2h, h = 1.3
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
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ParameterError
from ..frame.graph import PassGraph
from ..frame.settings import Defaults
from ..params import Params, param
from ..render.camera import looking_at
from ..render.sort import DepthSort
from ..render.sprites import Sprites
from .base import Scene

SHADER = "sph/sph.frag"
G = 9.81
RHO0 = 1000.0  # water, kg/m^3
SMOOTHING = 1.3  # h over the particle spacing
POINT_SIZE_2D = 2.0
SPRITE_PER_METRE = 200.0  # 3D: a sprite's size (in a picture 1024 high) a metre of spacing


@dataclass(frozen=True)
class SphParams(Params):
    """The dam break's parameters (SI units)."""

    dimensions: int = param(2, 2, 3, integer=True, help="2 or 3")
    box: tuple = param((4.0, 3.0), 0.01, 1e3, count=(2, 3), unit="m", metavar="W,H[,D]",
                       help="the container from the origin (3D: D defaults to 1)")
    column: tuple = param((1.0, 2.0), 1e-3, 1e3, count=(2, 3), unit="m", metavar="W,H[,D]",
                          help="the water's starting block, in the container's lower left "
                               "(3D: D defaults to the container's, the column spans it)")
    spacing: float = param(None, 1e-4, 1.0, unit="m", optional=True,
                           help="the particles' starting spacing (the particle count follows; "
                                "none: 0.025 in 2D, 0.05 in 3D)")
    dt: float = param(None, 1e-7, 0.1, unit="s", optional=True,
                      help="time step (default: CFL, 0.25 h / c0)")
    viscosity: float = param(0.1, 0.0, 10.0, help="Monaghan's artificial viscosity alpha")
    restitution: float = param(0.5, 0.0, 1.0,
                               help="the share of its normal speed a particle keeps off a wall")
    bound: int = param(2048, 1, 2 ** 16, integer=True,
                       help="the most particles a loop visits in a row of 3 cells")

    def check(self):
        for name in ("box", "column"):
            if self.dimensions == 2 and len(getattr(self, name)) == 3:
                raise ParameterError(f"--{name} has a depth ({getattr(self, name)[2]:g}) but "
                                     "--dimensions is 2: give W,H, or --dimensions 3")
        box, column = self.tank, self.water
        if any(c > b for c, b in zip(column, box)):
            raise ParameterError(f"--column {_text(column)} must fit in the --box {_text(box)}")
        if 2 * SMOOTHING * self.dx > min(box) / 2:
            raise ParameterError(f"--spacing {self.dx:g}: the kernel's support, "
                                 f"{2 * SMOOTHING * self.dx:g} m, is more than half the "
                                 "--box's shorter side")
        if self.dx > min(column) / 2:
            raise ParameterError(f"--spacing {self.dx:g} m leaves the --column fewer than "
                                 "2 particles a side")
        cells = math.prod(math.ceil(side / (2 * self.h)) for side in box)
        if cells > 2 ** 24:
            raise ParameterError(f"--spacing {self.dx:g} m: the neighbour grid's cells (the "
                                 f"kernel's support, {2 * self.h:g} m) over the --box number "
                                 f"{cells}, more than 2^24: give a larger spacing")

    @property
    def tank(self):
        """The container's sides, one a dimension (3D: 1 m deep unless --box gives D)."""
        box = tuple(map(float, self.box))
        return box if len(box) == self.dimensions else box + (1.0,)

    @property
    def water(self):
        """The column's sides (3D: the tank's depth unless --column gives D)."""
        column = tuple(map(float, self.column))
        return column if len(column) == self.dimensions else column + (self.tank[2],)

    @property
    def dx(self):
        """The starting spacing (none given: 2.5 cm in 2D, 5 cm in 3D)."""
        if self.spacing is not None:
            return float(self.spacing)
        return 0.025 if self.dimensions == 2 else 0.05

    @property
    def lattice(self):
        """(nx, ny[, nz]): the water's particles along each side."""
        return tuple(int(math.floor(c / self.dx + 1e-9)) for c in self.water)

    @property
    def count(self):
        return math.prod(self.lattice)

    @property
    def mass(self):
        """A particle's mass: rho0 dx^d (kg; in 2D, kg a metre of depth)."""
        return RHO0 * self.dx ** self.dimensions

    @property
    def h(self):
        return SMOOTHING * self.dx

    @property
    def sound(self):
        """c0 = 10 sqrt(g H): the column's fastest free-surface flow, ten times over."""
        return 10.0 * math.sqrt(G * self.water[1])

    @property
    def step(self):
        return self.dt if self.dt is not None else 0.25 * self.h / self.sound


class Sph(Scene):
    """A dam break in weakly compressible SPH, 2D or 3D, SI units."""

    name = "sph"
    Params = SphParams
    defaults = Defaults(particles=3200, point_size=2.0, steps=2000, rounding="dither")

    def __init__(self, params=None, **given):
        super().__init__(params, **given)
        p = self.params
        self.view = (0.0, 0.0, p.tank[0], p.tank[1])
        # 3D: sprites as wide as the spacing seen from the camera (they touch at the start)
        size = POINT_SIZE_2D if p.dimensions == 2 else SPRITE_PER_METRE * p.dx
        self.defaults = replace(self.defaults, particles=p.count, point_size=size)

    def graph(self, caps=None, count=None):
        p = self.params
        if count is not None and count != p.count:
            raise ParameterError(f"--particles {count}: the particle count follows from "
                                 f"--column and --spacing ({' x '.join(map(str, p.lattice))} "
                                 f"= {p.count}); give --spacing instead")
        box, h, c0, d = p.tank, p.h, p.sound, p.dimensions
        top = 2.0 * math.sqrt(2.0 * G * box[1]) + c0 * 0.1  # a fall from the box's top, and more
        g = PassGraph()
        g.quantity("position", (0.0,) * d, box, clamps="none")  # the walls are its edges
        g.quantity("velocity", -top, top, components=d)
        g.quantity("rho", 0.0, 2.0 * RHO0, components=1)  # kg/m^3
        g.neighbours("water", "position", cell=2.0 * h, bound=p.bound,
                     sets="twice h, from --spacing")
        kernel = {"u_h": float(h), "u_mass": float(p.mass)}
        dims = {"SPH_3D": None} if d == 3 else {}
        gravity = (0.0, -G, 0.0)[:d]
        g.add("density", SHADER, writes="rho", reads=["position"], neighbours="water",
              defines={**dims, "DENSITY": None}, uniforms=kernel)
        g.add("acceleration", SHADER, writes="velocity", reads=["position", "velocity"],
              reads_new=["rho"], neighbours="water", defines={**dims, "ACCELERATION": None},
              uniforms={**kernel, "u_dt": float(p.step), "u_gravity": gravity,
                        "u_fluid": (RHO0, RHO0 * c0 * c0 / 7.0, c0),
                        "u_viscosity": float(p.viscosity),
                        "u_restitution": float(p.restitution), "u_box": box})
        g.add("position", SHADER, writes="position", reads=["position"], reads_new=["velocity"],
              defines={**dims, "POSITION": None},
              uniforms={"u_dt": float(p.step), "u_box": box})
        return g

    @classmethod
    def default_text(cls, setting):
        if setting == "point_size":
            return f"{POINT_SIZE_2D:g} (3D: {SPRITE_PER_METRE:g} x the spacing in m)"
        if setting == "gradient":  # 3D SPH is sprites, drawn in colour
            return f"{cls.defaults.gradient} (3D: none)"
        return super().default_text(setting)

    def rendering(self):
        if self.params.dimensions == 2:
            return super().rendering()
        from ..render import meshes as shapes

        floor = shapes.floor(1.2 * max(self.params.tank), cell=0.5)  # 0.5 m squares: the scale
        return Sprites(sprite="disc", size_spread=0.0,
                       attenuation=(0.0, 0.0, 1.0 / self._distance ** 2), blend="over",
                       sort=DepthSort(), tint=(0.2, 0.45, 0.95, 1.0), opacity=0.9, meshes=(floor,),
                       background=(0.02, 0.03, 0.05), roles={"position": "position"})

    @property
    def _distance(self):
        return 1.3 * float(max(self.params.tank))

    def camera_at(self, frame, frames):
        """3D: the tank from in front, above and to the right of its middle."""
        return looking_at(np.array(self.params.tank) * [0.5, 0.3, 0.5], (0.3, 0.45, 1.0),
                          self._distance, fov=50.0)

    def time_step(self, count):
        return self.params.step

    def start(self, count, rng):
        """The column on a square lattice of --spacing, at rest, each particle moved by up to
        1% of the spacing (from --seed: a lattice's symmetry would otherwise hold)."""
        p = self.params
        axes = np.meshgrid(*(np.arange(n) for n in p.lattice), indexing="xy")
        lattice = (np.stack([a.ravel() for a in axes], 1) + 0.5) * p.dx
        jitter = 0.0 if rng is None else rng.uniform(-0.01, 0.01, lattice.shape) * p.dx
        return {"position": lattice + jitter, "velocity": np.zeros((p.count, p.dimensions))}

    def derived(self, state, count):
        """``density`` recomputed in float64 from the saved positions (the same kernel)."""
        from ..twins.neighbours import pairs_within

        p = self.params
        x = state["position"]
        i, j, r = pairs_within(x, 2.0 * p.h)
        w = wendland(r, p.h, p.dimensions) * p.mass
        self_weight = wendland(np.zeros(1), p.h, p.dimensions)[0] * p.mass
        n = len(x)
        return {"density": (np.bincount(i, w, n) + np.bincount(j, w, n) + self_weight)[:, None]}

    def describe(self):
        p = self.params
        return [f"sph: {' x '.join(map(str, p.lattice))} = {p.count} particles {p.dx:g} m apart "
                f"({p.dimensions}D), h = {p.h:.4g} m, "
                f"c0 = {p.sound:.3g} m/s, dt = {p.step:.3g} s"
                + (" (CFL 0.25 h / c0)" if p.dt is None else "")] + super().describe()


def wendland(r, h, dimensions=2):
    """The Wendland C2 kernel, support 2h (float64): 7 / (4 pi h^2) in 2D, 21 / (16 pi h^3) in
    3D, times (1 - q/2)^4 (2q + 1), q = r / h."""
    q = np.asarray(r, np.float64) / h
    t = np.clip(1.0 - 0.5 * q, 0.0, None)
    norm = 7.0 / (4.0 * np.pi * h * h) if dimensions == 2 else 21.0 / (16.0 * np.pi * h ** 3)
    return norm * t ** 4 * (2.0 * q + 1.0)


def _text(values):
    return ",".join(f"{v:g}" for v in values)
