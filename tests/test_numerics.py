"""The numerical defects an independent float64 check found (biased dither, thin walls, the
sub-step cap, clocks, float formats, contact symmetry, bad inputs...), each as a stability case
the report prints with its figure and bound; here each must pass."""

import pytest

from es2particles.report.stability import NUMERICS


@pytest.mark.parametrize("name", list(NUMERICS))
def test_numerics_case(gl, name):
    case = NUMERICS[name](gl)
    print(" | ".join(map(str, case.row())))
    assert case.passed, f"{case.name}: measured {case.measured}, bound {case.bound}"


def test_parameters_that_would_void_no_tunnelling_are_refused(capsys):
    from es2particles.cli import main

    code = main(["run", "collision", "--dt", "1", "--field-resolution", "4096", "--out", "x.png"])
    message = capsys.readouterr().err
    assert code == 2 and "sub-steps of half a cell to rule out tunnelling; at most 4096" in message
    assert message.count("\n") == 1 and "Traceback" not in message
