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
