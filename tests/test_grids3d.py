"""3D grids (issue 39, item 1): a W x H x D grid stored as a 2D atlas of its slices, with
7-point stencils and trilinear samples across slices. Plans and array layouts with no GL; values
on a real context against float64 references written here (the stencil on np.pad, the cell
centres' closed form) and scipy's ``map_coordinates`` (trilinear, edges extended)."""

import numpy as np
import pytest

from conftest import shader
from es2particles import ParameterError, PassGraph, Simulation
from es2particles.frame.state import Grid

CODE = 1 / 65024  # a 16-bit code of a unit range
SHAPE = (11, 7, 5)  # W, H, D: odd, not square; 5 slices in 2 x 3 tiles leave one tile spare
BOX = ((-0.5, 0.25, 1.0), (1.5, 1.25, 2.5))


# --- no GL ----------------------------------------------------------------------------------------

def test_a_3d_grid_is_an_atlas_of_its_slices():
    grid = Grid("vol", SHAPE, BOX)
    assert grid.tiles == (2, 3) and grid.size == (22, 21) and grid.cells == 385
    assert grid.layout(4096).count == 22 * 21
    # Slice k at column k mod 2, row k div 2: cell (i, j, k)'s texel, row by row.
    d, h, w = SHAPE[::-1]
    values = np.arange(w * h * d, dtype=float).reshape(d, h, w, 1)  # value = its flat index
    rows = grid.texel_rows(values).reshape(21, 22)
    for i, j, k in [(0, 0, 0), (10, 6, 0), (3, 2, 1), (0, 0, 2), (5, 4, 3), (10, 6, 4)]:
        x, y = (k % 2) * w + i, (k // 2) * h + j
        assert rows[y, x] == (k * h + j) * w + i
    assert np.all(rows[2 * h:, w:] == 0)  # the spare tile
    assert np.array_equal(grid.arranged(grid.texel_rows(values)), values)
    flat = values.reshape(-1, 1)  # k, then j, then i
    assert np.array_equal(grid.texel_rows(flat), grid.texel_rows(values))


def test_a_3d_grids_centres_and_plan():
    grid = Grid("vol", SHAPE, BOX)
    c = grid.centres()
    assert c.shape == (5, 7, 11, 3)
    k, j, i = 3, 5, 9
    lo, hi = np.array(BOX[0]), np.array(BOX[1])
    assert np.allclose(c[k, j, i], lo + (np.array([i, j, k]) + 0.5) * (hi - lo) / SHAPE)
    g = PassGraph()
    g.grid("vol", SHAPE, BOX)
    g.quantity("centre", (-1, 0, 0), (2, 2, 3), domain="vol")
    g.add("point", "point3d.frag", writes="centre")
    text = str(g.plan())
    assert ("grid vol: 11x7x5 cells over (-0.5, 0.25, 1)-(1.5, 1.25, 2.5), slices in an atlas "
            "of 2x3 tiles (22x21 texels), one texel a cell") in text


def test_3d_grids_are_checked():
    with pytest.raises(ParameterError, match=r"grid 'vol': box must be \(\(x0, y0, z0\), "):
        Grid("vol", (4, 4, 4), ((0, 0), (1, 1)))
    with pytest.raises(ParameterError, match="box must have x1 > x0, y1 > y0, z1 > z0"):
        Grid("vol", (4, 4, 4), ((0, 0, 1), (1, 1, 1)))
    with pytest.raises(ParameterError, match=r"grid 'vol' is 512x512x512 cells in an atlas of "
                                             r"11776x11776 texels; this context's textures are "
                                             r"at most 4096 texels a side"):
        Grid("vol", (512, 512, 512)).layout(4096)


def test_a_3d_grid_pass_gets_vec3_cells_and_trilinear_reads():
    from es2particles.gl.bindings import pass_interface

    g = PassGraph()
    g.grid("vol", SHAPE, BOX)
    g.quantity("f", -1, 1, components=1, domain="vol")
    g.quantity("lap", -12, 12, components=1, domain="vol")
    spec = g.add("lap", "laplacian3d.frag", writes="lap", reads=["f"])
    text = pass_interface(spec, g.quantities, "rgba8").text
    for line in ("uniform vec3 u_vol_size;", "uniform vec3 u_vol_lo;", "uniform vec3 u_vol_hi;",
                 "uniform vec2 u_vol_tiles;", "vec3 grid_cell()", "vec3 grid_point()",
                 "float f_at(vec3 cell)", "float sample_f(vec3 point)"):
        assert line in text, line


# --- on a context ----------------------------------------------------------------------------------

LAP = (-12.25, 12.5)  # up to 6 + 6 over [-1, 1]; codes not commensurate with f's (see test_grids)


@pytest.mark.parametrize("fmt", ["rgba8", "rgba16f", "rgba32f"])
def test_a_7_point_stencil_across_slices_matches_float64(gl, fmt):
    w, h, d = SHAPE
    g = PassGraph()
    g.grid("vol", SHAPE, BOX)
    g.quantity("f", -1, 1, components=1, domain="vol")
    g.quantity("lap", *LAP, components=1, domain="vol")
    g.add("keep_f", shader("grids/keep_f.frag"), writes="f", reads=["f"])
    g.add("lap", shader("grids/laplacian3d.frag"), writes="lap", reads=["f"])
    rng = np.random.default_rng(391)
    with Simulation(gl, g, None, fmt=fmt) as sim:
        sim.upload("f", rng.uniform(-1, 1, (d, h, w, 1)))
        f = sim.download("f")[..., 0]  # the values stored, as the pass reads them
        sim.step()
        got = sim.download("lap")[..., 0]
    assert got.shape == (d, h, w)
    p = np.pad(f, 1, mode="edge")  # the clamped edge: a Neumann boundary
    want = (p[1:-1, 1:-1, 2:] + p[1:-1, 1:-1, :-2] + p[1:-1, 2:, 1:-1] + p[1:-1, :-2, 1:-1]
            + p[2:, 1:-1, 1:-1] + p[:-2, 1:-1, 1:-1] - 6 * f)
    error = got - want
    # The output's rounding: half a code of LAP in rgba8; half float's 11 bits of |lap| < 16
    # (2^-8) in rgba16f; in every format the float32 sum of seven terms up to 6 (a few units
    # in the last place of 16: 16 * 2^-22).
    bound = {"rgba8": (LAP[1] - LAP[0]) * CODE / 2, "rgba16f": 2 ** -8,
             "rgba32f": 0}[fmt] + 16 * 2 ** -22
    print(f"{fmt}: max |error| {np.abs(error).max():.3e} (bound {bound:.3e}), mean "
          f"{error.mean():.2e}")
    assert np.abs(error).max() <= bound * 1.001
    assert abs(error.mean()) <= bound / 10  # no bias: a half-code bias would be bound / 2


def test_each_cell_computes_its_own_centre(gl):
    """grid_cell() and grid_point() over the atlas: every cell's centre, in the closed form."""
    g = PassGraph()
    g.grid("vol", SHAPE, BOX)
    g.quantity("centre", BOX[0], BOX[1], domain="vol")
    g.add("point", shader("grids/point3d.frag"), writes="centre")
    with Simulation(gl, g, None, fmt="rgba32f") as sim:
        sim.step()
        got = sim.download("centre")
    k, j, i = np.indices(SHAPE[::-1])
    lo, hi = np.array(BOX[0]), np.array(BOX[1])
    want = lo + (np.stack([i, j, k], axis=-1) + 0.5) * (hi - lo) / SHAPE
    assert np.abs(got - want).max() <= 4 * 2 ** -24 * np.abs(want).max()


@pytest.mark.parametrize("fmt", ["rgba8", "rgba32f"])
def test_particles_sample_a_3d_grid_trilinearly(gl, fmt):
    ndimage = pytest.importorskip("scipy.ndimage")
    w, h, d = SHAPE
    g = PassGraph()
    g.grid("vol", SHAPE, BOX)
    g.quantity("f", -1, 1, components=1, domain="vol")
    g.quantity("position", (-1, 0, 0.5), (2, 1.5, 3))
    g.quantity("value", -1, 1, components=1)
    g.add("keep_f", shader("grids/keep_f.frag"), writes="f", reads=["f"])
    g.add("keep_position", shader("keep_position.frag"), writes="position", reads=["position"])
    g.add("sample", shader("grids/sample3d.frag"), writes="value", reads=["position", "f"])
    rng = np.random.default_rng(392)
    n = 4000
    with Simulation(gl, g, n, outputs=["value"], fmt=fmt) as sim:
        sim.upload("f", rng.uniform(-1, 1, (d, h, w, 1)))
        # points inside the box and a little around it (the edges extend outwards)
        sim.upload("position", rng.uniform((-0.9, 0.1, 0.6), (1.9, 1.4, 2.9), (n, 3)))
        field, points = sim.download("f")[..., 0], sim.download("position")
        sim.step()
        got = sim.download("value")[:, 0]
    lo, hi = np.array(BOX[0]), np.array(BOX[1])
    index = (points - lo) / (hi - lo) * SHAPE - 0.5  # (i, j, k) in cells, centres at integers
    want = ndimage.map_coordinates(field, index[:, ::-1].T, order=1, mode="nearest")
    error = got - want
    # Output rounding (half a code of [-1, 1] in rgba8) plus float32 weights: a position's
    # rounding moves a weight by ~1e-6 of values up to 2 apart, in each of three axes.
    bound = {"rgba8": CODE, "rgba32f": 0}[fmt] + 6e-6
    print(f"{fmt}: max |error| {np.abs(error).max():.3e} (bound {bound:.3e})")
    assert np.abs(error).max() <= bound


# --- samples by the hardware ---------------------------------------------------------------------

def sampled_graph(shape, box, sampling, position_range):
    g = PassGraph()
    g.grid("cells", shape, box)
    g.quantity("f", -1, 1, components=1, domain="cells", sampling=sampling)
    g.quantity("position", *position_range)
    g.quantity("value", -1, 1, components=1)
    g.add("keep_f", shader("grids/keep_f.frag"), writes="f", reads=["f"])
    g.add("keep_position", shader("keep_position.frag"), writes="position", reads=["position"])
    g.add("sample", shader("grids/sample3d.frag" if len(shape) == 3 else "grids/sample.frag"),
          writes="value", reads=["position", "f"])
    return g


def test_the_plan_says_how_each_grid_quantity_is_sampled():
    from dataclasses import replace as changed

    from es2particles.frame.plan import plan_graph
    from es2particles.gl.context import Capabilities

    def notes(sampling, fmt, caps=Capabilities.assumed()):
        graph = sampled_graph(SHAPE, BOX, sampling, ((-1, 0, 0.5), (2, 1.5, 3)))
        return [n for n in plan_graph(graph, 100, fmt=fmt, caps=caps).notes if "sample_" in n]
    assert notes("hardware", "rgba32f") == [
        "sample_f: trilinear by the hardware (rgba32f filtered LINEAR, one fetch a slice; "
        "weights at its sub-texel precision)"]
    assert notes("hand", "rgba32f") == [
        "sample_f: trilinear by hand from 8 decoded cells (declared by hand: exact to float32)"]
    assert notes("hardware", "rgba8") == [
        "sample_f: trilinear by hand from 8 decoded cells (rgba8 is packed: linear filtering "
        "would mix its bytes)"]
    es = changed(Capabilities.assumed(), version="OpenGL ES 2.0 Mesa")
    assert notes("hardware", "rgba16f", es) == [
        "sample_f: trilinear by hand from 8 decoded cells (this context does not filter rgba16f "
        "LINEAR)"]
    es = changed(es, extensions=frozenset({"GL_OES_texture_half_float_linear"}))
    assert "by the hardware (rgba16f" in notes("hardware", "rgba16f", es)[0]
    with pytest.raises(ParameterError, match="sampling must be 'hand' or 'hardware', got 'gpu'"):
        PassGraph().quantity("q", 0, 1, sampling="gpu")
    with pytest.raises(ParameterError, match="sampling='hardware' is for a grid's quantities"):
        PassGraph().quantity("q", 0, 1, sampling="hardware")


# Hardware filtering's weights are the implementation's: D3D10 and on ask 8 bits of sub-texel
# precision; llvmpipe filters float textures in float. A weight of 8 bits is one of the two
# quanta about the true fraction, so off by up to 2^-8 on each axis (an H200 measured 4.8e-3 of
# the cells' spread in 2D: more than 2 x 2^-9, within 2 x 2^-8): the bound is 2^-8 per axis.
WEIGHT = 2 ** -8


@pytest.mark.parametrize("dims", [2, 3])
@pytest.mark.parametrize("fmt", ["rgba32f", "rgba16f"])
def test_samples_by_the_hardware_match_float64(gl, fmt, dims):
    ndimage = pytest.importorskip("scipy.ndimage")
    shape, box = (SHAPE, BOX) if dims == 3 else (SHAPE[:2], (BOX[0][:2], BOX[1][:2]))
    lo, hi = np.array(box[0]), np.array(box[1])
    rng = np.random.default_rng(393 + dims)
    n = 4000
    with Simulation(gl, sampled_graph(shape, box, "hardware", (lo - 0.5, hi + 0.5)), n,
                    outputs=["value"], fmt=fmt) as sim:
        assert any(f"sample_f: {('bi', 'tri')[dims - 2]}linear by the hardware" in line
                   for line in sim.describe())
        sim.upload("f", rng.uniform(-1, 1, shape[::-1] + (1,)))
        sim.upload("position", rng.uniform(lo - 0.4, hi + 0.4, (n, dims)))
        field, points = sim.download("f")[..., 0], sim.download("position")
        sim.step()
        got = sim.download("value")[:, 0]
    index = ((points - lo) / (hi - lo) * shape - 0.5)[:, ::-1].T  # (k,) j, i
    want = ndimage.map_coordinates(field, index, order=1, mode="nearest")
    spread = (ndimage.maximum_filter(field, size=2, origin=0, mode="nearest")
              - ndimage.minimum_filter(field, size=2, origin=0, mode="nearest"))
    # the spread of each sample's 2^d cells: the filters' windows reach back one cell
    local = ndimage.map_coordinates(spread, np.floor(index) + 1, order=0, mode="nearest")
    # The output's rounding (half float: a unit in the last place of values below 1, 2^-11, as
    # llvmpipe truncates to half; see test_wind) and float32's weights (as by hand) beside the
    # hardware's.
    write = {"rgba32f": 0, "rgba16f": 2 ** -11}[fmt] + 6e-6
    error = np.abs(got - want)
    beyond = np.maximum(error - write, 0) / np.maximum(local, 1e-9)
    print(f"{fmt} {dims}D: max |error| {error.max():.3e} (write {write:.2e}); beyond the "
          f"write, max share of the spread {beyond.max():.2e} (bound {dims * WEIGHT:.2e})")
    assert np.all(error <= dims * WEIGHT * local + write)


def test_a_context_that_cannot_filter_samples_by_hand(gl, monkeypatch):
    """sampling='hardware' on a context without float filtering (an ES 2.0 one lacking
    OES_texture_float_linear) is the by-hand sample, exact to float32."""
    ndimage = pytest.importorskip("scipy.ndimage")
    from es2particles.gl.context import Capabilities

    monkeypatch.setattr(Capabilities, "filters", lambda caps, fmt: fmt == "rgba8")
    lo, hi = np.array(BOX[0]), np.array(BOX[1])
    rng = np.random.default_rng(396)
    with Simulation(gl, sampled_graph(SHAPE, BOX, "hardware", (lo - 0.5, hi + 0.5)), 2000,
                    outputs=["value"], fmt="rgba32f") as sim:
        assert any("does not filter rgba32f LINEAR" in line for line in sim.describe())
        sim.upload("f", rng.uniform(-1, 1, SHAPE[::-1] + (1,)))
        sim.upload("position", rng.uniform(lo - 0.4, hi + 0.4, (2000, 3)))
        field, points = sim.download("f")[..., 0], sim.download("position")
        sim.step()
        got = sim.download("value")[:, 0]
    index = ((points - lo) / (hi - lo) * SHAPE - 0.5)[:, ::-1].T
    want = ndimage.map_coordinates(field, index, order=1, mode="nearest")
    assert np.abs(got - want).max() <= 6e-6
