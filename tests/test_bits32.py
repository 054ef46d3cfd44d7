"""32-bit packed state (a quantity declared ``bits=32``: storage ``rgba8_32``, one value a RGBA8
texel as two 16-bit codes): on the GPU, in the numpy twin, through a simulation and a map.

References are float64: the bytes (a, b, c, d) of a texel mean (255 a + b + (255 c + d) / 65024)
/ 65024 by definition, and the map's reference is numpy float64 on the values the state held.
"""

import numpy as np
import pytest

from conftest import run_fullscreen, shader
from es2particles import ParameterError, PassGraph, Simulation
from es2particles.frame.state import Quantity
from es2particles.twins import pack as packing

F32_HALF_ULP_1 = 2.0 ** -24  # float32's rounding of a value in [0.5, 1]: half an ulp
STEP16 = 1 / 65024


def bytes_value(texels):
    """Independent float64 decode of 32-bit texels (a, b, c, d)."""
    t = np.asarray(texels, dtype=np.float64)
    return (255 * t[..., 0] + t[..., 1] + (255 * t[..., 2] + t[..., 3]) / 65024) / 65024


def gpu_pack32(ctx, values):
    values = np.asarray(values, dtype=np.float32)
    width = int(np.ceil(np.sqrt(len(values))))
    height = -(-len(values) // width)
    texels = np.zeros((width * height, 4), dtype=np.float32)
    texels[: len(values), 0] = values
    src = ctx.texture((width, height), "rgba32f", data=texels.tobytes())
    try:
        return run_fullscreen(ctx, "pack32_floats.frag", src)[: len(values)]
    finally:
        ctx.free(src)


def test_pack32_keeps_float32_precision_on_gpu_and_in_the_twin(gl):
    rng = np.random.default_rng(7)
    k = np.arange(0, 65025, 97, dtype=np.float64)
    x = np.concatenate([rng.random(10 ** 6), k / 65024, (k + 0.5) / 65024, [0, 1, 1e-9, 2.0 ** -20,
                        1 - 2.0 ** -24, 0.5, 1.5, -1, np.inf, -np.inf]]).astype(np.float32)
    got = gpu_pack32(gl, x)
    expected = np.clip(np.nan_to_num(x.astype(np.float64), posinf=1, neginf=0), 0, 1)
    error = np.abs(bytes_value(got) - expected)
    # Within half an ulp of 1.0's neighbourhood (plus the half step of the second code, 2^-33):
    # float32 itself; 16-bit codes err by up to 2^-17.
    bound = F32_HALF_ULP_1 + 0.5 / 65024 ** 2
    print(f"GPU pack32: max |error| {error.max():.3e} (bound {bound:.3e}; 16-bit's half step "
          f"{STEP16 / 2:.3e})")
    assert error.max() <= bound
    assert np.all(bytes_value(got[expected == 1]) == 1.0), "the top must stay the top"
    twin = packing.pack32(x)
    differ = np.count_nonzero(np.any(twin != got, axis=1))
    assert differ == 0, f"the numpy twin differs from the GPU on {differ} of {len(x)} values"
    # Decoding: the twin and an independent float64 decode agree to float32's rounding.
    assert np.abs(packing.unpack32(got) - bytes_value(got)).max() <= F32_HALF_ULP_1


def test_a_32_bit_quantity_is_one_texel_a_value_and_float32_exact_in_every_float_format():
    q = Quantity("p", (-2.5, -2.5), (2.5, 2.5), bits=32)
    assert [q.format_in(f) for f in ("rgba8", "rgba16f", "rgba32f")] == \
        ["rgba8_32", "rgba8_32", "rgba32f"]
    assert q.parts("rgba8") == 2 and q.part_axes("rgba8", 1) == "y"
    assert q.bytes_per_particle("rgba8") == 8 and q.bytes_per_particle("rgba16f") == 8
    assert Quantity("c", 0, 1, components=3, bits=32).parts("rgba8") == 3
    with pytest.raises(ParameterError, match="bits must be 16 or 32"):
        Quantity("p", 0, 1, bits=24)


def dejong_graph(bits):
    g = PassGraph()
    g.quantity("q", (-2.5, -2.5), (2.5, 2.5), bits=bits)
    g.add("map", shader("dejong_step.frag"), writes="q", reads=["q"],
          uniforms={"u_k": (-2.0, -2.0, -1.2, 2.0)})
    return g


@pytest.mark.parametrize("fmt", ["rgba8", "rgba16f"])
def test_one_map_step_in_32_bit_state_errs_as_float32_not_as_16_bit_codes(gl, fmt):
    """One step of the de Jong map from the state's own values: the stored result against
    float64's map of what was stored. 32-bit state errs by float32's arithmetic (sin/cos of a
    GPU within a few ulps of 2.5); 16-bit codes by half a code of the range, 3.8e-5."""
    n = 4096
    rng = np.random.default_rng(3)
    start = rng.uniform(-2, 2, (n, 2))
    k = np.array([-2.0, -2.0, -1.2, 2.0])
    errors = {}
    for bits in (32, 16):
        with Simulation(gl, dejong_graph(bits), n, fmt="rgba8" if bits == 16 else fmt) as sim:
            sim.upload("q", start)
            held = sim.download("q")
            sim.run(1)
            got = sim.download("q")
        x, y = held[:, 0], held[:, 1]
        exact = np.stack([np.sin(k[0] * y) - np.cos(k[1] * x),
                          np.sin(k[2] * x) - np.cos(k[3] * y)], axis=1)
        errors[bits] = np.abs(got - exact).max()
        if bits == 32:  # world -> unit -> world in float32: two ulps of the span (5: 2^-21)
            assert np.abs(held - start).max() <= 2 * 2.0 ** -21, "upload lost precision"
    half_code = 0.5 * 5 / 65024
    print(f"{fmt}: one step max |error| 32-bit {errors[32]:.2e}, 16-bit {errors[16]:.2e} "
          f"(half a 16-bit code {half_code:.2e})")
    assert errors[32] <= 2e-6, "32-bit state must keep the map's float32 result"
    assert errors[16] > 0.5 * half_code  # the comparison can tell the two apart


@pytest.mark.parametrize("args, says", [
    (["dejong", "--rounding", "jitter"], "--rounding jitter: scene 'dejong' keeps its state in "
                                         "rgba8_32 here, always rounded to the nearest value"),
    (["clifford", "--rounding", "dither"], "--rounding dither: scene 'clifford' keeps"),
    (["dejong", "--format", "rgba16f"], "--format rgba16f: scene 'dejong' keeps its state in "
                                        "rgba8_32 with --format rgba8 too"),
    (["dejong", "--reseed", "--format", "rgba32f", "--rounding", "jitter"],
     "--rounding jitter: scene 'dejong' keeps its state in rgba32f here"),
])
def test_a_state_setting_that_would_change_nothing_is_refused_in_one_line(args, says, capsys,
                                                                         tmp_path):
    from es2particles.cli import main

    out = tmp_path / "x.png"
    assert main(["run", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert says in err and len(err.splitlines()) == 1, err
    assert not out.exists()


def test_state_settings_that_act_are_taken():
    """The same settings where they change the state: the reseeded attractor's 16-bit position
    in rgba16f, dithered 16-bit state in the collision scene."""
    from es2particles.frame.plan import plan_frame
    from es2particles.frame.settings import FrameSettings
    from es2particles.scenes import Collision, DeJong

    plan = plan_frame(DeJong(reseed=True), FrameSettings(format="rgba16f", particles=64), None)
    assert plan.resources["position"].format == "rgba16f"
    plan = plan_frame(Collision(), FrameSettings(rounding="dither", particles=64), None)
    assert plan.resources["position"].format == "rgba8"
    assert any("STATE_DITHER" in s.defines for s in plan.stages)


def test_the_plan_says_which_quantities_are_32_bit():
    from es2particles.frame.plan import plan_frame
    from es2particles.frame.settings import FrameSettings
    from es2particles.scenes import DeJong

    text = "\n".join(plan_frame(DeJong(), FrameSettings(particles=64), None).describe())
    assert "position (2 components, rgba8_32: 32 bits a value): 2 parts x 2" in text
    assert "writes position part 2/2 (y)" in text
    text = "\n".join(plan_frame(DeJong(), FrameSettings(particles=64, format="rgba32f"),
                                None).describe())
    assert "position (2 components): 2 (" in text
