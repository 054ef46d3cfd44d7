"""Executing pass graphs on a real GL context: ping-pong, time of reads, pruning, formats, leaks."""

import numpy as np
import pytest

from conftest import shader
from es2particles import ParameterError, PassGraph, Simulation

WORLD_STEP = 1 / 65024  # grid step of a quantity with range [0, 1]


def counter_graph(delta_reads_new=False):
    g = PassGraph()
    g.quantity("position", 0, 1)
    g.quantity("copy_new", 0, 1)
    g.quantity("copy_last", 0, 1)
    g.add("add", "examples/drift.frag", writes="position", reads=["position"],
          uniforms={"u_delta": (0.0, 0.0)})
    g.add("copy_this_step", shader("copy.frag"), writes="copy_new", reads_new=["position"])
    g.add("copy_last_step", shader("copy.frag"), writes="copy_last", reads=["position"])
    return g


@pytest.mark.parametrize("fmt", ["rgba8", "rgba16f", "rgba32f"])
def test_ping_pong_adds_a_constant_each_step(gl, fmt):
    n, steps = 1000, 7
    delta = (300 * WORLD_STEP, 1000 * WORLD_STEP)  # whole codes: exact in the packed format
    with Simulation(gl, counter_graph(), n, outputs=["position"], fmt=fmt) as sim:
        start = np.stack([np.linspace(0, 0.5, n), np.full(n, 0.25)], axis=1)
        start = np.round(start * 65024) / 65024
        sim.upload("position", start)
        sim.set_uniform("u_delta", delta)
        sim.run(steps)
        got = sim.download("position")
    expected = start + steps * np.array(delta)
    tolerance = {"rgba8": 1e-7, "rgba16f": steps * 2 ** -11, "rgba32f": 1e-6}[fmt]
    error = np.abs(got - expected).max()
    print(f"{fmt}: after {steps} steps max |error| = {error:.3e} (tolerance {tolerance:.1e})")
    assert error <= tolerance


def test_reads_see_this_steps_or_last_steps_value(gl):
    n = 64
    delta = (65 * WORLD_STEP, 0.0)
    with Simulation(gl, counter_graph(), n) as sim:
        sim.upload("position", np.full((n, 2), 0.5))
        sim.set_uniform("u_delta", delta)
        sim.run(3)
        value, new, last = (sim.download(q) for q in ("position", "copy_new", "copy_last"))
    assert np.allclose(value[:, 0], 0.5 + 3 * delta[0], atol=WORLD_STEP / 2)
    assert np.array_equal(new, value), "reads_new must see this step's value"
    assert np.allclose(last[:, 0], 0.5 + 2 * delta[0], atol=WORLD_STEP / 2), \
        "reads must see last step's value"


def test_pruned_passes_are_never_compiled_or_run(gl):
    g = counter_graph()
    g.quantity("broken", 0, 1)
    g.add("never", shader("broken.frag"), writes="broken", reads=["position"])
    # The broken shader would raise if it were compiled; pruning must leave it out entirely.
    with Simulation(gl, g, 16, outputs=["position"]) as sim:
        assert [s.name for s in sim.stages] == ["pass 'add'"]
        assert set(sim.buffers) == {"position"}
        sim.run(2)


def test_a_user_pass_in_a_few_lines(gl, tmp_path):
    frag = tmp_path / "swap_xy.frag"
    frag.write_text("#version 100\nvoid main() { write_p(read_p(v_uv).yx); }\n")
    g = PassGraph()
    g.quantity("p", -1, 1)
    g.add("swap", str(frag), writes="p", reads=["p"])
    with Simulation(gl, g, 10) as sim:
        start = np.stack([np.full(10, 0.5), np.full(10, -0.25)], axis=1)
        sim.upload("p", start)
        sim.step()
        assert np.allclose(sim.download("p"), start[:, ::-1], atol=2 / 65024)


def test_release_frees_every_gl_object(gl):
    before = gl.live_objects()
    sim = Simulation(gl, counter_graph(), 100)
    sim.run(1)
    sim.release()
    sim.release()  # twice is safe
    after = gl.live_objects()
    after.pop("Program", None), before.pop("Program", None)  # programs are cached by the context
    assert after == before


def test_non_square_and_tiny_counts(gl):
    for n in (1, 2, 1000, 4099):
        with Simulation(gl, counter_graph(), n, outputs=["position"]) as sim:
            assert sim.layout.width * sim.layout.height >= n
            values = np.random.default_rng(n).random((n, 2))
            sim.upload("position", values)
            assert np.abs(sim.download("position") - values).max() <= WORLD_STEP / 2 + 1e-7


@pytest.mark.parametrize("count", [0, -5, 2.5, "many"])
def test_bad_particle_counts_are_clear_errors(gl, count):
    with pytest.raises(ParameterError, match="particles"):
        Simulation(gl, counter_graph(), count)


def test_count_beyond_the_texture_limit_is_a_clear_error(gl):
    limit = gl.caps.max_texture_size ** 2
    with pytest.raises(ParameterError, match=rf"particles must be in \[1, {limit}\]"):
        Simulation(gl, counter_graph(), limit + 1)


def test_unknown_quantity_and_format_are_clear_errors(gl):
    with Simulation(gl, counter_graph(), 4, outputs=["position"]) as sim:
        with pytest.raises(ParameterError, match="quantity 'velocity' is not in this"):
            sim.download("velocity")
        with pytest.raises(ParameterError, match="values must have shape"):
            sim.upload("position", np.zeros((3, 2)))
        with pytest.raises(ParameterError, match="no pass of this graph declares a uniform 'u_nothing'"):
            sim.set_uniform("u_nothing", 1.0)
    with pytest.raises(ParameterError, match="format must be one of"):
        Simulation(gl, counter_graph(), 4, fmt="rgb565")


def test_texel_uv_names_each_particle_texel_centre_row_by_row():
    from es2particles.frame.state import Layout

    layout = Layout.for_count(1000, 4096)  # 32 x 32 with 24 spare texels
    index = np.arange(1000)
    expected = np.stack([(index % 32 + 0.5) / 32, (index // 32 + 0.5) / 32], axis=1)
    assert np.array_equal(layout.texel_uv().astype(np.float64), expected)


@pytest.mark.parametrize("fmt", ["rgba8", "rgba32f"])
def test_fill_uniform_draws_uniformly_from_the_rectangle(gl, fmt):
    """The stored points against the uniform distribution: inside the box, 32x32 cell counts
    within a chi-square bound, and (packed) nearly all distinct codes, which a coarse draw would
    not give."""
    g = PassGraph()
    g.quantity("position", (-2, -2), (2, 2))
    g.add("add", "examples/drift.frag", writes="position", reads=["position"],
          uniforms={"u_delta": (0.0, 0.0)})
    n, lo, hi = 2 ** 18, np.array([-1.5, 0.25]), np.array([1.0, 1.75])
    with Simulation(gl, g, n, fmt=fmt) as sim:
        sim.fill_uniform("position", lo, hi, np.random.default_rng(3))
        got = sim.download("position")
        sim.fill_uniform("position", lo, hi, np.random.default_rng(3))
        again = sim.download("position")
    half_code = 4 / 65024 / 2
    assert np.array_equal(got, again)  # the same generator state gives the same points
    assert (got >= lo - half_code).all() and (got <= hi + half_code).all()
    counts, _, _ = np.histogram2d(got[:, 0], got[:, 1], bins=32, range=np.stack([lo, hi], 1))
    expected = n / counts.size
    chi2 = ((counts - expected) ** 2 / expected).sum()
    dof = counts.size - 1
    distinct = len(np.unique(got, axis=0)) / n
    print(f"{fmt}: chi-square {chi2:.0f} for {dof} degrees of freedom; {distinct:.5f} distinct")
    assert chi2 < dof + 5 * np.sqrt(2 * dof)
    assert distinct > 0.999


def test_fill_uniform_rejects_a_reversed_rectangle(gl):
    with Simulation(gl, counter_graph(), 16, outputs=["position"]) as sim:
        with pytest.raises(ParameterError, match="hi >= lo"):
            sim.fill_uniform("position", (0.5, 0.5), (0.25, 1.0), np.random.default_rng(0))
        with pytest.raises(ParameterError, match="not in this simulation"):
            sim.fill_uniform("velocity", (0, 0), (1, 1), np.random.default_rng(0))


@pytest.mark.parametrize("fmt", ["rgba8", "rgba32f"])
def test_clamped_counts_values_on_edges_that_are_not_exact_in_float32(gl, fmt):
    g = PassGraph()
    g.quantity("position", (0.1, -0.3), (0.7, 0.7))
    g.add("add", "examples/drift.frag", writes="position", reads=["position"],
          uniforms={"u_delta": (0.0, 0.0)})
    with Simulation(gl, g, 4, fmt=fmt) as sim:
        sim.upload("position", np.array([[-5.0, 5.0], [0.4, 0.2], [9.0, -9.0], [0.2, 0.1]]))
        assert sim.clamped("position") == [2, 2]


def test_a_float_write_inside_a_branch_keeps_float32(gl):
    """GLSL ES 1.00's gl_FragColor is mediump, and llvmpipe rounded a write made inside a branch
    to half floats (1 + k / 16384 came back as 1 or 1 + 1/1024): the generated main writes it
    once, after the shader's own, so the values come back exact."""
    g = PassGraph()
    g.quantity("q", 0.0, 4.0, components=1)
    g.add("q", shader("write_in_branch.frag"), writes="q")
    with Simulation(gl, g, 64, fmt="rgba32f") as sim:  # 8x8 texels
        sim.step()
        q = sim.download("q")[:, 0].reshape(8, 8)
    column = np.arange(8)
    want = 1 + column / 16384 + np.where((np.arange(8)[:, None] + 0.5) / 8 > 0.5, 0, 0.5)
    assert np.array_equal(q, want), np.abs(q - want).max()
