"""numpy twin of ``lib/trig.glsl``: sin and cos from + - * and floor, in float32 step by step
as the shader computes them (no fused multiply-add)."""

import numpy as np

F32 = np.float32
TWO_OVER_PI = F32(0.636619772367581)
PIO2 = (F32(1.5703125), F32(4.837512969970703125e-4), F32(7.54978995489188216e-8))
SIN = (F32(-1.6666654611e-1), F32(8.3321608736e-3), F32(-1.9515295891e-4))
COS = (F32(4.166664568298827e-2), F32(-1.388731625493765e-3), F32(2.443315711809948e-5))


def sin_cos(x):
    """(sin x, cos x) of float32 ``x`` as ``trig_sin_cos`` computes them."""
    x = np.asarray(x, F32)
    with np.errstate(invalid="ignore"):
        n = np.floor(x * TWO_OVER_PI + F32(0.5))
        r = ((x - n * PIO2[0]) - n * PIO2[1]) - n * PIO2[2]
        r2 = r * r
        s = r + r * r2 * (SIN[0] + r2 * (SIN[1] + r2 * SIN[2]))
        c = F32(1) - F32(0.5) * r2 + r2 * r2 * (COS[0] + r2 * (COS[1] + r2 * COS[2]))
        quadrant = n - F32(4) * np.floor(n * F32(0.25))
    sin = np.select([quadrant == 1, quadrant == 2, quadrant == 3], [c, -s, -c], s)
    cos = np.select([quadrant == 1, quadrant == 2, quadrant == 3], [-s, -c, s], c)
    return sin.astype(F32), cos.astype(F32)
