"""Quantities of 1, 3 and 4 components in every storage format, against float64 numpy.

RGBA8 holds two 16-bit values per texel, so a 3- or 4-component quantity spans two textures and
the pass that writes it draws once per texture; float formats hold up to four values in one.
"""

import numpy as np
import pytest

from conftest import shader, wide_graph
from es2particles import PassGraph, Simulation

FORMATS = ["rgba8", "rgba16f", "rgba32f"]


def tolerance(fmt, span, value):
    """Largest storage error of one write: half a code of the range (rgba8); 2^-11 |value| for
    half floats (up to a whole ulp: a driver may round towards zero when it converts to half),
    half an ulp for single floats; plus float32 arithmetic."""
    if fmt == "rgba8":
        return span / 65024 / 2 + 4e-7 * span
    ulp = {"rgba16f": 2.0 ** -10, "rgba32f": 2.0 ** -23}[fmt]
    return np.abs(value) * ulp / 2 + 1e-7


def keep_graph(lo, hi):
    g = PassGraph()
    g.quantity("q", lo, hi)
    g.add("keep", shader("keep_q.frag"), writes="q", reads=["q"])
    return g


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("components", [1, 2, 3, 4])
def test_upload_keep_download_round_trip(gl, fmt, components):
    lo = np.array([-3.0, 0.0, -1.0, 10.0])[:components]
    hi = np.array([3.0, 1.0, 5.0, 20.0])[:components]
    n = 1000
    values = np.random.default_rng(components).uniform(lo, hi, (n, components))
    with Simulation(gl, keep_graph(lo, hi), n, fmt=fmt) as sim:
        assert len(sim.buffers["q"].fronts) == (-(-components // 2) if fmt == "rgba8" else 1)
        sim.upload("q", values)
        uploaded = sim.download("q")
        sim.run(3)  # a pass that reads and writes every part, three times
        got = sim.download("q")
    assert got.shape == (n, components)
    error = np.abs(uploaded - values)
    print(f"{fmt}, {components} components: max |error| {error.max():.3e}")
    assert np.all(error <= tolerance(fmt, hi - lo, values))
    assert np.array_equal(got, uploaded), "decode then encode of a stored value is exact"


@pytest.mark.parametrize("fmt", FORMATS)
def test_a_pass_updates_every_component_and_reads_see_the_right_step(gl, fmt):
    n, steps = 4096, 5
    shift = np.array([0.01, -0.02, 0.03])
    rng = np.random.default_rng(0)
    position = rng.uniform(0.2, 0.6, (n, 3))
    mass = rng.uniform(0.5, 1.0, (n, 1))
    with Simulation(gl, wide_graph(tuple(shift) + (0.0,)), n, fmt=fmt) as sim:
        # the plan: position and colour draw twice in rgba8, once in float formats
        draws = [(s.target.resource, s.target.part) for s in sim.stages]
        parts = 2 if fmt == "rgba8" else 1
        assert draws == [("position", k) for k in range(parts)] + \
            [("colour", k) for k in range(parts)] + [("mass", 0)]
        sim.upload("position", position)
        sim.upload("mass", mass)
        start = sim.download("position")
        m = sim.download("mass")
        sim.run(steps)
        got, colour, m_after = (sim.download(q) for q in ("position", "colour", "mass"))
    expected = start + steps * shift * m  # float64; every step moves all three components
    error = np.abs(got - expected).max()
    bound = steps * tolerance(fmt, 2.0, 1.0) + 1e-6
    print(f"{fmt}: 3-component position after {steps} steps: max |error| {error:.3e} "
          f"(bound {bound:.3e})")
    assert error <= bound
    assert np.array_equal(m_after, m), "a 1-component quantity keeps its value"
    # colour = (this step's position, last step's mass): reads_new sees the value just written
    colour_error = np.abs(colour[:, :3] - got).max()
    assert colour_error <= tolerance(fmt, 1.0, 1.0) + 1e-6, colour_error
    assert np.abs(colour[:, 3] - m[:, 0]).max() <= tolerance(fmt, 1.0, 1.0) + 1e-6


@pytest.mark.parametrize("fmt", FORMATS)
def test_fill_uniform_of_a_four_component_quantity(gl, fmt):
    g = keep_graph((0, 0, 0, 0), (1, 2, 3, 4))
    lo, hi = np.array([0.1, 0.5, 1.0, 2.0]), np.array([0.2, 1.5, 2.0, 3.0])
    with Simulation(gl, g, 2 ** 14, fmt=fmt) as sim:
        sim.fill_uniform("q", lo, hi, np.random.default_rng(1))
        got = sim.download("q")
    assert got.shape == (2 ** 14, 4)
    assert np.all(got >= lo - 1e-3) and np.all(got <= hi + 1e-3)
    assert np.allclose(got.mean(axis=0), (lo + hi) / 2, atol=0.02)
