"""The clamping report (issue 44, item 7): a value written beyond its quantity's range is clamped
to the edge, and a run says once which quantities hold clamped values, with their share and the
range. Counted on the stored codes; checked here against float64 comparisons of the decoded
values, in every storage format, and against a drift that pushes a known share out."""

import numpy as np
import pytest

from es2particles import ParameterError, PassGraph, Simulation
from es2particles.scenes.base import clamp_report


def drifting(clamps="both", bits=16, delta=(0.3, 0.0)):
    g = PassGraph()
    g.quantity("position", (0.0, -1.0), (1.0, 1.0), clamps=clamps, bits=bits)
    g.add("drift", "examples/drift.frag", writes="position", reads=["position"],
          uniforms={"u_delta": delta})
    return g


@pytest.mark.parametrize("fmt, bits", [("rgba8", 16), ("rgba8", 32), ("rgba16f", 16),
                                       ("rgba32f", 16)])
def test_edge_counts_are_the_decoded_values_on_the_edges(gl, fmt, bits):
    """Values drawn across and beyond the range: the codes' counts equal float64 comparisons of
    the downloaded values with the range's ends, per component and edge."""
    rng = np.random.default_rng(44)
    n = 5000
    values = rng.uniform((-0.5, -1.5), (1.5, 1.5), (n, 2))
    values[:50] = (0.0, -1.0)  # exactly on the edges: there, not beyond
    values[50:80] = (1.0, 1.0)
    with Simulation(gl, drifting(bits=bits), n, fmt=fmt) as sim:
        sim.upload("position", values)
        got_lo, got_hi = sim.edge_counts("position")
        stored = sim.download("position")
    want_lo = (stored <= np.array([0.0, -1.0])).sum(axis=0)
    want_hi = (stored >= np.array([1.0, 1.0])).sum(axis=0)
    print(f"{fmt} {bits}-bit: on lo {list(got_lo)}, on hi {list(got_hi)}")
    assert list(got_lo) == list(want_lo) and list(got_hi) == list(want_hi)
    # On the edges: every value at or beyond them (the clamp), and those within the format's
    # rounding of them (a code's half of the span, or half float's 2^-11 at 1): no others.
    lo, hi, step = np.array([0.0, -1.0]), np.array([1.0, 1.0]), {"rgba8": 2 / 65024}.get(
        fmt if bits == 16 else "", 2 ** -11)
    assert np.all((values <= lo).sum(axis=0) <= want_lo)
    assert np.all(want_lo <= (values < lo + step).sum(axis=0))
    assert np.all((values >= hi).sum(axis=0) <= want_hi)
    assert np.all(want_hi <= (values > hi - step).sum(axis=0))


def test_a_drift_beyond_the_range_is_reported_with_its_share(gl):
    """A drift of 0.3 a step from x uniform in [0, 1): after two steps the particles that
    started beyond 0.4 sit on x's top edge; the report says x's share and the range, once."""
    n = 4096
    x = (np.arange(n) + 0.5) / n
    with Simulation(gl, drifting(), n, fmt="rgba8") as sim:
        sim.upload("position", np.stack([x, np.zeros(n)], 1))
        sim.run(2)
        lines = clamp_report(sim, hints={"position": "widen it"})
    share = np.count_nonzero(x + 0.6 >= 1.0) / n  # 40%
    assert lines == [f"position: x {100 * share:.3g}% of its values sit on its range's edge "
                     f"([0, 1], [-1, 1]): written beyond it and clamped; widen it"], lines


def test_edges_the_physics_holds_are_not_reported(gl):
    """clamps="lo" reports only the top edge, "none" nothing; a still run reports nothing."""
    n = 1024
    start = np.stack([np.linspace(0.0, 0.5, n), np.full(n, -1.0)], 1)  # y on its lo edge
    for clamps, want in (("both", ["y 100%"]), ("hi", []), ("none", [])):
        with Simulation(gl, drifting(clamps, delta=(0.0, 0.0)), n) as sim:
            sim.upload("position", start)
            sim.run(1)
            lines = clamp_report(sim)
        assert [w for w in want if not any(w in line for line in lines)] == [], (clamps, lines)
        assert bool(lines) == bool(want), (clamps, lines)
    with pytest.raises(ParameterError, match="clamps must be one of both, lo, hi, none"):
        PassGraph().quantity("q", 0, 1, clamps="walls")
