"""The flame: the article's last repository demo, a raymarched flame, here an emission and
absorption integral through a volume (``render/flame.py``) whose density and temperature come
from one of three sources:

- ``noise``: no particles, the author's field (a stretched sphere's distance displaced by two
  octaves of noise rising with time), made a density with a soft edge, hotter at its core and
  base;
- ``smoke``: the smoke scene's particles (``smoke.py``: an orbiting emitter, buoyant particles
  riding a divergence-free flow), splatted each frame into a grid of cells, a cell's density
  its particles' count and its temperature their mean heat (1 at birth, cooling to 0 at the end
  of life): a flame driven by a simulation;
- ``wind``: the wind field's fluid in 3D (``air.py``: stable fluids on a MAC grid of
  ``--cells``^3 over the box, open at the top, slip walls elsewhere), carrying a fire,
  (density, temperature) at the cells, fed at a burner on the floor; its heat lifts the air, vorticity confinement
  keeps its curls, and it cools and fades as it rises: a flame of a simulated fluid.

Each is coloured by a blackbody ramp (Planck's law at three wavelengths, 1,000 to 3,000 K).
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..frame.graph import PassGraph
from ..frame.settings import Defaults
from ..params import param
from ..render.flame import MAX_STEPS, Flame as FlameRendering, flame_light
from ..render.shafts import ShaftParams
from .air import ADVECTIONS, WALL_KINDS, Air, Fire, carried_faces
from .base import Scene, clamp_report
from .emitter import CAMERAS, camera_of, eye, target

SOURCES = ("noise", "smoke", "wind")
# The parameters only some sources use: each given with another source is refused in one line.
USED_BY = {"shape": ("noise",), "rise": ("noise",), "cells": ("smoke", "wind"),
           "burner": ("wind",), "buoyancy": ("wind",), "cooling": ("wind",),
           "vorticity": ("wind",), "pressure_iterations": ("wind",), "max_speed": ("wind",),
           "advection": ("wind",)}
# The wind flame's air: open at the top, slip walls elsewhere (x0, x1, y0, y1, z0, z1); with
# open sides strong confinement grew sooner at their edges, where air is drawn in.
WIND_WALLS = tuple(WALL_KINDS["open" if side == 3 else "slip"] for side in range(6))
WIND_STEPS = 90  # three seconds at the default dt: the fire has risen to the top of the box
STILL_AIR = 0.02  # m/s: the largest stir of the wind flame's air at the start (--seed)
# The smoke scene's parameters for a flame: short lives, a tight fast orbit at the floor, strong
# buoyancy, and its sphere still and out of the way above the flame.
SMOKE = {"lifetime": (1.0, 1.6), "emitter": (0.0, 0.3, 0.0, 0.2), "emission": (1.5, 0.25),
         "wind": (0.0, 1.2, 0.0), "gravity": (0.0, 1.5, 0.0), "tau": 0.15,
         "noise": (0.3, 1.4, 0.6, 1.0), "sphere": (0.0, 7.0, 0.0, 0.2),
         "sway": (0.0, 0.0, 0.0, 7.0)}
SMOKE_BOX = ((-1.5, 0.0, -1.5), (1.5, 3.5, 1.5))


@dataclass(frozen=True)
class FlameParams(ShaftParams):
    """The flame's parameters (metres, seconds), and the light shafts it lights."""

    source: str = param("noise", choices=SOURCES,
                        help="the density and temperature: noise (the author's field, no "
                             "particles), smoke (the smoke scene's particles splatted into a "
                             "grid) or wind (a 3D fluid carrying a fire fed at a burner)")
    march_steps: int = param(64, 1, MAX_STEPS, integer=True,
                             help="segments a ray through the flame's box")
    march_jitter: str = param("on", choices=("on", "off"),
                              help="dither each ray's samples by a 4x4 Bayer pattern and the "
                                   "frame (banding becomes noise), or take midpoints")
    dt: float = param(1 / 30, 1e-4, 0.25, unit="s", help="time step")
    extinction: float = param(2.5, 1e-3, 1e3, unit="1/m",
                              help="light absorbed a metre at density 1")
    emission: float = param(10.0, 0.0, 1e3, unit="1/m",
                            help="light emitted a metre at density 1, times the blackbody colour")
    shape: tuple = param((0.45, 2.0, 0.3, 3.0), (0.05, 0.1, 0.0, 0.01), (5.0, 10.0, 5.0, 100.0),
                         count=4, unit="m, 1/m", metavar="RADIUS,HEIGHT,FLICKER,FREQUENCY",
                         help="the noise flame: its radius and height, how far the noise moves "
                              "its surface at the top, and the noise's frequency")
    rise: float = param(1.5, 0.0, 100.0, unit="m/s", help="how fast the noise flame's noise rises")
    cells: int = param(48, 2, 128, integer=True,
                       help="the smoke or wind flame's grid: cells a side of its box")
    burner: tuple = param((0.0, 0.1, 0.0, 0.5), (-1.5, 0.0, -1.5, 0.05), (1.5, 3.5, 1.5, 1.5),
                          count=4, unit="m", metavar="X,Y,Z,RADIUS",
                          help="the wind flame's burner, where its fire is fed: a flat ball "
                               "(half as high as wide) at X,Y,Z in the box")
    buoyancy: float = param(10.0, 0.0, 100.0, unit="m/s^2",
                            help="the wind flame's lift: the upward acceleration of air at "
                                 "temperature 1 (3,000 K)")
    cooling: tuple = param((1.6, 0.6), 0.0, 100.0, count=2, unit="1/s",
                           metavar="TEMPERATURE,DENSITY",
                           help="the wind flame's fire cools and fades as it rises: the rate "
                                "its temperature and its density fall, per second")
    vorticity: float = param(1.0, 0.0, 100.0,
                             help="the wind flame's vorticity confinement epsilon (0: off): "
                                  "curls kept from the grid's numerical diffusion")
    pressure_iterations: int = param(40, 1, 10000, integer=True,
                                     help="the wind flame's Jacobi iterations of the pressure "
                                          "a step")
    max_speed: float = param(8.0, 1e-3, 1e3, unit="m/s",
                             help="the wind flame's air speed range: faster air is clamped")
    advection: str = param("semi-lagrangian", choices=ADVECTIONS,
                           help="how the wind flame's air carries itself and its fire: "
                                "semi-Lagrangian (one trilinear backtrace) or MacCormack "
                                "(ahead, behind, a correction limited to the 8 values around "
                                "the backtrace: less numerical diffusion)")
    # the flame is a bright light, its whole body the shafts' source: a quarter of the sky's
    shaft_exposure: float = param(0.05, 0.0, 10.0, help="the shafts' brightness")
    camera: str = param("fixed", choices=CAMERAS,
                        help="fixed, or orbit: circle the target once over an animation")
    eye: tuple = eye((0.0, 1.4, 5.2))
    target: tuple = target((0.0, 1.2, 0.0))
    fov: float = param(45.0, 1.0, 120.0, unit="degrees",
                       help="the camera's vertical field of view")

    def check(self):
        super().check()
        if np.allclose(self.eye, self.target):
            raise ParameterError("--eye and --target must differ")
        declared = self.declarations()
        for name, sources in USED_BY.items():
            if self.source not in sources and getattr(self, name) != declared[name].default:
                raise ParameterError(f"{declared[name].flag_name}: --source {self.source} does "
                                     f"not use it; give --source {' or '.join(sources)} with it")

    @property
    def box(self):
        """The march's box: the noise flame's reach (its radius and height, plus the most the
        noise moves its surface), or the smoke's and the wind's grid."""
        if self.source != "noise":
            return SMOKE_BOX
        radius, height, flicker, _ = self.shape
        reach = radius + 1.5 * flicker
        return (-reach, 0.0, -reach), (reach, height + 1.5 * flicker, reach)


class Flame(Scene):
    """A raymarched flame from noise, the smoke's particles or a 3D fluid's fire."""

    name, Params, renders = "flame", FlameParams, FlameRendering
    defaults = Defaults(particles=2 ** 16, point_size=1.0, steps=30, rounding="dither")

    def __init__(self, params=None, **given):
        super().__init__(params, **given)
        self.smoke = self.air = None
        p = self.params
        if p.source == "smoke":
            from .smoke import Smoke, SmokeParams

            self.smoke = Smoke(SmokeParams(dt=p.dt, **SMOKE))
            self.defaults = Defaults(2 ** 16, 1.0, self.smoke.defaults.steps, "dither")
        elif p.source == "wind":
            lo, hi = p.box
            cooling, fading = p.cooling
            keep = (float(np.exp(-fading * p.dt)), float(np.exp(-cooling * p.dt)))
            self.air = Air((p.cells,) * 3, lo, hi, p.dt, p.max_speed, WIND_WALLS,
                           pressure_iterations=p.pressure_iterations, vorticity=p.vorticity,
                           fire=Fire(p.burner, keep=keep, buoyancy=p.buoyancy),
                           advection=p.advection)
            self.defaults = Defaults(0, 1.0, WIND_STEPS, "dither")

    @classmethod
    def default_text(cls, setting):
        if setting == "steps":
            return (f"30, a second (noise); one longest lifetime (smoke); {WIND_STEPS}, three "
                    "seconds (wind)")
        if setting == "particles":
            return "none (noise, wind), 2^16 (smoke)"
        return super().default_text(setting)

    def graph(self, caps=None):
        if self.smoke:
            return self.smoke.graph(caps)
        g = PassGraph()
        if self.air:
            self.air.declare(g)
        return g

    def start(self, count, rng):
        """The smoke's particles; the wind flame's air stirred by at most 0.02 m/s a face
        (still where a face is blocked): a still start would rise as one symmetric plume."""
        if self.smoke:
            return self.smoke.start(count, rng)
        if not self.air:
            return {}
        return {c: np.where(blocked, 0.0, rng.uniform(-STILL_AIR, STILL_AIR, blocked.shape))
                [..., None] for c, blocked in zip("uvw", self.air.blocked())}

    def after_run(self, sim):
        """Quantities clamped at their range's edge, said once: the wind flame's air with what
        to change (its confinement, strong, grows without bound: measured at --vorticity 8, and
        at the default under MacCormack's scheme, which damps less). MacCormack's ahead and
        behind faces are left out: interpolated from the faces, they reach the edge only where
        the faces did."""
        hint = "raise --max-speed, or lower --vorticity (strong confinement grows without bound)"
        if self.air and self.params.advection == "maccormack":
            hint = ("raise --max-speed, or lower --vorticity (under --advection maccormack, "
                    "which damps less, confinement grows without bound sooner: try 0)")
        return clamp_report(sim, skip=carried_faces(sim),
                            hints={c: hint for c in "uvw"} if self.air else None)

    def camera_at(self, frame, frames):
        return camera_of(self.params, frame, frames)

    def rendering(self):
        p = self.params
        lo, hi = p.box
        return FlameRendering(
            source={"noise": "noise", "smoke": "grid", "wind": "state"}[p.source], lo=lo, hi=hi,
            steps=p.march_steps,
            jitter=p.march_jitter == "on", extinction=p.extinction, emission=p.emission,
            shape=p.shape, rise=p.rise, dt=p.dt, cells=p.cells, fov=p.fov,
            shafts=p.shafts_declared(flame_light(lo, hi)))

    def describe(self):
        p = self.params
        if self.air:
            field = (f"a fire carried by {p.cells}^3 cells of air (--pressure-iterations "
                     f"{p.pressure_iterations}, --vorticity {p.vorticity:g}), fed at the burner "
                     f"({', '.join(f'{v:g}' for v in p.burner[:3])}) of radius {p.burner[3]:g} m, "
                     f"lifted by {p.buoyancy:g} m/s^2 at temperature 1, cooling at "
                     f"{p.cooling[0]:g}/s and fading at {p.cooling[1]:g}/s")
        elif self.smoke:
            field = (f"the smoke's particles splatted into {p.cells}^3 cells each frame "
                     f"({self.smoke.params.lifetime[0]:g}-{self.smoke.params.lifetime[1]:g} s "
                     "lives, heat 1 at birth to 0 at the end)")
        else:
            field = ("noise: a sphere of radius {:g} m stretched to {:g} m, its surface moved up "
                     "to {:g} m by noise of {:g}/m rising at {:g} m/s").format(*p.shape, p.rise)
        return super().describe() + [f"field: {field}"]
