// sin and cos computed here, from + - * and floor alone, instead of the driver's built-ins.
// GLSL ES leaves the built-ins' accuracy to the driver, and drivers differ: in Chromium's WebGL
// on SwiftShader, one de Jong iteration with the built-ins put the 16-bit state up to 7 codes
// (4e-4) from llvmpipe's (Vulkan allows sin an absolute error of 2^-11). These are within 1.2e-7
// of float64 sin and cos for |x| <= 1e4 (3e-7 at 2e4, 5e-7 at 5e4: tests/test_numerics.py),
// whatever the driver, so a scene written with them gives the same state bytes on EGL and in a
// browser (tests/test_export.py).
//
// x is reduced to r in [-pi/4, pi/4] and a quadrant by Cody-Waite: pi/2 split in three parts,
// the first two short enough that n times them is exact in float32 for |n| < 2^13; then the
// minimax polynomials of Cephes' sinf and cosf. NaN and +-Inf give NaN, as sin() does.
// numpy twins: es2particles/twins/trig.py.

const float TRIG_TWO_OVER_PI = 0.636619772367581;
const float TRIG_PIO2_1 = 1.5703125;                  // 8 significant bits
const float TRIG_PIO2_2 = 4.837512969970703125e-4;    // 11 significant bits
const float TRIG_PIO2_3 = 7.54978995489188216e-8;     // the rest of pi/2

vec2 trig_sin_cos_reduced(float r)
{
    float r2 = r * r;
    float s = r + r * r2 * (-1.6666654611e-1 + r2 * (8.3321608736e-3 + r2 * -1.9515295891e-4));
    float c = 1.0 - 0.5 * r2 + r2 * r2 * (4.166664568298827e-2
              + r2 * (-1.388731625493765e-3 + r2 * 2.443315711809948e-5));
    return vec2(s, c);
}

// (sin x, cos x).
vec2 trig_sin_cos(float x)
{
    float n = floor(x * TRIG_TWO_OVER_PI + 0.5);
    float r = ((x - n * TRIG_PIO2_1) - n * TRIG_PIO2_2) - n * TRIG_PIO2_3;
    vec2 sc = trig_sin_cos_reduced(r);
    float quadrant = n - 4.0 * floor(n * 0.25);  // 0..3
    if (quadrant == 1.0) {
        sc = vec2(sc.y, -sc.x);
    } else if (quadrant == 2.0) {
        sc = -sc;
    } else if (quadrant == 3.0) {
        sc = vec2(-sc.y, sc.x);
    }
    return sc;
}

float trig_sin(float x)
{
    return trig_sin_cos(x).x;
}

float trig_cos(float x)
{
    return trig_sin_cos(x).y;
}
