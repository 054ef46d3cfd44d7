"""The numerical defects an independent float64 check found (biased dither, thin walls, the
sub-step cap, clocks, float formats, contact symmetry, bad inputs...), each as a stability case
the report prints with its figure and bound; here each must pass."""

import numpy as np
import pytest

from bounds import TRIG_ERROR
from conftest import run_fullscreen
from es2particles.report.stability import NUMERICS


@pytest.mark.parametrize("name", list(NUMERICS))
def test_numerics_case(gl, name):
    case = NUMERICS[name](gl)
    print(" | ".join(map(str, case.row())))
    assert case.passed, f"{case.name}: measured {case.measured}, bound {case.bound}"


def test_parameters_that_would_void_no_tunnelling_are_refused(capsys, tmp_path):
    from es2particles.cli import main

    code = main(["run", "collision", "--dt", "1", "--field-resolution", "4096", "--out",
                 str(tmp_path / "x.png")])
    message = capsys.readouterr().err
    assert code == 2 and "sub-steps of half a cell to rule out tunnelling; at most 4096" in message
    assert message.count("\n") == 1 and "Traceback" not in message
    assert list(tmp_path.iterdir()) == []


NUMERIC_OPTIONS = {
    "dejong": ["--a", "--b", "--c", "--d", "--exposure", "--point-size", "--intensity",
               "--bloom-threshold", "--bloom-radius", "--bloom-intensity"],
    "clifford": ["--a", "--d"],
    "collision": ["--dt", "--gravity", "--drag", "--sliding", "--bounce"],
    "smoke": ["--dt", "--tau", "--opacity"],
}


@pytest.mark.parametrize("scene, option, value", [
    (scene, option, value) for scene, options in NUMERIC_OPTIONS.items() for option in options
    for value in ("nan", "inf", "-inf")])
def test_non_finite_parameters_are_refused_in_one_line(scene, option, value, capsys, tmp_path):
    from es2particles.cli import main

    out = tmp_path / "x.png"
    code = main(["run", scene, option, value, "--particles", "64", "--size", "16x16",
                 "--steps", "1", "--out", str(out)])
    message = capsys.readouterr().err
    assert code == 2, f"{option} {value} was accepted"
    assert message.count("\n") == 1 and "Traceback" not in message, message
    assert option.lstrip("-").replace("-", " ").split()[0] in message.replace("-", " "), message
    assert not out.exists()


@pytest.mark.parametrize("value", ["1.5", "-0.1"])
def test_sliding_out_of_range_is_refused_not_clamped(value, capsys, tmp_path):
    from es2particles.cli import main

    assert main(["run", "collision", "--sliding", value, "--out", str(tmp_path / "x.png")]) == 2
    assert "sliding must be in [0, 1]" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_a_range_that_overflows_float32_is_refused():
    from es2particles import ParameterError, PassGraph

    with pytest.raises(ParameterError, match="overflows float32"):
        PassGraph().quantity("q", -1e300, 1e300)
    with pytest.raises(ParameterError, match="overflows float32"):
        PassGraph().quantity("q", -3e38, 3e38)  # each bound fits; the span does not


@pytest.mark.parametrize("reach, tolerance", [(4.0, TRIG_ERROR), (1e2, TRIG_ERROR), (2e4, 3e-7)])
def test_trig_is_float64_sin_and_cos_to_float32_rounding(gl, reach, tolerance):
    """lib/trig.glsl, which the attractors use so that a browser's WebGL computes the same
    state as EGL: against float64 sin and cos, and bit for bit against its numpy twin (only
    + - * floor, rounded in float32 step by step). Within +-100 its error bound is
    tests/bounds.py's TRIG_ERROR, which the attractors' float64 bounds carry.

    A driver that fuses a * b + c into one rounding (NVIDIA's: ``caps.fused_multiply_add``)
    computes with fewer roundings than the twin, so not bit for bit: there the float64 bound
    still holds, and within +-100 (where n times the first two parts of pi/2 is exact either
    way, so only the polynomials differ) the twin is matched to 2^-24, half an ulp of 1 (an
    H200: 590 of 4096 sines one ulp of a value below 1 apart, none more). At 2e4 the products
    n * (pi/2)'s parts round in the twin and not fused, so the two differ by up to their two
    bounds: only the float64 bound is asserted."""
    from es2particles.twins.trig import sin_cos

    x = np.random.default_rng(7).uniform(-reach, reach, 64 * 64).astype(np.float32)
    source = gl.texture((64, 64), "rgba32f", data=np.repeat(x, 4).astype(np.float32).tobytes())
    try:
        out = run_fullscreen(gl, "trig.frag", source, "rgba32f")
    finally:
        gl.free(source)
    exact = x.astype(np.float64)
    for k, (reference, name) in enumerate(((np.sin(exact), "sin"), (np.cos(exact), "cos"))):
        error = np.abs(out[:, k] - reference).max()
        assert error <= tolerance, f"trig_{name} within +-{reach:g}: error {error:.3g}"
        twin = sin_cos(x)[k]
        if not gl.caps.fused_multiply_add:
            assert np.array_equal(out[:, k], twin), \
                f"trig_{name}: {np.count_nonzero(out[:, k] != twin)} values differ from the twin"
        elif reach <= 100:
            apart = np.abs(out[:, k].astype(np.float64) - twin).max()
            assert apart <= 2.0 ** -24, f"trig_{name} (fused multiply-add): {apart:.3g} apart"


def test_the_multiply_add_probe_finds_what_the_driver_does(gl):
    """``caps.multiply_add``: a shader's u * v - w, with u = v = 1 + 2^-12 and w = 1 + 2^-11,
    is 2^-24 fused and 0 rounded twice (float64: the exact product less w). llvmpipe rounds
    twice; NVIDIA's driver fuses."""
    exact = (1 + 2.0 ** -12) ** 2 - (1 + 2.0 ** -11)
    assert exact == 2.0 ** -24
    assert float(np.float32(1 + 2.0 ** -12) * np.float32(1 + 2.0 ** -12)) == 1 + 2.0 ** -11
    expected = {"llvmpipe": "two roundings", "NVIDIA": "fused (one rounding)"}
    for name, rule in expected.items():
        if name in gl.caps.renderer:
            assert gl.caps.multiply_add == rule
    assert gl.caps.multiply_add in expected.values()
