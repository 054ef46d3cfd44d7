"""Back-to-front sorting on the GPU (es2particles/render/sort.py) against independent numpy references:
the network's schedule against np.sort and the textbook loop, the GPU network against numpy's
stable argsort and against its numpy twin pass by pass, the key pass against float64 view depths,
the decoding of lib/order.glsl in a vertex shader, spreading the passes over frames, and the
errors."""

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from conftest import glslang
from es2particles.render.camera import Camera, orbit
from es2particles.errors import ParameterError
from es2particles.gl.bindings import stage_interface
from es2particles.gl.shaders import expand
from es2particles.gl.command import DrawCommand
from es2particles.render.sort import (DepthSorter, SortingNetwork, comparators, network_pass,
                               network_sort, order_defines, schedule, sortedness)
from es2particles.frame.state import Layout, Quantity, StateBuffer

FORMATS = ("rgba8", "rgba32f")
COUNTS = (1, 2, 3, 1000, 4097)  # 4097: one past a power of two, 8192 slots, half padding


# --- the network in numpy ------------------------------------------------------------------

def textbook_comparators(n):
    """The comparators of each pass, from the iterative odd-even merge sort as Knuth and
    Wikipedia write it (four nested loops), independent of sort.py's per-slot arithmetic."""
    passes = []
    p = 1
    while p < n:
        k = p
        while k >= 1:
            pairs = set()
            for j in range(k % p, n - k, 2 * k):
                for i in range(min(k, n - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        pairs.add((i + j, i + j + k))
            passes.append(pairs)
            k //= 2
        p *= 2
    return passes


@pytest.mark.parametrize("levels", range(0, 9))
def test_each_slot_finds_the_textbook_comparators(levels):
    n = 2 ** levels
    plan = schedule(n)
    assert len(plan) == levels * (levels + 1) // 2
    textbook = textbook_comparators(n)
    assert len(textbook) == len(plan)
    for (p, k), expected in zip(plan, textbook):
        lower, upper = comparators(n, p, k)
        got = {(a, a + k) for a in np.flatnonzero(lower)}
        assert got == expected, f"pass p={p} k={k}"
        assert set(np.flatnonzero(upper)) == {b for _, b in expected}
        assert not np.any(lower & upper)


def test_numpy_network_equals_np_sort_for_every_level():
    rng = np.random.default_rng(5)
    for levels in range(0, 13):
        n = 2 ** levels
        for values in (rng.random(n), rng.integers(0, 3, n), np.arange(n)[::-1].copy()):
            np.testing.assert_array_equal(network_sort(values), np.sort(values),
                                          err_msg=f"L={levels}")


def test_sorted_input_is_unchanged_by_every_prefix_of_passes_numpy():
    rng = np.random.default_rng(6)
    for levels in range(1, 11):
        values = np.sort(rng.integers(0, 5, 2 ** levels))  # with many ties
        state = values
        for p, k in schedule(len(values)):
            state = network_pass(state, p, k)
            np.testing.assert_array_equal(state, values, err_msg=f"L={levels} after p={p} k={k}")


def test_sortedness_measures():
    depth = np.array([5.0, 4.0, 3.0, 2.0, 1.0])
    assert sortedness(np.arange(5), depth).adjacent == 0  # far first: already back to front
    s = sortedness(np.arange(5)[::-1], depth)
    assert (s.adjacent, s.discordant) == (1.0, 1.0)
    assert s.displacement == pytest.approx((4 + 2 + 0 + 2 + 4) / 5 / 5)
    s = sortedness([0, 2, 1, 3, 4], depth)  # one swap of neighbours
    assert s.adjacent == 0.25 and s.discordant == pytest.approx(1 / 10)
    assert s.depth_error == pytest.approx(2 / 5 / 4)
    # ties may go either way: nothing is out of order
    s = sortedness([1, 0, 2], np.array([1.0, 1.0, 0.0]))
    assert (s.adjacent, s.displacement, s.discordant, s.depth_error) == (0, 0, 0, 0)
    rng = np.random.default_rng(1)
    x = rng.integers(0, 40, 300)
    brute = sum(int(np.count_nonzero(x[i] < x[i + 1:])) for i in range(len(x)))
    assert sortedness(np.arange(300), x.astype(float)).discordant == brute / (300 * 299 / 2)


# --- the network on the GPU ----------------------------------------------------------------

def expected_order(network, keys):
    """numpy's stable argsort of what the network compares: the quantised codes (rgba8) or the
    float32 keys."""
    if network.fmt == "rgba8" and not np.issubdtype(np.asarray(keys).dtype, np.integer):
        keys = np.floor(np.clip(keys, 0, 1) * (2.0 ** network.key_bits - 1) + 0.5)
    elif network.fmt == "rgba32f":
        keys = np.asarray(keys).astype(np.float32)
    return np.argsort(keys, kind="stable")


def check_sorted(network, keys, what):
    got_keys, got = network.read()
    want = expected_order(network, keys)
    assert np.array_equal(got, want), (
        f"{what}: {np.count_nonzero(got != want)} of {network.count} slots differ from numpy's "
        f"stable argsort; first at {np.flatnonzero(got != want)[:5]}")
    all_keys, all_indices = network.read_slots()
    padding = all_indices[network.count:]
    assert np.array_equal(np.sort(padding), np.arange(network.count, network.slots)), what
    assert np.all(np.diff(got_keys) >= 0), what


def key_sets(count, rng, fmt):
    few = rng.integers(0, 4, count) / 3  # four distinct keys: ties everywhere
    random = rng.random(count)
    sets = {"random": random, "ties": few, "sorted": np.sort(random),
            "reversed": np.sort(random)[::-1].copy()}
    if fmt == "rgba32f":
        sets["wide"] = rng.normal(0, 1e30, count)  # any finite float
    return sets


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("count", COUNTS)
def test_gpu_network_is_numpys_stable_argsort(gl, fmt, count):
    rng = np.random.default_rng(count)
    with SortingNetwork(gl, count, fmt) as network:
        levels = math.ceil(math.log2(count))
        assert network.slots == 2 ** levels and network.passes == levels * (levels + 1) // 2
        for name, keys in key_sets(count, rng, fmt).items():
            network.load(keys)
            network.run()
            check_sorted(network, keys, f"{fmt} count {count} {name} keys")


def test_integer_codes_use_every_key_bit(gl):
    """rgba8 codes are taken as they are: keys that differ only in the lowest or the highest key
    bit sort apart, and the index bits never leak into the key."""
    rng = np.random.default_rng(2)
    for count in (200, 70000):  # 24 key bits (8 index bits); 15 key bits (17 index bits)
        with SortingNetwork(gl, count, "rgba8") as network:
            top = network.key_max
            codes = rng.choice(np.array([0, 1, top - 1, top, top // 2, top // 2 + 1]), count)
            network.load(codes)
            network.run()
            keys, indices = network.read()
            assert np.array_equal(indices, np.argsort(codes, kind="stable"))
            assert np.array_equal(keys, np.sort(codes))


@pytest.mark.parametrize("fmt", FORMATS)
def test_gpu_passes_equal_the_numpy_twin_pass_by_pass(gl, fmt):
    """Every prefix of the passes, not only the whole network: what spreading the sort over
    frames shows on screen. A sorted input stays as it is after every pass."""
    count = 300  # 512 slots, 45 passes
    rng = np.random.default_rng(9)
    with SortingNetwork(gl, count, fmt) as network:
        keys = rng.integers(0, 6, count) / 5
        network.load(keys)
        texels = network.read_slots()
        # the pairs as one comparable number: key rank, then index
        distinct = np.unique(texels[0])
        twin = np.searchsorted(distinct, texels[0]).astype(np.int64) * network.slots + texels[1]
        for i, (p, k) in enumerate(network.schedule):
            network.run(1)
            twin = network_pass(twin, p, k)
            got_keys, got_indices = network.read_slots()
            where = f"after pass {i} (p={p} k={k})"
            assert np.array_equal(got_indices, twin % network.slots), where
            assert np.array_equal(np.searchsorted(distinct, got_keys), twin // network.slots), where
        network.load(np.sort(keys))
        start = network.read_slots()
        for i in range(network.passes):
            network.run(1)
            got = network.read_slots()
            assert np.array_equal(got[1], start[1]) and np.array_equal(got[0], start[0]), (
                f"a sorted order changed at pass {i}")


# --- the key pass ----------------------------------------------------------------------------

CAMERA = Camera(eye=(5.0, 3.0, 8.0), target=(0.3, -0.2, 0.1))


def make_state(gl, group, name, count, state_format, rng):
    quantity = Quantity(name, (-2.0, -1.0, -3.0), (2.0, 3.0, 1.0))
    layout = Layout.for_count(count, gl.caps.max_texture_size)
    buffer = StateBuffer(group, quantity, layout, state_format, buffers=1)
    buffer.upload(rng.uniform(quantity.lo, quantity.hi, (count, 3)))
    return quantity, layout, buffer


def view_depth(buffer, camera):
    """float64 view depths of the positions the state holds (decoded as the shader decodes)."""
    return (buffer.download() - np.array(camera.eye)) @ camera.forward


@pytest.mark.parametrize("state_format, fmt, name", [("rgba8", "rgba8", "position"),
                                                     ("rgba8", "rgba32f", "pos"),
                                                     ("rgba32f", "rgba8", "position"),
                                                     ("rgba32f", "rgba32f", "p")])
def test_key_pass_orders_back_to_front(gl, state_format, fmt, name):
    count = 3001  # state 55 x 55 texels (a width no power of two), 4096 slots
    rng = np.random.default_rng(4)
    group = gl.group()
    try:
        quantity, layout, buffer = make_state(gl, group, name, count, state_format, rng)
        sorter = DepthSorter(gl, quantity, layout, state_format, fmt=fmt)
        try:
            sorter.update({name: buffer}, CAMERA)
            order = sorter.order()
            keys, _ = sorter.network.read()
            depth = view_depth(buffer, CAMERA)
            near, far = sorter.depth_range(CAMERA)
            assert near <= depth.min() and depth.max() <= far
            assert np.array_equal(np.sort(order), np.arange(count)), "not a permutation"
            # float32 rounding on the GPU: a few ulps of the largest term of dot(p - eye, f)
            eps = 8 * 2.0 ** -24 * (np.linalg.norm(CAMERA.eye) + 4)
            if fmt == "rgba8":
                step = (far - near) / sorter.network.key_max
                codes = (far - depth) / (far - near) * sorter.network.key_max
                assert np.all(np.abs(keys - codes[order]) <= 0.5 + eps / step), (
                    f"keys are not the rounded codes: off by up to "
                    f"{np.max(np.abs(keys - codes[order])):.3f} codes (allowed 0.5 + "
                    f"{eps / step:.3f} for float32)")
                tolerance = step + 2 * eps
            else:
                np.testing.assert_allclose(keys, -depth[order], rtol=0, atol=eps)
                tolerance = 2 * eps
            drawn = depth[order]
            worst = float(np.max(drawn[1:] - drawn[:-1]))
            assert worst <= tolerance, (
                f"a nearer particle is drawn before a farther one by {worst:.3g} world units "
                f"(tolerance {tolerance:.3g}: one key step and float32 rounding)")
            # ties of the key are broken by the particle index, as numpy's stable argsort does
            assert np.array_equal(order, np.argsort(keys[np.argsort(order)], kind="stable"))
            # without sorting the same check fails: it can fail
            assert np.max(depth[1:] - depth[:-1]) > 100 * tolerance
        finally:
            sorter.release()
    finally:
        group.release()


VERTEX = """#version 100
// Vertex i decodes slot i of the order, as a sprite renderer's vertex shader does.
precision highp float;
precision highp sampler2D;
#include "lib/order.glsl"
attribute vec2 a_slot;
uniform sampler2D u_order;
uniform vec2 u_state_size;
varying vec4 v_out;

void main()
{
    float index = order_index(texture2D(u_order, a_slot));
    v_out = vec4(index, order_particle_uv(u_order, a_slot, u_state_size), 1.0);
    gl_Position = vec4(a_slot * 2.0 - 1.0, 0.0, 1.0);  // onto the slot's own texel
}
"""
FRAGMENT = """#version 100
precision highp float;
varying vec4 v_out;

void main()
{
    gl_FragColor = v_out;
}
"""


@pytest.mark.parametrize("fmt", FORMATS)
def test_order_glsl_decodes_slots_in_a_vertex_shader(gl, fmt, tmp_path):
    count = 70001  # 17 index bits: the high half holds one of them; state 265 x 265
    state = Layout.for_count(count, gl.caps.max_texture_size)
    (tmp_path / "decode.vert").write_text(VERTEX)
    (tmp_path / "decode.frag").write_text(FRAGMENT)
    rng = np.random.default_rng(8)
    with SortingNetwork(gl, count, fmt) as network:
        network.load(rng.random(count))
        network.run()
        _, order = network.read()
        group = gl.group()
        try:
            slots = group.buffer(network.slot_uv().tobytes())
            decode = DrawCommand(group, "decode", str(tmp_path / "decode.frag"),
                                 str(tmp_path / "decode.vert"), network.defines(),
                                 vertices=[(slots, "2f", "a_slot")], primitive="points")
            target = group.texture(network.layout, "rgba32f")
            framebuffer = group.framebuffer(target)
            gl.clear(framebuffer, (-1.0, -1.0, -1.0, -1.0))
            decode.draw(framebuffer, {"u_order": network.texture},
                        {"u_state_size": (float(state.width), float(state.height))})
            out = np.frombuffer(gl.read(target), np.float32).reshape(-1, 4)[:count]
        finally:
            group.release()
    assert np.array_equal(out[:, 0], order.astype(np.float32)), "order_index"
    # The texel centre (i + 0.5) / size is one division: GLSL allows it 2.5 ulps (4.x, ES 3.00;
    # ES 1.00 states none). llvmpipe rounds it correctly; NVIDIA's driver multiplies by a
    # reciprocal, 1 ulp off in 19% of these (an H200, driver 580). Either way the same texel.
    exact = state.texel_uv()[order]
    ulps = np.abs(out[:, 1:3] - exact) / np.spacing(exact)
    assert ulps.max() <= 2.5, f"order_state_uv: {ulps.max():.3g} ulps from the texel centre"


def test_shaders_are_valid_glsl_es_100_in_every_build(gl, tmp_path):
    """glslangValidator over key.frag with its generated interface (test_shaders leaves out
    shaders that call generated accessors) and over lib/order.glsl in a vertex shader, for each
    order format and both halves of the rgba8 index split."""
    tool = glslang()
    quantity = Quantity("position", -1.0, 1.0, components=3)
    builds = [order_defines("rgba32f", 100), order_defines("rgba8", 100),
              order_defines("rgba8", 70000)]  # 8 and 17 index bits
    (tmp_path / "decode.vert").write_text(VERTEX)
    for defines in builds:
        for state_format in ("rgba8", "rgba16f", "rgba32f"):
            prelude = stage_interface(("position",), {"position": quantity}, state_format).lines
            for name, source in (("key.frag", expand("sort/key.frag", defines, prelude).text),
                                 ("merge.frag", expand("sort/merge.frag", defines).text),
                                 ("decode.vert", expand(str(tmp_path / "decode.vert"),
                                                        defines).text)):
                target = tmp_path / ("x" + Path(name).suffix)
                target.write_text(source)
                result = subprocess.run([tool, str(target)], capture_output=True, text=True)
                assert result.returncode == 0, (f"{name} {defines} {state_format}:\n"
                                                f"{result.stdout}{result.stderr}")


# --- spreading over frames ---------------------------------------------------------------------

def test_spread_passes_reach_the_full_sort_after_ceil_p_over_k_updates(gl):
    count, per_frame = 1000, 7  # 1024 slots, 55 passes: 8 frames
    rng = np.random.default_rng(12)
    group = gl.group()
    try:
        quantity, layout, buffer = make_state(gl, group, "position", count, "rgba8", rng)
        with_full = DepthSorter(gl, quantity, layout, passes_per_frame=None)
        spread = DepthSorter(gl, quantity, layout, passes_per_frame=per_frame)
        try:
            with_full.update({"position": buffer}, CAMERA)
            want = with_full.order()
            frames = math.ceil(spread.network.passes / per_frame)
            assert frames == 8
            assert "7 of 55" in spread.describe() and "every 8 frames" in spread.describe()
            for frame in range(frames):
                spread.update({"position": buffer}, CAMERA)
                got = spread.order()
                if frame == frames - 2:
                    assert not np.array_equal(got, want), "sorted a frame early: test too weak"
            assert np.array_equal(got, want)
            for _ in range(3):  # later frames keep it as it is
                spread.update({"position": buffer}, CAMERA)
                assert np.array_equal(spread.order(), want)
        finally:
            with_full.release()
            spread.release()
    finally:
        group.release()


def test_spread_sort_of_moving_particles_stays_nearly_sorted(gl):
    """Particles drift (crossing the box in ~300 frames) while the camera orbits (a turn in 600
    frames): ~10 ranks of change per frame. With 8 of 78 passes per frame the order stays close
    to back to front (numbers in the assertion messages; an unsorted order is ~33% displaced)."""
    count, per_frame, frames = 4096, 8, 40
    rng = np.random.default_rng(3)
    group = gl.group()
    try:
        quantity, layout, buffer = make_state(gl, group, "position", count, "rgba8", rng)
        start = buffer.download()
        velocity = rng.normal(0, 0.01, (count, 3))
        sorter = DepthSorter(gl, quantity, layout, passes_per_frame=per_frame)
        try:
            measures = []
            for frame in range(frames):
                buffer.upload(np.clip(start + velocity * frame, quantity.lo, quantity.hi))
                camera = orbit(frame, 600, radius=6.0, height=2.0, target=(0.0, 0.0, 0.0))
                sorter.update({"position": buffer}, camera)
                if frame >= 10:  # after the first whole cycle
                    measures.append(sortedness(sorter.order(), view_depth(buffer, camera)))
            unsorted = sortedness(np.arange(count), view_depth(buffer, camera))
        finally:
            sorter.release()
    finally:
        group.release()
    mean = {f: float(np.mean([getattr(m, f) for m in measures]))
            for f in ("adjacent", "displacement", "discordant", "depth_error")}
    worst = {f: float(np.max([getattr(m, f) for m in measures]))
             for f in ("displacement", "discordant", "depth_error")}
    report = f"mean {mean}, worst {worst}, unsorted: {unsorted}"
    assert unsorted.displacement > 0.25, report
    assert mean["displacement"] < 0.02 and worst["displacement"] < 0.04, report
    assert mean["discordant"] < 0.025 and worst["discordant"] < 0.05, report
    assert mean["depth_error"] < 0.02, report


# --- errors and resources ------------------------------------------------------------------------

@pytest.mark.parametrize("make, name", [
    (lambda gl: SortingNetwork(gl, 0), "count"),
    (lambda gl: SortingNetwork(gl, 2 ** 24 + 1), "count"),
    (lambda gl: SortingNetwork(gl, 10, fmt="rgba16"), "fmt"),
    (lambda gl: DepthSorter(gl, Quantity("position", -1, 1, components=3),
                            Layout(10, 4, 3), passes_per_frame=0), "passes_per_frame"),
    (lambda gl: DepthSorter(gl, Quantity("position", -1, 1, components=2),
                            Layout(10, 4, 3)), "position_quantity"),
])
def test_errors_name_the_parameter(gl, make, name):
    before = gl.live_objects()
    with pytest.raises(ParameterError) as info:
        make(gl)
    assert name in str(info.value)
    assert gl.live_objects() == before


def test_load_checks_its_keys(gl):
    with SortingNetwork(gl, 10, "rgba8") as network:
        with pytest.raises(ParameterError, match=r"shape \(10,\)"):
            network.load(np.zeros(9))
        with pytest.raises(ParameterError, match="codes"):
            network.load(np.full(10, 2 ** 24))
        with pytest.raises(ParameterError, match="finite"):
            network.load(np.full(10, np.nan))
    with SortingNetwork(gl, 10, "rgba32f") as network:
        with pytest.raises(ParameterError, match="finite"):
            network.load(np.full(10, np.inf))


def test_nothing_leaks_and_release_is_safe_twice(gl):
    rng = np.random.default_rng(0)
    group = gl.group()
    quantity, layout, buffer = make_state(gl, group, "position", 100, "rgba8", rng)
    sorter = DepthSorter(gl, quantity, layout)  # compiles its programs once (the cache keeps them)
    sorter.release()
    before = gl.live_objects()
    sorter = DepthSorter(gl, quantity, layout, passes_per_frame=3)
    for frame in range(4):
        sorter.update({"position": buffer}, orbit(frame, 10))
    assert gl.live_objects()["Texture"] == before["Texture"] + 2  # the two order textures
    sorter.release()
    sorter.release()
    assert gl.live_objects() == before
    group.release()
    assert sorter.describe().startswith("sort: key pass + 3 of 28 odd-even merge passes")
