"""Grids as state (issue 39): quantities on a W x H grid of their own size, neighbour and
bilinear reads, passes repeated k times inside a step, and several writers of one quantity a
step. Plans with no GL; values on a real context against float64 references written here (a
stencil, a bilinear interpolation, Jacobi's iteration and scipy's sparse solve)."""

import numpy as np
import pytest

from conftest import shader
from es2particles import GraphError, ParameterError, PassGraph, Simulation

CODE = 1 / 65024  # a 16-bit code of a unit range


def names(passes):
    return [p.name for p in passes]


# --- plans, no GL ---------------------------------------------------------------------------------

def fluid_like(k=3):
    """The shape of a fluid's step: three writers of the velocity, k Jacobi iterations."""
    g = PassGraph()
    air = g.grid("air", (8, 4), box=((0, 0), (2, 1)))
    g.quantity("velocity", -4, 4, components=2, domain=air)
    g.quantity("divergence", -100, 100, components=1, domain=air)
    g.quantity("pressure", -50, 50, components=1, domain="air")
    g.quantity("position", 0, 2)
    g.add("advect", "advect.frag", writes="velocity", reads=["velocity"])
    g.add("force", "force.frag", writes="velocity", reads_new=["velocity"])
    g.add("divergence", "div.frag", writes="divergence", reads_new=["velocity"])
    with g.repeat("pressure_iterations", k):
        g.add("jacobi", "jacobi.frag", writes="pressure", reads_new=["pressure", "divergence"])
    g.add("project", "project.frag", writes="velocity", reads_new=["velocity", "pressure"])
    g.add("move", "move.frag", writes="position", reads=["position"], reads_new=["velocity"])
    return g


def test_a_fluid_step_plans_its_writers_in_order_with_versions():
    plan = fluid_like().plan(["position"])
    assert names(plan.passes) == ["advect", "force", "divergence", "jacobi", "project", "move"]
    assert set(plan.versioned) == {"velocity", "pressure"}
    assert plan.buffers == {"velocity": 2, "divergence": 1, "pressure": 2, "position": 2}
    v = plan.versions()
    assert v["advect"] == ({"velocity": (0, 0)}, (1, 1))  # last step's, into version 1
    assert v["force"] == ({"velocity": (1, 1)}, (2, 2))
    assert v["divergence"] == ({"velocity": (2, 2)}, None)  # the forced velocity
    assert v["jacobi"] == ({"pressure": (0, 2)}, (1, 3))  # three iterations, three versions
    assert v["project"] == ({"velocity": (2, 2), "pressure": (3, 3)}, (3, 3))
    assert v["move"] == ({"velocity": (3, 3)}, None)  # the projected velocity
    text = str(plan)
    assert "grid air: 8x4 cells over (0, 0)-(2, 1), one texel a cell" in text
    assert "repeat pressure_iterations: 3 iterations of jacobi, ping-ponging" in text
    assert "jacobi: jacobi.frag writes pressure (v1..v3) over grid air; reads pressure "\
           "(v0..v2)" in text
    assert "divergence: div.frag writes divergence over grid air; reads velocity (v2)" in text
    assert "velocity (2 components, on grid air): 2 (ping-pong: written more than once" in text


def test_a_read_of_a_version_not_yet_written_is_an_error_naming_pass_and_quantity():
    g = fluid_like()
    g.add("early", "early.frag", writes="divergence", reads=["velocity"])
    with pytest.raises(GraphError, match="pass 'early' reads last step's 'velocity', but "
                                         "passes advect, force, project write 'velocity' "
                                         "before it in this step"):
        g.plan()
    g = PassGraph()
    g.quantity("a", 0, 1)
    g.quantity("b", 0, 1)
    g.add("read", "r.frag", writes="b", reads_new=["a"])
    g.add("one", "a.frag", writes="a", reads=["a"])
    g.add("two", "a.frag", writes="a", reads_new=["a"])
    with pytest.raises(GraphError, match="pass 'read' reads this step's 'a', but no pass "
                                         "declared before it writes 'a'"):
        g.plan()


def test_a_repeat_reading_last_steps_value_of_what_it_writes_is_an_error():
    g = PassGraph()
    g.quantity("p", 0, 1)
    with g.repeat("loop", 2):
        g.add("jacobi", "j.frag", writes="p", reads=["p"])
    with pytest.raises(GraphError, match="from its second iteration on, last step's 'p' is "
                                         "gone"):
        g.plan()


def test_repeat_counts_and_grids_are_checked():
    g = PassGraph()
    with pytest.raises(ParameterError, match="repeat 'loop' count must be in"):
        with g.repeat("loop", 0):
            pass
    with pytest.raises(GraphError, match="repeat 'empty' holds no pass"):
        with g.repeat("empty", 2):
            pass
    with pytest.raises(ParameterError, match="grid 'air': shape must be"):
        g.grid("air", (8, 4, 2, 1))
    with pytest.raises(GraphError, match="grid 'nowhere' is not declared"):
        g.quantity("q", 0, 1, domain="nowhere")
    with pytest.raises(ParameterError, match="box must have x1 > x0"):
        g.grid("flat", (4, 4), box=((0, 0), (0, 1)))


def test_a_grid_larger_than_the_context_is_refused():
    from es2particles.frame.plan import plan_graph
    from es2particles.gl.context import Capabilities

    g = PassGraph()
    g.grid("big", (4097, 8))
    g.quantity("f", 0, 1, domain="big")
    g.add("fill", "f.frag", writes="f")
    from dataclasses import replace

    caps = replace(Capabilities.assumed(), max_texture_size=4096)
    with pytest.raises(ParameterError, match="grid 'big' is 4097x8 cells; this context's "
                                             "textures are at most 4096 texels a side"):
        plan_graph(g, None, caps=caps)


def test_a_grid_pass_gets_its_cell_and_neighbour_and_bilinear_reads():
    from es2particles.gl.bindings import pass_interface

    g = PassGraph()
    g.grid("air", (8, 4))
    g.quantity("f", -1, 1, components=1, domain="air")
    g.quantity("lap", -8, 8, components=1, domain="air")
    spec = g.add("lap", "laplacian.frag", writes="lap", reads=["f"])
    text = pass_interface(spec, g.quantities, "rgba8").text
    for line in ("uniform vec2 u_air_size;", "uniform vec4 u_air_box;", "vec2 grid_cell()",
                 "float f_at(vec2 cell)", "float sample_f(vec2 point)", "float read_f(vec2 uv)"):
        assert line in text, line
    assert "state_jitter" not in text  # a grid's cells are read as stored


# --- on a context ----------------------------------------------------------------------------------

LAP = (-8.25, 8.5)  # the Laplacian's range: its codes (16.75 / 65024) are not commensurate with
# f's (2 / 65024), so no sum lands exactly half-way between two codes (ties, rounded up, would
# bias the mean by 1/16 of a code where the grids align, as [-8, 8] does)


def laplacian_graph(shape):
    g = PassGraph()
    g.grid("cells", shape)
    g.quantity("f", -1, 1, components=1, domain="cells")
    g.quantity("lap", *LAP, components=1, domain="cells")
    g.add("keep_f", shader("grids/keep_f.frag"), writes="f", reads=["f"])
    g.add("lap", shader("grids/laplacian.frag"), writes="lap", reads=["f"])
    return g


@pytest.mark.parametrize("fmt", ["rgba8", "rgba16f", "rgba32f"])
def test_a_neighbour_stencil_matches_float64(gl, fmt):
    w, h = 37, 23  # not powers of two, not square
    rng = np.random.default_rng(39)
    with Simulation(gl, laplacian_graph((w, h)), None, fmt=fmt) as sim:
        sim.upload("f", rng.uniform(-1, 1, (h, w, 1)))
        f = sim.download("f")[..., 0]  # the values stored, as the pass reads them
        sim.step()
        got = sim.download("lap")[..., 0]
    assert got.shape == (h, w)
    padded = np.pad(f, 1, mode="edge")  # the clamped edge: a Neumann boundary
    want = (padded[1:-1, 2:] + padded[1:-1, :-2] + padded[2:, 1:-1] + padded[:-2, 1:-1]
            - 4 * f)
    error = got - want
    # The output's rounding: half a code of LAP in rgba8; half float's 11 bits of |lap| (up to
    # 8: 2^-9) in rgba16f; and in every format the float32 sum of five terms up to 4 (a few
    # units in the last place of 8: 8 * 2^-22).
    span = LAP[1] - LAP[0]
    bound = {"rgba8": span * CODE / 2, "rgba16f": 8 * 2 ** -11, "rgba32f": 0}[fmt] + 8 * 2 ** -22
    print(f"{fmt}: max |error| {np.abs(error).max():.3e} (bound {bound:.3e}), mean "
          f"{error.mean():.2e}")
    assert np.abs(error).max() <= bound * 1.001
    assert abs(error.mean()) <= bound / 10  # no bias: a half-code bias would be bound / 1


def bilinear(field, box, points):
    """Float64 bilinear interpolation of cell-centred ``field`` (H, W) over ``box`` at
    ``points`` (n, 2), edge cells extended outwards."""
    (x0, y0), (x1, y1) = box
    h, w = field.shape
    c = (points - (x0, y0)) / ((x1 - x0), (y1 - y0)) * (w, h) - 0.5
    i = np.floor(c)
    t = c - i
    i = i.astype(int)

    def at(dx, dy):
        return field[np.clip(i[:, 1] + dy, 0, h - 1), np.clip(i[:, 0] + dx, 0, w - 1)]
    return ((at(0, 0) * (1 - t[:, 0]) + at(1, 0) * t[:, 0]) * (1 - t[:, 1])
            + (at(0, 1) * (1 - t[:, 0]) + at(1, 1) * t[:, 0]) * t[:, 1])


@pytest.mark.parametrize("fmt", ["rgba8", "rgba32f"])
def test_particles_sample_a_grid_bilinearly(gl, fmt):
    box = ((-0.5, 0.25), (1.5, 1.25))
    g = PassGraph()
    g.grid("cells", (13, 6), box=box)
    g.quantity("f", -1, 1, components=1, domain="cells")
    g.quantity("position", (-1, -0.25), (2, 1.75))
    g.quantity("value", -1, 1, components=1)
    g.add("keep_f", shader("grids/keep_f.frag"), writes="f", reads=["f"])
    g.add("keep_position", "examples/drift.frag", writes="position", reads=["position"],
          uniforms={"u_delta": (0.0, 0.0)})
    g.add("sample", shader("grids/sample.frag"), writes="value", reads=["position", "f"])
    rng = np.random.default_rng(40)
    n = 4000
    with Simulation(gl, g, n, outputs=["value"], fmt=fmt) as sim:
        # ground truth from a smooth field plus noise, and points inside and around the box
        sim.upload("f", rng.uniform(-1, 1, (6, 13, 1)))
        sim.upload("position", rng.uniform((-0.9, -0.2), (1.9, 1.7), (n, 2)))
        field, points = sim.download("f")[..., 0], sim.download("position")
        sim.step()
        got = sim.download("value")[:, 0]
    want = bilinear(field, box, points)
    error = got - want
    # Output rounding (half a code of [-1, 1] in rgba8) plus float32 weights: a position's
    # rounding (2^-24 of 13 cells over 2 m) moves a weight by ~1e-6 of a value up to 2 apart.
    bound = {"rgba8": CODE, "rgba32f": 0}[fmt] + 4e-6
    print(f"{fmt}: max |error| {np.abs(error).max():.3e} (bound {bound:.3e})")
    assert np.abs(error).max() <= bound


def jacobi_graph(shape, k):
    g = PassGraph()
    g.grid("cells", shape)
    g.quantity("b", -1, 1, components=1, domain="cells")
    g.quantity("p", -64, 64, components=1, domain="cells")
    g.add("keep_b", shader("grids/copy_b.frag"), writes="b", reads=["b"])
    with g.repeat("iterations", k):
        g.add("jacobi", shader("grids/jacobi.frag"), writes="p", reads_new=["p", "b"])
    return g


def jacobi64(b, p, k):
    """k Jacobi iterations of lap(p) = b with p = 0 outside the grid, in float64."""
    for _ in range(k):
        q = np.pad(p, 1)
        p = 0.25 * (q[1:-1, 2:] + q[1:-1, :-2] + q[2:, 1:-1] + q[:-2, 1:-1] - b)
    return p


@pytest.mark.parametrize("k", [1, 2, 3, 8])
def test_a_repeat_is_k_jacobi_iterations_whatever_their_parity(gl, k):
    """Odd and even counts leave the latest version in either texture of the pair; each step
    starts from the last step's solution (the state's own warm start)."""
    w, h = 12, 9
    rng = np.random.default_rng(41)
    with Simulation(gl, jacobi_graph((w, h), k), None, fmt="rgba32f") as sim:
        sim.upload("b", rng.uniform(-1, 1, (h, w, 1)))
        b = sim.download("b")[..., 0]
        sim.run(2)
        got = sim.download("p")[..., 0]
    want = jacobi64(b, np.zeros_like(b), 2 * k)
    error = np.abs(got - want).max()
    print(f"k={k}: max |error| {error:.2e} of max |p| {np.abs(want).max():.2f}")
    assert error <= 2 * k * 4 * 2 ** -24 * max(1, np.abs(want).max())


def test_many_iterations_converge_to_the_sparse_solve(gl):
    """600 iterations on 16 x 12 cells (spectral radius ~0.977) against scipy's exact solve."""
    sparse = pytest.importorskip("scipy.sparse")
    spsolve = pytest.importorskip("scipy.sparse.linalg").spsolve
    w, h = 16, 12
    rng = np.random.default_rng(42)
    with Simulation(gl, jacobi_graph((w, h), 600), None, fmt="rgba32f") as sim:
        sim.upload("b", rng.uniform(-1, 1, (h, w, 1)))
        b = sim.download("b")[..., 0]
        sim.step()
        got = sim.download("p")[..., 0]

    def second_difference(n):
        return sparse.diags([1.0, -2.0, 1.0], [-1, 0, 1], shape=(n, n), dtype=float)
    lap = sparse.kronsum(second_difference(w), second_difference(h)).tocsc()
    exact = spsolve(lap, b.ravel()).reshape(h, w)
    error = np.abs(got - exact).max() / np.abs(exact).max()
    print(f"600 iterations: max |p - exact| / max |exact| = {error:.2e}")
    assert error <= 1e-4


@pytest.mark.parametrize("fmt", ["rgba8", "rgba32f"])
def test_several_writers_of_one_quantity_in_one_step(gl, fmt):
    """a -> 2a + 0.1 -> a / 2 - 0.2 each step; b, between them, sees the first version; c,
    there too, last step's (in the back of the pair after one write)."""
    g = PassGraph()
    g.quantity("a", -4, 4, components=1)
    g.quantity("b", -4, 4, components=1)
    g.quantity("c", -4, 4, components=1)
    g.add("double", shader("grids/affine.frag"), writes="a", reads=["a"],
          uniforms={"u_scale": 2.0, "u_shift": 0.1})
    g.add("copy", shader("grids/copy_a.frag"), writes="b", reads_new=["a"])
    g.add("old", shader("grids/copy_a_to_c.frag"), writes="c", reads=["a"])
    g.add("halve", shader("grids/affine.frag"), writes="a", reads_new=["a"],
          uniforms={"u_scale": 0.5, "u_shift": -0.2})
    n = 100
    start = np.linspace(-1, 1, n)
    with Simulation(gl, g, n, fmt=fmt) as sim:
        sim.upload("a", start)
        a0 = sim.download("a")[:, 0]
        sim.run(3)
        a, b, c = (sim.download(q)[:, 0] for q in "abc")
    # each step: a -> a + 0.05 - 0.2 = a - 0.15; b = 2 a_before + 0.1 in the last step
    want_a, want_b, want_c = a0 - 3 * 0.15, 2 * (a0 - 2 * 0.15) + 0.1, a0 - 2 * 0.15
    bound = {"rgba8": 3 * 2 * 8 * CODE, "rgba32f": 1e-6}[fmt]
    for got, want in ((a, want_a), (b, want_b), (c, want_c)):
        assert np.abs(got - want).max() <= bound


@pytest.mark.parametrize("warm", [0.0, 0.5, 1.0])
def test_a_warm_start_scales_last_steps_solution(gl, warm):
    """Two steps of k iterations: the second starts from warm x the first's solution."""
    w, h, k = 10, 7, 5
    g = PassGraph()
    g.grid("cells", (w, h))
    g.quantity("b", -1, 1, components=1, domain="cells")
    g.quantity("p", -64, 64, components=1, domain="cells")
    g.add("keep_b", shader("grids/copy_b.frag"), writes="b", reads=["b"])
    with g.repeat("iterations", k, warm_start={"p": warm}):
        g.add("jacobi", shader("grids/jacobi.frag"), writes="p", reads_new=["p", "b"])
    plan = g.plan()
    assert [p.name for p in plan.passes] == ["keep_b"] + (["iterations_warm_start"]
                                                          if warm != 1 else []) + ["jacobi"]
    rng = np.random.default_rng(43)
    with Simulation(gl, g, None, fmt="rgba32f") as sim:
        sim.upload("b", rng.uniform(-1, 1, (h, w, 1)))
        b = sim.download("b")[..., 0]
        sim.run(2)
        got = sim.download("p")[..., 0]
    want = jacobi64(b, warm * jacobi64(b, np.zeros_like(b), k), k)
    assert np.abs(got - want).max() <= 4 * k * 4 * 2 ** -24 * max(1, np.abs(want).max())
