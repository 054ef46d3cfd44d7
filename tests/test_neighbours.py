"""Neighbour grids (es2particles/frame/neighbours.py): the particles within h of each particle, found
through the sorted order and the cell table in ES 2.0 passes, against a float64 reference written
here (scipy's k-d tree for the candidates, the distance test in float64).

Positions are multiples of 2^-12 in [0, 1] and h a power of two, so every difference and squared
distance the shader computes is exact in float32 (fused or not): the GPU's set and the float64 set
must be the same, pair for pair, with no tolerance. A pass writes, per particle, three fingerprints
of the set it found: how many, the sum of their indices and the sum of (i mod 61)(i mod 67)
(each an integer below 2^24, exact in float32); a missed or extra neighbour changes the count.
"""

import re

import numpy as np
import pytest

from es2particles.errors import CapabilityError, GraphError, ParameterError
from es2particles.frame.graph import PassGraph
from es2particles.frame.plan import plan_graph
from es2particles.frame.simulation import Simulation

KEEP = "#version 100\nvoid main() { write_position(read_position(v_uv)); }\n"
FOUND = """#version 100
// the fingerprints of the set of particles within sqrt(u_h2) of this one (itself included)
void main()
{
    vec2 p = read_position(v_uv);
    vec4 found = vec4(0.0);
    vec2 other;
    FOR_EACH_NEIGHBOUR(p, other) {
        vec2 d = read_position(other) - p;
        if (dot(d, d) < u_h2) {
            vec2 texel = floor(other * u_neighbour_state_size);
            float i = texel.y * u_neighbour_state_size.x + texel.x;
            // i mod 61 and 67 from a floor that cannot land on a multiple: GLSL's mod(x, y)
            // divides, and NVIDIA's division put 61 k at 61 rather than 0 (seen on an H200)
            float a = i - 61.0 * floor((i + 0.5) / 61.0);
            float b = i - 67.0 * floor((i + 0.5) / 67.0);
            found += vec4(1.0, i, a * b, 0.0);
        }
    }
    write_found(found);
}
"""


def graph(tmp_path, h, bound=64, cell=None, box=None, dimensions=2):
    (tmp_path / "keep.frag").write_text(KEEP)
    (tmp_path / "found.frag").write_text(FOUND if dimensions == 2 else
                                         FOUND.replace("vec2 p", "vec3 p").replace("vec2 d", "vec3 d"))
    g = PassGraph()
    g.quantity("position", 0.0, 1.0, components=dimensions)
    g.add("keep", str(tmp_path / "keep.frag"), writes="position", reads=["position"])
    g.neighbours("cells", "position", cell=cell or h, box=box, bound=bound)
    g.quantity("found", 0.0, 2.0 ** 24, components=4)
    g.add("found", str(tmp_path / "found.frag"), writes="found", reads=["position"],
          neighbours="cells", uniforms={"u_h2": h * h})
    return g


def reference(points, h):
    """(count, sum of i, sum of (i mod 61)(i mod 67)) of the particles strictly within h of
    each, itself included, in float64: a k-d tree's candidates within h (inclusive), then the
    strict test."""
    from scipy.spatial import cKDTree

    tree = cKDTree(points)
    out = np.zeros((len(points), 3))
    weight = (np.arange(len(points)) % 61) * (np.arange(len(points)) % 67)
    for i, near in enumerate(tree.query_ball_point(points, h)):
        near = np.asarray(near, dtype=np.int64)
        d2 = ((points[near] - points[i]) ** 2).sum(axis=1)
        near = near[d2 < h * h]
        out[i] = (len(near), near.sum(), weight[near].sum())
    return out


def found(gl, g, points):
    with Simulation(gl, g, len(points), fmt="rgba32f") as sim:
        sim.upload("position", points)
        sim.run(1)
        assert np.array_equal(sim.download("position"), points)  # exact in rgba32f
        return sim.download("found")[:, :3], sim.check_neighbours()["cells"], sim


@pytest.mark.slow
def test_2_16_uniform_particles_find_exactly_the_float64_neighbours(gl, tmp_path):
    """2^16 particles spread at random over the unit square, h = 1/128 (about 13 neighbours
    each): every particle's set equals the float64 one."""
    rng = np.random.default_rng(7)
    points = rng.integers(0, 4097, (2 ** 16, 2)) / 4096.0  # 1.0 included: the box's edge
    h = 1 / 128
    got, worst, _ = found(gl, graph(tmp_path, h), points)
    want = reference(points, h)
    assert want[:, 0].mean() > 10
    bad = np.flatnonzero((got != want).any(axis=1))
    assert bad.size == 0, f"{bad.size} particles differ, first {bad[:5]}: {got[bad[:3]]} " \
                          f"against {want[bad[:3]]}"
    assert 0 < worst <= 64


def test_every_particle_in_one_cell_is_found_uncapped(gl, tmp_path):
    """2^12 particles in one cell of a 64 x 64 grid (every other cell empty), a bound that
    visits them all: each sees all 4096 within h (they span less than h / sqrt 2 a side), pair
    for pair."""
    rng = np.random.default_rng(3)
    points = (2048 + rng.integers(0, 45, (2 ** 12, 2))) / 4096.0  # in cell (32, 32) of 1/64
    h = 1 / 64
    got, worst, _ = found(gl, graph(tmp_path, h, bound=4096), points)
    want = reference(points, h)
    assert want[:, 0].min() == 2 ** 12 and worst == 2 ** 12
    assert np.array_equal(got, want)


def test_particles_exactly_on_cell_boundaries(gl, tmp_path):
    """A 128 x 128 lattice of spacing 1/128 under cells of 1/64: every other lattice line lies
    on a cell boundary, and the four lattice points 2 spacings away sit at exactly h = 1/64, a
    tie the strict test leaves out: each interior particle finds its 3 x 3 block of 9."""
    i, j = np.meshgrid(np.arange(128), np.arange(128))
    points = np.stack([i.ravel(), j.ravel()], 1) / 128.0
    h = 1 / 64
    got, _, _ = found(gl, graph(tmp_path, h, cell=1 / 64), points)
    want = reference(points, h)
    interior = (i.ravel() > 1) & (i.ravel() < 126) & (j.ravel() > 1) & (j.ravel() < 126)
    assert np.all(want[interior, 0] == 9)  # itself, 4 at 1/128, 4 at sqrt 2/128; not 4 at h
    assert np.array_equal(got, want)


def test_3d_particles_find_exactly_the_float64_neighbours(gl, tmp_path):
    """A 3D grid (3 x 3 x 3 cells a point, nine runs): 2^15 particles at random in the unit
    cube, h = 1/16 (about 4 neighbours each; 3D keys), and 2^11 more crowded into one cell of an
    otherwise empty grid: every particle's set equals the float64 one, pair for pair."""
    rng = np.random.default_rng(11)
    points = rng.integers(0, 4097, (2 ** 15, 3)) / 4096.0
    crowd = (2048 + rng.integers(0, 150, (2 ** 11, 3))) / 4096.0  # in cell (8, 8, 8) of 1/16
    points = np.concatenate([crowd, points])  # the crowd first: its index sums stay < 2^24
    h = 1 / 16
    got, worst, sim = found(gl, graph(tmp_path, h, bound=4096, dimensions=3), points)
    want = reference(points, h)
    assert want[2 ** 11:, 0].mean() > 4 and want[:2 ** 11, 0].min() > 2 ** 11
    bad = np.flatnonzero((got != want).any(axis=1))
    assert bad.size == 0, f"{bad.size} particles differ, first {bad[:5]}: {got[bad[:3]]} " \
                          f"against {want[bad[:3]]}"
    assert 2 ** 11 < worst <= 4096


def test_3d_lattice_on_cell_boundaries_and_its_table(gl, tmp_path):
    """A 32^3 lattice of spacing 1/32 under cells of 1/16 (every other plane on a boundary; the
    6 lattice points at exactly h = 1/16 left out by the strict test): each interior particle
    finds its 3 x 3 x 3 block of 27. The table (a texel a cell, row k H + j) holds each cell's
    first slot: its runs are numpy's bincount of the cells, (k H + j) W + i."""
    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(32), np.arange(32), np.arange(32),
                                              indexing="ij"))
    points = np.stack([i, j, k], 1) / 32.0
    h = 1 / 16
    got, _, sim = found(gl, graph(tmp_path, h, cell=1 / 16, dimensions=3), points)
    want = reference(points, h)
    interior = np.all((np.stack([i, j, k], 1) > 1) & (np.stack([i, j, k], 1) < 30), axis=1)
    assert np.all(want[interior, 0] == 27)
    assert np.array_equal(got, want)
    cells = np.minimum(points * 16, 15).astype(np.int64)  # the box is [0, 1]: 16 cells a side
    with Simulation(gl, graph(tmp_path, h, cell=1 / 16, dimensions=3), len(points)) as rgba8:
        rgba8.upload("position", points)
        rgba8.run(1)
        first = rgba8.neighbour_table("cells")
    assert first.shape == (16 * 16, 16)
    counts = np.diff(np.append(first.ravel(), len(points)))
    want_counts = np.bincount((cells[:, 2] * 16 + cells[:, 1]) * 16 + cells[:, 0],
                              minlength=16 ** 3)
    assert np.array_equal(counts, want_counts)


def test_a_3d_row_over_the_bound_names_its_cell(gl, tmp_path):
    with pytest.raises(GraphError, match=r"neighbour grid 'cells': the cells around \(\d+, "
                                         r"\d+, \d+\) hold 65 particles in a row of 3"):
        found(gl, graph(tmp_path, 1 / 16, dimensions=3), np.full((65, 3), 0.5))


def test_the_table_holds_each_cells_first_slot_in_rgba8(gl, tmp_path):
    """RGBA8 state and order (the ES 2.0 path): the table's runs are each cell's count, and the
    order the particles of each cell: counts against numpy's bincount of the cells of the
    positions (placed at cell centres, far from any boundary)."""
    rng = np.random.default_rng(5)
    cells = rng.integers(0, 32, (5000, 2))
    cells[:1000] = (3, 4)  # a crowded cell
    points = (cells + 0.5) / 32
    g = graph(tmp_path, 1 / 32, bound=2048)
    with Simulation(gl, g, len(points)) as sim:
        assert sim.executor.plan.resources["cells"].format == "rgba8"
        sim.upload("position", points)
        sim.run(1)
        first = sim.neighbour_table("cells").ravel()
    counts = np.diff(np.append(first, len(points)))
    want = np.bincount(cells[:, 1] * 32 + cells[:, 0], minlength=32 * 32)
    assert first[0] == 0 and np.array_equal(counts, want)


def test_a_row_holding_more_than_the_bound_is_an_error_naming_it(gl, tmp_path):
    """65 particles at one point against a bound of 64: refused, naming the grid; 64 pass, and
    each sees all 64."""
    with pytest.raises(GraphError, match=r"neighbour grid 'cells': .* hold 65 particles in a "
                                         r"row of 3 after step 1, more than the 64"):
        found(gl, graph(tmp_path, 1 / 64), np.full((65, 2), 0.5))
    got, worst, _ = found(gl, graph(tmp_path, 1 / 64), np.full((64, 2), 0.5))
    assert worst == 64 and np.all(got[:, 0] == 64)


def test_the_plan_states_the_grid_its_bound_and_cost(tmp_path):
    plan = plan_graph(graph(tmp_path, 1 / 64, bound=32), 2 ** 16)
    text = "\n".join(plan.describe())
    assert "neighbour grid cells: 64x64 cells of 0.015625 over position; a step sorts 65536 " \
           "slots (136 merge passes, rgba8: 16 key bits)" in text
    assert "at most 32 particles a row (96 a point)" in text
    graph_text = "\n".join(plan.graph.describe())
    assert "2. cells: neighbour grid of position (last step) over 64x64 cells" in graph_text
    assert "neighbours cells (at most 32 a row of 3 cells)" in graph_text
    assert [s.name for s in plan.step_stages][:5] == [
        "pass 'keep'", "cells key", "cells sort", "cells table", "pass 'found'"]


def test_the_plan_states_a_3d_grid_and_its_nine_rows(tmp_path):
    plan = plan_graph(graph(tmp_path, 1 / 16, bound=32, dimensions=3), 2 ** 14)
    text = "\n".join(plan.describe())
    assert "neighbour grid cells: 16x16x16 cells of 0.0625 over position" in text
    assert "visits 9 rows of 3 cells, at most 32 particles a row (288 a point)" in text
    assert plan.resources["cells"].size == (16, 256)


def test_more_cells_than_the_keys_hold_is_refused_before_any_gl(tmp_path):
    """2^20 particles leave an RGBA8 order 12 key bits: 4096 cells; a 128 x 128 grid is
    refused, naming the ways out."""
    with pytest.raises(CapabilityError, match=r"has 128x128 = 16384 cells, more than the 4096 "
                                              r"an rgba8 sort order over 1048576 particles"):
        plan_graph(graph(tmp_path, 1 / 128), 2 ** 20)


def test_a_grid_built_from_this_step_follows_its_writers_and_misuse_is_named(tmp_path):
    (tmp_path / "keep.frag").write_text(KEEP)
    g = PassGraph()
    g.quantity("position", 0.0, 1.0)
    g.add("move", str(tmp_path / "keep.frag"), writes="position", reads=["position"])
    g.neighbours("cells", "position", cell=0.1, this_step=True)
    g.quantity("n", 0, 100, components=1)
    g.add("use", "x.frag", writes="n", reads_new=["position"], neighbours="cells")
    order = [p.name for p in g.plan(["n"]).passes]
    assert order == ["move", "cells", "use"]
    assert [p.name for p in g.plan(["position"]).passes] == ["move"]  # left out: unread
    with pytest.raises(GraphError, match="reads neighbour grid 'cels', which is not declared"):
        g.add("typo", "x.frag", writes="n", neighbours="cels")
    with pytest.raises(GraphError, match="'of' must be a declared quantity of 2 or 3 components"):
        g.neighbours("more", "n", cell=0.1)
    with pytest.raises(ParameterError, match="cell must be > 0"):
        g.neighbours("zero", "position", cell=0.0)


@pytest.mark.parametrize("radius, words", [
    (0.002, "500x500x500 cells, more than 2^24: use larger cells (the largest of --radii)"),
    (0.005, "a side: use larger cells (the largest of --radii)")])
def test_too_many_cells_are_refused_naming_what_sets_them(radius, words):
    """A grid of more cells than 2^24, or whose table (W x H D texels) is wider than the
    context's textures, is refused in one line naming the scene's option that sets the cells."""
    from es2particles.frame.plan import plan_frame
    from es2particles.frame.settings import FrameSettings
    from es2particles.scenes.boids import Boids

    with pytest.raises(ParameterError, match=re.escape(words)):
        plan_frame(Boids(dimensions=3, radii=(radius,) * 3),
                   FrameSettings(particles=1024, size=(32, 32)))
