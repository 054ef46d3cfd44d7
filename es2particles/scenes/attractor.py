"""The attractor family: a 2D map with four coefficients (a, b, c, d), iterated on every particle.

A member gives its name, its map in GLSL (a file defining ``vec2 attractor_map(vec2 p, vec4 k)``
that includes ``lib/attractor.glsl``, the one main of every member), the same map in numpy, its
default coefficients, and the box the map sends the plane into (the position range and the view).
The family gives the rest: one pass and one quantity, stateful or reseeded runs, iterations per
pass, animation between coefficient sets, the command-line options and the rounding default.

Two modes: stateful (each step continues from last step's positions; the density converges to the
attractor's invariant measure) and reseed (the article's: each frame restarts from the texel grid
spread over the position range, so only the coefficients carry time). No velocity or acceleration:
the plan is one pass and one quantity.
"""

import sys
from dataclasses import dataclass, make_dataclass

import numpy as np

from ..errors import ParameterError
from ..frame.graph import PassGraph
from .base import Defaults, Fill, Scene
from ..params import Params, param

COEFFICIENT_LIMIT = 1e4
CONTROL_LIMIT = 4.0  # the page's sliders: -4 .. 4
MARGIN = 0.05  # of the range's size, each side of the picture
ACCURACY = "one step's float32 error: 0.5 code at |k| 1, 0.7 at 100, 30 at 1e4"


def coefficient(k, default):
    # The article's coefficients lie within +-3; the page keeps the exported position range, so
    # a member whose box grows with its coefficients (Clifford) clamps beyond it.
    return param(default, -COEFFICIENT_LIMIT, COEFFICIENT_LIMIT,
                 help=f"coefficient {'abcd'[k]} ({ACCURACY})",
                 slider=("u_coefficients", k, -CONTROL_LIMIT, CONTROL_LIMIT))


@dataclass(frozen=True)
class AttractorParams(Params):
    """An attractor's parameters; a member's own class sets the coefficients' defaults
    (:meth:`with_coefficients`)."""

    a: float = coefficient(0, 0.0)
    b: float = coefficient(1, 0.0)
    c: float = coefficient(2, 0.0)
    d: float = coefficient(3, 0.0)
    iterations: int = param(3, 1, 64, integer=True,
                            help="map iterations inside one pass (the article's 3)")
    reseed: bool = param(False, flag=True,
                         help="restart every frame from the texel grid (the article's mode)")
    animate_to: tuple = param(None, -COEFFICIENT_LIMIT, COEFFICIENT_LIMIT, count=4,
                              optional=True, metavar="A,B,C,D",
                              help="with --frames: move the coefficients to these over the "
                                   "frames")

    @classmethod
    def with_coefficients(cls, name, values):
        """The Params class of a member whose coefficients default to ``values``."""
        declared = [(n, float, coefficient(k, float(v))) for k, (n, v) in
                    enumerate(zip("abcd", values))]
        made = make_dataclass(name, declared, bases=(cls,), frozen=True)
        made.__module__ = sys._getframe(1).f_globals["__name__"]  # pickles by its module's name
        return made

    @property
    def coefficients(self):
        return (self.a, self.b, self.c, self.d)


class Attractor(Scene):
    """An iterated 2D map with coefficients (a, b, c, d), optionally animated to ``animate_to``.
    ``coefficients`` sets a, b, c and d at once."""

    shader = ""  # the member's GLSL map
    Params = AttractorParams
    # Stateful runs iterate a chaotic map, and what the state drops each step stays in the
    # accumulated density as a floor. On the 16-bit grid nearest rounding fell into short cycles
    # (de Jong: 47% distinct positions after 2000 steps of 2^18 particles); dithered writes left
    # a floor near 3%, jittered reads one of ~0.7% (1.25x numpy's noise at K = 1024;
    # benchmarks/NOTES.md). So the position of a stateful run is 32-bit (``bits=32``: float32's
    # precision over the range, in rgba8 and rgba16f alike), rounded to nearest; reseeded frames
    # write once, and 16 bits draw them exactly.
    defaults = Defaults(steps=20, rounding="nearest")
    reseeded_defaults = Defaults(steps=1, rounding="nearest")
    state_bits = 32  # a stateful run's position (16: the packed format's own, as tests use)

    @staticmethod
    def map(p, k):
        """numpy twin of the member's ``attractor_map`` (float64 unless given float32)."""
        raise NotImplementedError

    @classmethod
    def bounds(cls, k):
        """(x0, y0, x1, y1): a box that holds the map's image for coefficients ``k``."""
        raise NotImplementedError

    def __init__(self, params=None, coefficients=None, **given):
        if coefficients is not None:
            if len(tuple(coefficients)) != 4:
                raise ParameterError(f"coefficients must be four numbers a, b, c, d, got "
                                     f"{tuple(coefficients)}")
            given.update(zip("abcd", coefficients))
        super().__init__(params, **given)
        p = self.params
        self.coefficients, self.iterations = p.coefficients, p.iterations
        self.reseed, self.animate_to = p.reseed, p.animate_to
        boxes = [self.bounds(k) for k in (self.coefficients, self.animate_to) if k is not None]
        # The position range holds the map's image; the view adds a margin of 5% each side, so
        # the attractor does not touch the picture's edges.
        self.range = (min(b[0] for b in boxes), min(b[1] for b in boxes),
                      max(b[2] for b in boxes), max(b[3] for b in boxes))
        x0, y0, x1, y1 = self.range
        mx, my = MARGIN * (x1 - x0), MARGIN * (y1 - y0)
        self.view = (x0 - mx, y0 - my, x1 + mx, y1 + my)
        if self.reseed:
            self.defaults = self.reseeded_defaults
        self.positions_repeat = self.stateless = self.reseed

    @classmethod
    def default_text(cls, setting):
        text = super().default_text(setting)
        if setting in ("steps", "rounding"):
            text += f" ({getattr(cls.reseeded_defaults, setting)} with --reseed)"
        return text

    def graph(self):
        x0, y0, x1, y1 = self.range
        g = PassGraph()
        # the range holds the map's image: a value on its edge is the map's, never a clamp
        g.quantity("position", (x0, y0), (x1, y1), bits=16 if self.reseed else self.state_bits,
                   clamps="none")
        defines = {"ITERATIONS": self.iterations}
        if self.reseed:
            defines["RESEED"] = None
        uniforms = {"u_coefficients": self.coefficients}
        if self.reseed:
            uniforms["u_jitter"] = (0.0, 0.0)
        g.add(self.name, self.shader, writes="position",
              reads=() if self.reseed else ("position",), uniforms=uniforms, defines=defines)
        return g

    def sample_uniforms(self, sample, samples):
        """Reseeded runs shift the grid by a sub-texel offset for each accumulated sample (the
        R2 low-discrepancy sequence, sample 0 unshifted); stateful ones sample by stepping."""
        if not self.reseed:
            return {}
        return {"u_jitter": tuple(float(v) for v in jitter(sample))}

    def start(self, count, rng):
        x0, y0, x1, y1 = self.range
        return {} if self.reseed else {"position": Fill((x0, y0), (x1, y1))}

    def coefficients_at(self, frame, frames):
        if self.animate_to is None or frames <= 1:
            return self.coefficients
        t = frame / (frames - 1)
        return tuple((1 - t) * a + t * b for a, b in zip(self.coefficients, self.animate_to))

    def frame_uniforms(self, frame, frames):
        return {"u_coefficients": self.coefficients_at(frame, frames)}

    def iterate(self, p, iterations=None, coefficients=None):
        """numpy twin of one pass: the map ``iterations`` times, then clamped to the range (as a
        write does). float64 in, float64 out: the independent reference of the tests."""
        k = self.coefficients if coefficients is None else coefficients
        for _ in range(self.iterations if iterations is None else iterations):
            p = self.map(p, k)
        x0, y0, x1, y1 = self.range
        return np.clip(p, (x0, y0), (x1, y1))

    def describe(self):
        return super().describe() + [
                f"{self.name} needs no velocity or acceleration, so neither is declared: one "
                "quantity (position), one pass"
                + ("; reseeded: nothing reads last step's position, so one texture" if self.reseed
                   else "")]


R2 = 1 / np.array([1.32471795724474602596, 1.32471795724474602596 ** 2])  # 1/phi_2, 1/phi_2^2


def jitter(sample):
    """The grid offset (texels, in [-0.5, 0.5)^2) of accumulated sample ``sample``: the R2
    sequence (Roberts 2018), which spreads any number of samples evenly; sample 0 is (0, 0)."""
    return (0.5 + sample * R2) % 1.0 - 0.5
