"""Precision of the 16-bit pack/unpack: on the GPU, in the numpy twin, and at the edges.

References are float64 numpy or plain integer arithmetic on the bytes, never the code under test:
a byte pair (H, L) means (255 H + L) / 65024 by definition.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import run_fullscreen
from es2particles.twins import pack as packing

STEP = 1 / 65024
F32_EPS = 2.0 ** -24  # float32 rounding of a value in [0, 1]


def bytes_value(pairs):
    """Independent decode of (H, L) byte pairs, float64."""
    pairs = np.asarray(pairs, dtype=np.float64)
    return (255 * pairs[..., 0] + pairs[..., 1]) / 65024


def gpu_pack(ctx, values):
    """Pack float32 values on the GPU (two per texel); returns the (H, L) byte pairs."""
    values = np.asarray(values, dtype=np.float32)
    n = -(-len(values) // 2)
    width = int(np.ceil(np.sqrt(n)))
    height = -(-n // width)
    texels = np.zeros((width * height, 4), dtype=np.float32)
    flat = texels[:, :2].reshape(-1)
    flat[: len(values)] = values
    texels[:, :2] = flat.reshape(-1, 2)
    src = ctx.texture((width, height), "rgba32f", data=texels.tobytes())
    try:
        out = run_fullscreen(ctx, "pack_floats.frag", src)
    finally:
        ctx.free(src)
    return out.reshape(-1, 2)[: len(values)]


def test_all_byte_pairs_survive_unpack_and_repack_on_gpu(gl):
    pairs = np.stack(np.meshgrid(np.arange(256), np.arange(256), indexing="ij"), -1).reshape(-1, 2)
    texels = np.concatenate([pairs, pairs[:, ::-1]], axis=1).astype(np.uint8)  # (H,L,L,H)
    src = gl.texture((256, 256), "rgba8", data=texels.tobytes())
    try:
        out = run_fullscreen(gl, "repack.frag", src)
    finally:
        gl.free(src)
    got = np.concatenate([out[:, 0:2], out[:, 2:4]])
    sent = np.concatenate([texels[:, 0:2], texels[:, 2:4]])
    value = bytes_value(sent)
    # Canonical pairs (L < 255, value <= 1) must come back bit-exact.
    canonical = (sent[:, 1] < 255) & (value <= 1)
    mismatched = np.count_nonzero(np.any(got[canonical] != sent[canonical], axis=1))
    assert mismatched == 0, f"{mismatched} canonical byte pairs changed on unpack+repack"
    # The others (L = 255 is the next H; above 1 clamps) must decode to the same, clamped value.
    expected = np.minimum(value, 1.0)
    assert np.array_equal(bytes_value(got), expected), "non-canonical pairs changed value"


def test_float_values_pack_on_gpu_within_half_a_step(gl):
    k = np.arange(65024, dtype=np.float64)
    rng = np.random.default_rng(1)
    x64 = np.concatenate([k / 65024, (k + 0.5) / 65024, rng.random(10 ** 6)])
    x32 = x64.astype(np.float32)
    got = gpu_pack(gl, x32)
    error = np.abs(bytes_value(got) - x32.astype(np.float64))
    bound = STEP / 2 + 4 * F32_EPS
    print(f"GPU pack: max |error| = {error.max():.3e} (bound {bound:.3e}, half step "
          f"{STEP / 2:.3e}) over {len(x32)} values")
    assert error.max() <= bound, f"max error {error.max():.3e} > bound {bound:.3e}"
    # ...and the numpy twin predicts the GPU's bytes exactly.
    twin = packing.pack16(x32, "round")
    differ = np.count_nonzero(np.any(twin != got, axis=1))
    assert differ == 0, f"numpy twin differs from the GPU on {differ} of {len(x32)} values"


EDGES = np.array([
    0.0, -0.0, np.float32(1e-45), 1 / 255, np.nextafter(np.float32(1 / 255), np.float32(0)),
    np.nextafter(np.float32(1 / 255), np.float32(1)), 0.5, 1 - 2.0 ** -24, 1.0, 1 + 2.0 ** -23,
    2.0, 1e30, -1e-30, -0.5, -1e30, np.nan, np.inf, -np.inf,
], dtype=np.float32)


def documented(x):
    """The documented value of a packed float (to within half a step): clamp to [0, 1], NaN and -Inf
    to 0, +Inf to 1."""
    x = np.asarray(x, dtype=np.float64)
    return np.clip(np.nan_to_num(x, nan=0.0, posinf=1.0, neginf=0.0), 0, 1)


def test_edge_values_follow_the_documented_result_on_gpu_and_numpy(gl):
    got = gpu_pack(gl, EDGES)
    twin = packing.pack16(EDGES)
    expected = documented(EDGES)
    for x, g, t, e in zip(EDGES, got, twin, expected):
        assert abs(bytes_value(g) - e) <= STEP / 2 + 4 * F32_EPS, f"GPU packs {x!r} to {g} ({bytes_value(g)}), documented {e}"
        assert np.array_equal(g, t), f"numpy twin packs {x!r} to {t}, the GPU to {g}"
    # The top stays the top: 1.0 and anything above it decode to exactly 1, never wrap to 0.
    top = bytes_value(got[EDGES >= 1])
    assert np.all(top == 1.0), f"values at or above the top decode to {top}"


@pytest.mark.parametrize("rule", packing.STORE_RULES)
def test_numpy_twin_is_within_one_step_under_every_store_rule(rule):
    k = np.arange(65024, dtype=np.float64)
    rng = np.random.default_rng(2)
    x = np.concatenate([k / 65024, (k + 0.5) / 65024, rng.random(10 ** 5)]).astype(np.float32)
    error = np.abs(bytes_value(packing.pack16(x, rule)) - x.astype(np.float64))
    bound = (STEP / 2 if rule == "round" else STEP) + 4 * F32_EPS
    print(f"store rule {rule}: max |error| = {error.max():.3e} (bound {bound:.3e})")
    assert error.max() <= bound


def test_article_formula_loses_a_high_step_under_truncation():
    # The test above could fail: the article's high byte fract(x) - fract(255x)/255 lands just
    # below H/255, and a truncating store then drops a whole high step (1/255).
    x = np.random.default_rng(3).random(10 ** 5).astype(np.float32)
    error = np.abs(article_pack_value(x, "truncate") - x.astype(np.float64))
    print(f"article formula under truncation: max |error| = {error.max():.3e} (1/255 = {1/255:.3e})")
    assert error.max() > 100 * STEP
    # Under round-to-nearest the article's formula is fine below the top...
    assert np.abs(article_pack_value(x, "round") - x).max() <= STEP / 2 + 4 * F32_EPS
    # ...but it wraps 1.0 to 0.
    assert article_pack_value(np.float32([1.0]), "round")[0] == 0.0


def article_pack_value(x, rule):
    return packing.article_unpack16(packing.article_pack16(x, rule))


finite_unit = st.floats(min_value=0.0, max_value=1.0, exclude_max=True, width=32)


@settings(max_examples=300, deadline=None)
@given(finite_unit, st.sampled_from(packing.STORE_RULES))
def test_property_pack_then_unpack_is_within_the_rule_bound(x, rule):
    decoded = float(packing.unpack16(packing.pack16(np.float32(x), rule)))
    bound = (STEP / 2 if rule == "round" else STEP) + 4 * F32_EPS
    assert abs(decoded - x) <= bound
    assert 0.0 <= decoded <= 1.0


@settings(max_examples=200, deadline=None)
@given(st.floats(width=32, allow_nan=True, allow_infinity=True))
def test_property_any_float32_decodes_to_its_documented_value(x):
    decoded = float(packing.unpack16(packing.pack16(np.float32(x))))
    assert abs(decoded - documented(x)) <= STEP / 2 + 4 * F32_EPS


@pytest.mark.parametrize("x", EDGES)
def test_edge_list_in_numpy(x):
    assert abs(float(packing.unpack16(packing.pack16(x))) - documented(x)) <= STEP / 2 + 4 * F32_EPS


def test_world_range_round_trip_and_top_of_range(gl):
    from es2particles.frame.state import Layout, Quantity, StateBuffer

    q = Quantity("position", -2, 2)
    values = np.array([[-2, 2], [2, -2], [0, 1e-9], [2.5, -7], [np.nan, np.inf], [1.0, -1.0]])
    layout = Layout.for_count(len(values), gl.caps.max_texture_size)
    group = gl.group()
    try:
        buffer = StateBuffer(group, q, layout, "rgba8", buffers=1)
        buffer.upload(values)
        got = buffer.download()
    finally:
        group.release()
    expected = np.array([[-2, 2], [2, -2], [0, 0], [2, -2], [-2, 2], [1, -1]], dtype=np.float64)
    world_step = 4 / 65024
    assert np.abs(got - expected).max() <= world_step / 2 + 1e-6, got
    assert got[0, 1] == 2.0 and got[1, 0] == 2.0, "the top of the range must stay the top"


@pytest.mark.parametrize("fmt", ["rgba8", "rgba16f", "rgba32f"])
def test_a_pass_writing_beyond_the_range_is_clamped_into_it(gl, fmt):
    """Every format holds a quantity within its range: a write beyond either end stores the end
    (RGBA8 by its codec's clamp, the float formats by state_clamp), in every component."""
    from bounds import rounding_error
    from conftest import wide_graph
    from es2particles import Simulation

    shift = (5.0, -5.0, 0.25, 0.0)  # past +1, past -1, within: position's range is [-1, 1]
    start = np.array([[0.5, -0.5, 0.5], [-0.9, 0.9, -0.2], [0.0, 0.0, 0.0]])
    with Simulation(gl, wide_graph(shift), len(start), fmt=fmt) as sim:
        sim.upload("position", start)
        sim.upload("mass", np.ones(len(start)))
        sim.upload("colour", np.ones((len(start), 4)))
        before = sim.download("position")
        sim.step()
        got = sim.download("position")
    exact = np.clip(before + np.array(shift[:3]), -1, 1)
    assert np.array_equal(got[:, :2], exact[:, :2]), f"{fmt}: the ends, {got[:, :2]}"
    # within the range: one write's rounding (half a code in RGBA8, half an ulp in float16)
    assert np.abs(got[:, 2] - exact[:, 2]).max() <= rounding_error(fmt, -1, 1)


@pytest.mark.parametrize("fmt", ["rgba8", "rgba16f", "rgba32f"])
def test_a_start_packed_in_runs_of_rows_is_the_same_bytes(fmt, monkeypatch):
    """encode_values packs ENCODE_ROWS rows at a time (its temporaries bounded, not 30 bytes a
    value of 2^26 particles): the texels are those of packing every row at once, values beyond
    the range and a last short run among them."""
    from es2particles.frame import state
    from es2particles.frame.graph import PassGraph
    from es2particles.twins.pack import state_encode

    monkeypatch.setattr(state, "ENCODE_ROWS", 1000)
    g = PassGraph()
    g.quantity("position", (-4.0, -1.0, -4.0), (4.0, 7.0, 4.0))
    q = g.quantities["position"]
    values = np.random.default_rng(3).uniform(-6, 9, (4321, 3))

    class Rows:
        count = len(values)

    whole = state_encode(values.astype(np.float32), q.lo32, q.span32, q.format_in(fmt))
    assert np.array_equal(state.encode_values(q, Rows, values, fmt), whole)
