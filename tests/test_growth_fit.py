"""The fit behind the benchmark's growth tables (benchmarks/growth.py): in log-log, one line's
exponent, and a bend only where two joined segments are clearly better. Synthetic float64
curves, no GL; the timings themselves are benchmark output and never tested."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
from growth import fit  # noqa: E402

XS = 2.0 ** np.arange(10, 23)  # the particle sweep's range, one point a doubling


def noise(scale, seed=0):
    """Multiplicative noise of ``scale`` (RMS in the log), as of timings' medians."""
    return np.exp(np.random.default_rng(seed).normal(0, scale, len(XS)))


def bent(before, after, bend):
    """A curve of slope ``before`` up to ``bend`` and ``after`` beyond it, joined there."""
    x = np.log2(XS / bend)
    return 1e-3 * 2.0 ** np.where(x < 0, before * x, after * x)


def test_a_known_bend_and_its_slopes_are_recovered():
    # A fixed cost giving way to a per-particle one: slope 0.1 up to 2^16, then 1.0. Exact data
    # within the knot's grid (2000 steps over the range); with 3% noise, the slopes within 0.1
    # and the bend within a factor 2^0.5.
    for scale, slope_tol, bend_tol in ((0.0, 1e-3, 0.01), (0.03, 0.1, 0.5)):
        f = fit(XS, bent(0.1, 1.0, 2.0 ** 16) * noise(scale))
        assert f.bend is not None, f"no bend found at noise {scale}: {f}"
        assert abs(np.log2(f.bend) - 16) <= bend_tol, f"noise {scale}: bend 2^{np.log2(f.bend)}"
        assert abs(f.before - 0.1) <= slope_tol and abs(f.after - 1.0) <= slope_tol, \
            f"noise {scale}: slopes {f.before:.3f} -> {f.after:.3f}, want 0.1 -> 1.0"


@pytest.mark.slow
def test_a_pure_power_law_has_its_exponent_and_no_bend():
    # 10% noise is what the rule's 10% line RMS sits at: the exponent within 0.03 all the same.
    for exponent in (0.0, 1.0, 2.0):
        for scale in (0.0, 0.05, 0.1):
            f = fit(XS, 1e-3 * XS ** exponent * noise(scale, seed=int(exponent * 10)))
            assert f.bend is None, f"x^{exponent}, noise {scale}: a bend at {f.bend}: {f}"
            assert abs(f.exponent - exponent) <= 0.03, f"x^{exponent}: fitted {f.exponent}"
    # A fixed cost wiggling by 30% (the de Jong step against image sizes 256 to 4096, as
    # measured) does not grow: its two segments' better fit (-0.31 -> 0.14) is noise.
    f = fit([256, 512, 1024, 2048, 4096], [1.80e-3, 1.58e-3, 1.16e-3, 1.37e-3, 1.45e-3])
    assert f.bend is None, f"a flat curve: a bend at {f.bend}: {f}"
