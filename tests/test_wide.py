"""Quantities of 1, 3 and 4 components in every storage format, against float64 numpy.

RGBA8 holds two 16-bit values per texel, so a 3- or 4-component quantity spans two textures and
the pass that writes it draws once per texture; float formats hold up to four values in one.
Every bound is derived from the format (tests/bounds.py): half a code of the range and the codec's
float32 rounding, half an ulp of float32 or float16 (a whole one for a GPU's write into half
floats), and the float32 roundings of the test pass's arithmetic; a half-code bias in every RGBA8
write, or a relative bias of 2 to 4 ulps in every float write (2^-22 in float32, 2^-9 in float16),
fails the pass test.
"""

import numpy as np
import pytest

from bounds import U, codec_error, float_rounding, rounding_error
from conftest import shader, wide_graph
from es2particles import PassGraph, Simulation

FORMATS = ["rgba8", "rgba16f", "rgba32f"]


def upload_error(fmt, lo, hi, value):
    """Largest error of an upload (numpy's encode, nearest rounding) read back: rgba8, half a code
    of the range plus the codec's float32 rounding (rounding_error); float formats, the value
    rounded to float32, then (rgba16f) to float16, half an ulp each in its binade."""
    if fmt == "rgba8":
        return np.broadcast_to(rounding_error("rgba8", lo, hi), np.shape(value))
    error = float_rounding(value)
    if fmt == "rgba16f":
        error = error + float_rounding(np.abs(value) + error, "rgba16f")
    return error


def write_error(fmt, lo, hi, magnitude):
    """Largest error of one GPU write of a float32 value of magnitude up to ``magnitude`` read back:
    rgba8, half a code of the range plus the codec's float32 rounding (the shader's decode, which
    a driver may fuse differently from numpy's, and its encode); rgba16f, a whole ulp (GL leaves
    the conversion to half floats to the driver: llvmpipe's rounds towards zero); rgba32f, none
    (the shader's float32 value is stored as it is)."""
    if fmt == "rgba8":
        return np.broadcast_to(rounding_error("rgba8", lo, hi), np.shape(magnitude))
    if fmt == "rgba16f":
        return float_rounding(magnitude, "rgba16f", whole_ulp=True)
    return np.zeros(np.shape(magnitude))


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
    bound = upload_error(fmt, lo, hi, values)
    worst = np.unravel_index(np.argmax(error - bound), error.shape)
    print(f"{fmt}, {components} components: max |error| {error.max():.3e}; nearest to its bound: "
          f"{error[worst]:.3e} of {bound[worst]:.3e}")
    assert error[worst] <= bound[worst], (
        f"{fmt}: an uploaded value errs by {error[worst]:.3e} > bound {bound[worst]:.3e} (half a "
        f"code + the codec's float32 rounding, or half an ulp to float32 and to float16)")
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
    # Each step computes x + s m in float32 and writes it: s rounded to float32 (a uniform) times
    # m, the product's and the sum's roundings, (rgba8) the mass as the shader decodes it (a
    # driver may fuse the decode: the codec's rounding, times s), and the write's error; the
    # steps' errors add up (a particle's s m is the same every step, so they can all lean the
    # same way: the bound is reached, 5 half codes in rgba8, 5 ulps in rgba16f on llvmpipe).
    error_bound = np.zeros_like(expected)
    for k in range(1, steps + 1):
        x_k = np.abs(start + k * shift * m) + error_bound
        error_bound = error_bound + (
            m * float_rounding(shift) + float_rounding(shift * m) + float_rounding(x_k)
            + (np.abs(shift) * codec_error(0.0, 1.0) if fmt == "rgba8" else 0.0)
            + write_error(fmt, -1.0, 1.0, x_k))
    error = np.abs(got - expected)
    worst = np.unravel_index(np.argmax(error - error_bound), error.shape)
    print(f"{fmt}: 3-component position after {steps} steps: max |error| {error.max():.3e}; "
          f"nearest to its bound: {error[worst]:.3e} of {error_bound[worst]:.3e}")
    assert error[worst] <= error_bound[worst], (
        f"{fmt}: a position errs by {error[worst]:.3e} after {steps} steps > bound "
        f"{error_bound[worst]:.3e} (= {steps} x (write error + float32 rounding of x + s m))")
    assert np.array_equal(m_after, m), "a 1-component quantity keeps its value"
    # colour = (this step's position, last step's mass): reads_new sees the value just written.
    # Written again into colour's range [0, 1]: one more write's error, plus (rgba8) the
    # position's decode, which a driver may fuse.
    colour_bound = write_error(fmt, 0.0, 1.0, np.abs(got)) + (codec_error(-1.0, 1.0)
                                                              if fmt == "rgba8" else 0.0)
    colour_error = np.abs(colour[:, :3] - got)
    worst = np.unravel_index(np.argmax(colour_error - colour_bound), got.shape)
    assert colour_error[worst] <= colour_bound[worst], (
        f"{fmt}: colour.xyz is {colour_error[worst]:.3e} off this step's position, bound "
        f"{colour_bound[worst]:.3e} (one write into [0, 1])")
    mass_bound = write_error(fmt, 0.0, 1.0, m[:, 0])
    assert np.all(np.abs(colour[:, 3] - m[:, 0]) <= mass_bound), \
        f"{fmt}: colour.w off last step's mass by {np.abs(colour[:, 3] - m[:, 0]).max():.3e}"


@pytest.mark.parametrize("fmt", FORMATS)
def test_fill_uniform_of_a_four_component_quantity(gl, fmt):
    g = keep_graph((0, 0, 0, 0), (1, 2, 3, 4))
    lo, hi = np.array([0.1, 0.5, 1.0, 2.0]), np.array([0.2, 1.5, 2.0, 3.0])
    with Simulation(gl, g, 2 ** 14, fmt=fmt) as sim:
        sim.fill_uniform("q", lo, hi, np.random.default_rng(1))
        got = sim.download("q")
    assert got.shape == (2 ** 14, 4)
    # The fill draws float32 u in [0, 1) and places it in the range's unit box, u scale + offset
    # (both rounded to float32, then the product and the sum: 4 U of a number at most 1, times the
    # span); rgba8 packs that (half a code and the codec), the float formats store
    # lo + unit span (two more roundings, then float16's half ulp).
    span = np.array([1.0, 2.0, 3.0, 4.0])
    slack = 4 * U * span
    if fmt == "rgba8":
        slack = slack + rounding_error(fmt, 0.0, span)
    else:
        slack = slack + 2 * float_rounding(hi + slack)
        if fmt == "rgba16f":
            slack = slack + float_rounding(hi + slack, "rgba16f")
    below, above = (lo - got).max(axis=0), (got - hi).max(axis=0)
    print(f"{fmt}: furthest outside the box: {max(below.max(), above.max()):.3e} (slack "
          f"{slack.min():.3e} to {slack.max():.3e})")
    assert np.all(below <= slack) and np.all(above <= slack), (
        f"{fmt}: a filled value lies {np.maximum(below, above).max():.3e} outside its box, slack "
        f"{slack} (float32 placement + the format's rounding)")
    # The mean of n uniform draws: six standard deviations, (hi - lo) / sqrt(12 n), plus the slack.
    n = len(got)
    mean_bound = 6 * (hi - lo) / np.sqrt(12 * n) + slack
    mean_error = np.abs(got.mean(axis=0) - (lo + hi) / 2)
    assert np.all(mean_error <= mean_bound), (
        f"{fmt}: the fill's mean is {mean_error} off the box's middle, bound {mean_bound} (six "
        f"standard deviations of the mean of {n} uniform draws + the slack)")
