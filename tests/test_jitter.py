"""Rounding "jitter": packed state written to the nearest code, each read offset within its code
by a hash of the texel and the step (lib/state.glsl, state_jitter). What a read returns is kept in
a float quantity and compared with the stored codes decoded in float64: within the code, uniform,
independent between components, steps and readers, and a value at rest keeps its code. The
plans say which stages read with jitter."""

import numpy as np
import pytest

from bounds import CODES, U, read_jitter
from conftest import shader
from es2particles import PassGraph, Simulation
from es2particles.frame.pipeline import Pipeline
from es2particles.frame.plan import plan_frame
from es2particles.frame.settings import FrameSettings
from es2particles.gl.bindings import READ_SALTS
from es2particles.scenes import DeJong, Fountain
from test_render import binned

# De Jong with its state in 16-bit codes, where rounding acts (the scene's own is 32-bit).
from es2particles.report.measure import DeJongInFormat as DeJong16  # noqa: E402

LO, HI = -2.0, 2.0
CODE = (HI - LO) / CODES
SPREAD = 0.5 - 1 / 64  # the largest offset, in codes: half a code less the dead zone


def seen_graph():
    g = PassGraph()
    g.quantity("q", (LO,) * 4, (HI,) * 4)
    g.quantity("seen", (-3.0,) * 4, (3.0,) * 4, storage="rgba32f")
    g.add("keep", shader("keep_q.frag"), writes="q", reads=["q"])  # at rest: see the next test
    g.add("look", shader("copy_q_to_seen.frag"), writes="seen", reads=["q"])
    return g


def reads(gl, rounding, count=2 ** 16, steps=3):
    """(stored values (count, 4) float64, what each step's read returned (steps, count, 4) in
    codes from them, the particles' texels)."""
    with Simulation(gl, seen_graph(), count, rounding=rounding) as sim:
        sim.upload("q", np.random.default_rng(3).uniform(LO, HI, (count, 4)))
        stored = sim.download("q").astype(np.float64)
        offsets = []
        for _ in range(steps):
            sim.step()
            offsets.append((sim.download("seen") - stored) / CODE)
        texels = np.floor(sim.layout.texel_uv() * sim.layout.size)
    return stored, np.array(offsets), texels


def test_a_jittered_read_is_uniform_within_its_code_and_independent(gl):
    stored, offsets, _ = reads(gl, "jitter")
    n = offsets.shape[1]
    # float32: the read's lo + (unpack + offset) span rounds a few times, each under 2 U |value|
    slack = 4 * U * (HI - LO) / CODE
    assert np.abs(offsets).max() <= SPREAD + slack, np.abs(offsets).max()
    # Uniform over the spread: the Kolmogorov-Smirnov distance to the uniform CDF, within its
    # 1e-6 critical value plus the float32 grid the offsets are measured on (an offset is a
    # difference of float32 values up to 2, whose ulp is 0.004 codes: bins would alias on it).
    flat = np.sort(offsets.reshape(-1))
    cdf = (flat + SPREAD) / (2 * SPREAD)
    ranks = np.arange(1, flat.size + 1) / flat.size
    distance = max(np.abs(cdf - ranks).max(), np.abs(cdf - ranks + 1 / flat.size).max())
    allowed = np.sqrt(np.log(2 / 1e-6) / (2 * flat.size)) + slack / (2 * SPREAD)
    print(f"offsets in codes: mean {flat.mean():+.5f}, std {flat.std():.4f} (uniform: "
          f"{2 * SPREAD / np.sqrt(12):.4f}); KS distance {distance:.5f} (allowed {allowed:.5f})")
    assert distance <= allowed
    assert abs(flat.mean()) <= 6 * (2 * SPREAD / np.sqrt(12)) / np.sqrt(flat.size)
    limit = 6 / np.sqrt(n)  # six standard deviations of the correlation of independent samples
    per_step = offsets.reshape(len(offsets), -1)
    for a in range(4):
        for b in range(a + 1, 4):
            r = np.corrcoef(offsets[0, :, a], offsets[0, :, b])[0, 1]
            assert abs(r) <= limit, f"components {a} and {b} correlate: {r:.4f}"
    for s in range(1, len(offsets)):
        r = np.corrcoef(per_step[0], per_step[s])[0, 1]
        assert abs(r) <= limit, f"steps 0 and {s} correlate: {r:.4f}"


def test_a_jittered_read_is_the_hash_of_its_texel_and_step(gl):
    """The offsets are lib/hash.glsl's hash of (texel, step, salt) to within its GPU-against-twin
    error: deterministic, so the same arguments make the same bytes."""
    _, offsets, texels = reads(gl, "jitter", count=4096, steps=2)
    slack = 4 * U * (HI - LO) / CODE
    for step, got in enumerate(offsets):
        for part in (0, 1):
            want, error = read_jitter(texels, step, READ_SALTS["pass"], (HI - LO, HI - LO), part)
            miss = (np.abs(got[:, 2 * part:2 * part + 2] - want / CODE) - error / CODE).max()
            assert miss <= slack, f"step {step}, part {part}: {miss:.3g} codes out"


@pytest.mark.parametrize("rounding", ["nearest", "dither"])
def test_other_roundings_read_the_code_itself(gl, rounding):
    _, offsets, _ = reads(gl, rounding, count=4096, steps=1)
    assert np.abs(offsets).max() <= 4 * U * (HI - LO) / CODE


def test_a_value_at_rest_keeps_its_code_under_jitter(gl):
    """x' = x for 300 steps: each read lands within the dead zone's margin of its code's edges,
    so nearest rounding writes the same code back, byte for byte."""
    g = PassGraph()
    g.quantity("q", (-8.0,) * 2, (8.0,) * 2)
    g.add("keep", shader("keep_q.frag"), writes="q", reads=["q"])
    with Simulation(gl, g, 2 ** 14, rounding="jitter") as sim:
        sim.upload("q", np.random.default_rng(4).uniform(-8, 8, (2 ** 14, 2)))
        first = sim.download("q")
        sim.run(300)
        assert np.array_equal(sim.download("q"), first)


def stage_reads_jittered(stage):
    return "STATE_JITTER" in stage.defines and stage.frame_uniforms.get("u_step") == ("step",)


def test_every_stage_that_reads_packed_state_jitters_and_only_under_jitter():
    """The plan gives STATE_JITTER and the step to the pass and the points draw alike (the draw's
    reads get their own salt); post stages read no state; other roundings give neither."""
    plan = plan_frame(DeJong16(), FrameSettings(rounding="jitter"))
    jittered = {s.name for s in plan.stages if stage_reads_jittered(s)}
    assert jittered == {"pass 'dejong'", "points"}, jittered
    vertex = next(s for s in plan.stages if s.name == "points").vertex_interface.text
    assert f"state_jitter(uv * u_state_size, {READ_SALTS['draw']:.1f})" in vertex
    for rounding in ("nearest", "dither"):
        plan = plan_frame(DeJong16(), FrameSettings(rounding=rounding))
        assert not any("STATE_JITTER" in s.defines for s in plan.stages)
    # The attractors' own state is 32-bit, read and written to the nearest value.
    plan = plan_frame(DeJong(), FrameSettings())
    assert plan.rounding == "nearest"
    assert plan.resources["position"].format == "rgba8_32"


def test_a_quantity_pinned_to_its_storage_reads_its_code_exactly():
    """The emitters' life clock (pinned to RGBA8, one code a step) must stay exact: its reads
    decode the code; velocity and position read with jitter."""
    plan = plan_frame(Fountain(), FrameSettings(rounding="jitter"))
    text = "\n".join(s.interface.text for s in plan.stages if s.step)
    assert "state_decode(texture2D(u_life" in text
    assert "state_read(texture2D(u_velocity" in text
    assert "state_read(texture2D(u_life" not in text


def test_the_points_draw_puts_each_point_where_its_jittered_read_says(gl):
    """The draw's reads have their own offsets (salt READ_SALTS["draw"], at the steps done). Each
    particle is placed, from the twin's offsets, half its offset before a pixel edge, so that its
    stored code and its jittered read fall in neighbouring pixels (17.5 codes a pixel at 4096
    wide); those whose offset the hash's GPU-against-twin error leaves open sit at pixel centres.
    The density must be the jittered reads', point for point, and not the stored codes'."""
    size, count = (4096, 64), 2 ** 14
    view = DeJong().view
    pixel = (view[2] - view[0]) / size[0]
    rng = np.random.default_rng(8)
    with Pipeline(gl, DeJong16(), count, size, rounding="jitter", steps=0) as p:
        texels = np.floor(p.sim.layout.texel_uv() * p.sim.layout.size)
        offsets, error = read_jitter(texels, 0, READ_SALTS["draw"], (HI - LO, HI - LO))
        j, e = offsets[:, 0] / CODE, error[:, 0] / CODE  # in codes
        # The central pixel edges, by where each falls between two codes: `below` codes above
        # the code under it. A particle of offset j > 0 is put on the code under an edge that
        # lies j/4 to j/2 above it (j < 0: on the code over one as far below), so its read
        # crosses that edge by at least j/2 and its code stays at least j/4 short of it.
        edges = view[0] + pixel * np.arange(size[0] // 8, 7 * size[0] // 8)
        below = (edges - LO) / CODE - np.floor((edges - LO) / CODE)
        x = np.empty(count)
        crosses = np.zeros(count, bool)
        for sign, phase in ((1, below), (-1, 1 - below)):
            order = np.argsort(phase)
            lo = np.searchsorted(phase[order], np.abs(j) / 4)
            hi = np.searchsorted(phase[order], np.abs(j) / 2)
            mine = (np.sign(j) == sign) & (hi > lo) & (np.abs(j) / 4 > e + 0.01)
            pick = order[np.minimum(lo + (rng.random(count) * (hi - lo)).astype(int),
                                    len(order) - 1)]
            x = np.where(mine, edges[pick] - sign * phase[pick] * CODE, x)
            crosses |= mine
        centres = edges[rng.integers(0, len(edges), count)] + pixel / 2
        x = np.where(crosses, x, np.round((centres - LO) / CODE) * CODE + LO)
        y = rng.uniform(-1.9, 1.9, count)
        p.sim.upload("position", np.stack([x, y], axis=1))
        stored = p.state()["position"]
        assert p.sim.steps_done == 0
        p.render()
        got = np.frombuffer(p.executor.read("density"), np.float32).astype(np.float64)
    want, ambiguous = binned(stored + offsets, size, view)
    plain, _ = binned(stored, size, view)
    moved = np.abs(got - want).sum() / 2
    unjittered = np.abs(got - plain).sum() / 2
    print(f"{int(crosses.sum())} of {count} points cross an edge by their draw's offset; points "
          f"elsewhere than their jittered read's pixel: {moved:.0f} ({ambiguous} near an edge); "
          f"than their stored code's: {unjittered:.0f}")
    assert crosses.sum() > count // 4  # the rest: offsets too small or too uncertain
    assert moved <= ambiguous
    assert unjittered >= crosses.sum() - ambiguous
