"""The Peter de Jong attractor: one pass that iterates the map on every particle's position.

x' = sin(a y) - cos(b x), y' = sin(c x) - cos(d y); the map sends the plane into [-2, 2]^2, which is
the position range, so +2 sits on the top code of the packed range (and stays there).

Two modes: stateful (each step continues from last step's positions; the density converges to the
attractor's invariant measure) and reseed (the article's: each frame restarts from the texel grid
spread over [-2, 2]^2, so only the coefficients carry time). The scene has no velocity or
acceleration: its plan is one pass and one quantity.
"""

import numpy as np

from ..errors import check_range
from ..graph import PassGraph
from .base import Scene

ARTICLE_COEFFICIENTS = (1.4, -2.3, 2.4, -2.1)
RANGE = 2.0


def dejong_map(p, coefficients, iterations=1):
    """numpy twin of ``dejong()`` in ``dejong.frag`` (float64 unless given float32)."""
    a, b, c, d = coefficients
    x, y = p[..., 0], p[..., 1]
    for _ in range(iterations):
        x, y = np.sin(a * y) - np.cos(b * x), np.sin(c * x) - np.cos(d * y)
    return np.stack([x, y], axis=-1)


class DeJong(Scene):
    """The attractor with coefficients (a, b, c, d), optionally animated towards ``animate_to``."""

    name = "dejong"
    view = (-RANGE, -RANGE, RANGE, RANGE)
    default_steps = 20

    def __init__(self, coefficients=ARTICLE_COEFFICIENTS, iterations=3, reseed=False,
                 animate_to=None):
        self.coefficients = tuple(check_range(n, v, -1e4, 1e4)
                                  for n, v in zip("abcd", coefficients))
        self.iterations = int(check_range("iterations", iterations, 1, 64, integer=True))
        self.reseed = bool(reseed)
        self.animate_to = None if animate_to is None else tuple(
            check_range(f"animate-to {n}", v, -1e4, 1e4) for n, v in zip("abcd", animate_to))
        # Stateful runs iterate a chaotic map on the 16-bit grid, where nearest rounding falls
        # into short cycles (measured: 41% distinct positions after 2000 steps of 2^18 particles,
        # density distance 0.085 against a 0.053 noise floor); dithered rounding stays at the
        # floor (99.9% distinct, 0.053). Reseeded frames write once: nearest is exact there.
        self.default_rounding = "nearest" if reseed else "dither"
        self.positions_repeat = self.reseed
        if reseed:
            self.default_steps = 1

    @classmethod
    def add_arguments(cls, parser):
        for name, value in zip("abcd", ARTICLE_COEFFICIENTS):
            parser.add_argument(f"--{name}", type=float, default=value,
                                help=f"coefficient {name} (default {value})")
        parser.add_argument("--iterations", type=int, default=3,
                            help="map iterations inside one pass (default 3, as the article)")
        parser.add_argument("--reseed", action="store_true",
                            help="restart every frame from the texel grid (the article's mode)")
        parser.add_argument("--animate-to", type=_four_floats, metavar="A,B,C,D",
                            help="with --frames: move the coefficients to these over the frames")

    @classmethod
    def from_args(cls, args):
        return cls((args.a, args.b, args.c, args.d), args.iterations, args.reseed, args.animate_to)

    def graph(self):
        g = PassGraph()
        g.quantity("position", -RANGE, RANGE)
        g.add("dejong", "dejong.frag", writes="position",
              reads=() if self.reseed else ("position",),
              uniforms={"u_coefficients": self.coefficients})
        return g

    def defines(self):
        flags = {"ITERATIONS": self.iterations}
        if self.reseed:
            flags["RESEED"] = None
        return flags

    def describe(self):
        return ["de Jong needs no velocity or acceleration, so neither is declared: one quantity "
                "(position), one pass"
                + ("; reseeded: nothing reads last step's position, so one texture" if self.reseed
                   else "")]

    def initialise(self, sim, rng):
        if not self.reseed:
            sim.fill_uniform("position", (-RANGE, -RANGE), (RANGE, RANGE), rng)

    def coefficients_at(self, frame, frames):
        if self.animate_to is None or frames <= 1:
            return self.coefficients
        t = frame / (frames - 1)
        return tuple((1 - t) * a + t * b for a, b in zip(self.coefficients, self.animate_to))

    def before_frame(self, sim, frame, frames):
        sim.set_uniform("u_coefficients", self.coefficients_at(frame, frames))


def _four_floats(text):
    import argparse

    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 4:
        raise argparse.ArgumentTypeError(f"expected four numbers A,B,C,D, got {text!r}")
    return values
