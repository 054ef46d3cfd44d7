"""The flame: the article's last repository demo, a raymarched flame, here an emission and
absorption integral through a volume (``render/flame.py``) whose density and temperature come
from one of two sources:

- ``noise``: no particles, the author's field (a stretched sphere's distance displaced by two
  octaves of noise rising with time), made a density with a soft edge, hotter at its core and
  base;
- ``smoke``: the smoke scene's particles (``smoke.py``: an orbiting emitter, buoyant particles
  riding a divergence-free flow), splatted each frame into a grid of cells, a cell's density
  its particles' count and its temperature their mean heat (1 at birth, cooling to 0 at the end
  of life): a flame driven by a simulation.

Either is coloured by a blackbody ramp (Planck's law at three wavelengths, 800 to 3,000 K).
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..frame.graph import PassGraph
from ..frame.settings import Defaults
from ..params import param
from ..render.flame import MAX_STEPS, Flame as FlameRendering, flame_light
from ..render.shafts import ShaftParams
from .base import Scene
from .emitter import CAMERAS, camera_of, eye, target

SOURCES = ("noise", "smoke", "wind")
NOISE_ONLY = ("shape", "rise")
SMOKE_ONLY = ("cells",)
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
                             "grid) or wind (not built yet: refused)")
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
                       help="the smoke flame's grid: cells a side of its box")
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
        if self.source == "wind":
            raise ParameterError("--source wind is not built yet: the wind field's grid is 2D "
                                 "(x, y), and a flame needs density and temperature in 3D; "
                                 "use --source noise or smoke")
        if np.allclose(self.eye, self.target):
            raise ParameterError("--eye and --target must differ")
        declared = self.declarations()
        other = SMOKE_ONLY if self.source == "noise" else NOISE_ONLY
        for name in other:
            if getattr(self, name) != declared[name].default:
                raise ParameterError(f"{declared[name].flag_name}: --source {self.source} does "
                                     f"not use it; give --source "
                                     f"{'smoke' if self.source == 'noise' else 'noise'} with it")

    @property
    def box(self):
        """The march's box: the noise flame's reach (its radius and height, plus the most the
        noise moves its surface), or the smoke flame's grid."""
        if self.source != "noise":
            return SMOKE_BOX
        radius, height, flicker, _ = self.shape
        reach = radius + 1.5 * flicker
        return (-reach, 0.0, -reach), (reach, height + 1.5 * flicker, reach)


class Flame(Scene):
    """A raymarched flame from noise or from the smoke's particles."""

    name, Params, renders = "flame", FlameParams, FlameRendering
    defaults = Defaults(particles=2 ** 16, point_size=1.0, steps=30, rounding="dither")

    def __init__(self, params=None, **given):
        super().__init__(params, **given)
        self.smoke = None
        if self.params.source == "smoke":
            from .smoke import Smoke, SmokeParams

            self.smoke = Smoke(SmokeParams(dt=self.params.dt, **SMOKE))
            self.defaults = Defaults(2 ** 16, 1.0, self.smoke.defaults.steps, "dither")

    @classmethod
    def default_text(cls, setting):
        if setting == "steps":
            return "30, a second (noise); one longest lifetime (smoke)"
        if setting == "particles":
            return "none (noise), 2^16 (smoke)"
        return super().default_text(setting)

    def graph(self, caps=None):
        return self.smoke.graph(caps) if self.smoke else PassGraph()

    def start(self, count, rng):
        return self.smoke.start(count, rng) if self.smoke else {}

    def camera_at(self, frame, frames):
        return camera_of(self.params, frame, frames)

    def rendering(self):
        p = self.params
        lo, hi = p.box
        return FlameRendering(
            source="grid" if self.smoke else "noise", lo=lo, hi=hi, steps=p.march_steps,
            jitter=p.march_jitter == "on", extinction=p.extinction, emission=p.emission,
            shape=p.shape, rise=p.rise, dt=p.dt, cells=p.cells, fov=p.fov,
            shafts=p.shafts_declared(flame_light(lo, hi)))

    def describe(self):
        p = self.params
        if self.smoke:
            field = (f"the smoke's particles splatted into {p.cells}^3 cells each frame "
                     f"({self.smoke.params.lifetime[0]:g}-{self.smoke.params.lifetime[1]:g} s "
                     "lives, heat 1 at birth to 0 at the end)")
        else:
            field = ("noise: a sphere of radius {:g} m stretched to {:g} m, its surface moved up "
                     "to {:g} m by noise of {:g}/m rising at {:g} m/s").format(*p.shape, p.rise)
        return super().describe() + [f"field: {field}"]
