"""Error bounds derived from the storage formats and float32, shared by the float64 comparisons.

Every tolerance a GPU-against-float64 test uses is built from these, so that it says where it
comes from (and prints it): half a code of a packed range, float32 rounding of the values a shader
computes, and the trig error that ``test_numerics.py`` measures for ``lib/trig.glsl``. A test of
each bound's sharpness (a half-code bias must fail it) lives with the test that uses it and in the
mutation suite (``python -m tests.mutations``).
"""

import numpy as np

CODES = 65024  # codes of a packed 16-bit value (lib/pack.glsl)
U = 2.0 ** -24  # float32's unit roundoff: one rounding of a value x errs by at most |x| U
# lib/trig.glsl's largest |error| against float64 sin and cos, for arguments within +-100:
# measured, and asserted, by test_numerics.py::test_trig_is_float64_sin_and_cos_to_float32_rounding.
TRIG_ERROR = 1.2e-7
# float16's unit roundoff (10 stored mantissa bits)
U16 = 2.0 ** -11


def half_code(lo, hi):
    """Half a code of the packed range [lo, hi]: the largest error of nearest rounding."""
    return (np.asarray(hi, float) - np.asarray(lo, float)) / CODES / 2


def codec_error(lo, hi):
    """float32 rounding in one encode or decode of a value of [lo, hi] (state_unit, unpack16 and
    state_decode each round a handful of times, every value at most max(|lo|, |hi|, hi - lo))."""
    scale = np.maximum(np.maximum(np.abs(lo), np.abs(hi)), np.asarray(hi, float) - lo)
    return 4 * U * scale


def rounding_error(fmt, lo, hi, dithered=False):
    """Largest error of writing a value of [lo, hi] in ``fmt`` and reading it back: half a code
    (a whole code when dithered) for rgba8, half an ulp of the largest value for the float
    formats, plus the codec's float32 rounding."""
    if fmt == "rgba8":
        return (2 if dithered else 1) * half_code(lo, hi) + 2 * codec_error(lo, hi)
    unit = {"rgba16f": U16, "rgba32f": U}[fmt]
    return unit * np.maximum(np.abs(lo), np.abs(hi))


def mean_rounding_bound(errors_half_code, count, dithered=False):
    """Six standard deviations of the mean of ``count`` independent rounding errors: uniform on
    [-h, h] (nearest, variance h^2/3) or, dithered, 1 - f codes with probability f and -f with
    1 - f (mean zero, variance f (1 - f) codes^2, at most h^2). A systematic bias of a fraction of
    a code stands far outside it."""
    variance = errors_half_code ** 2 * (1 if dithered else 1 / 3)
    return 6 * np.sqrt(variance / count)


def trig_map_error(components, start, start_error, iterations):
    """Per-particle bound on how far a float32 GPU run of a trigonometric map ends from float64.

    The map's each output component is a sum of terms ``outer * f(k * p[axis])``, f sin or cos,
    given as ``components = [[(outer, k, axis, "sin" | "cos"), ...], ...]``. One term's float32
    evaluation errs by at most: the input's error carried by the local derivative at the float64
    point (|outer k f'| e, plus the second-order (k e)^2 / 2), the argument's two roundings (k to
    float32 and the product), the trig error TRIG_ERROR, and for an outer factor other than +-1 its
    own two roundings; the sum rounds once more. Errors are carried in the max norm over axes.
    ``start_error`` is each particle's start error (scalar or array). Returns the float64 end
    points (count, 2) and each particle's error bound (count,)."""
    p = np.asarray(start, dtype=np.float64)
    error = np.broadcast_to(np.asarray(start_error, float), (len(p),)).copy()
    for _ in range(iterations):
        values, errors = [], []
        for terms in components:
            value = np.zeros(len(p))
            term_errors = np.zeros(len(p))
            for outer, k, axis, kind in terms:
                z = k * p[:, axis]
                f, slope = (np.sin(z), np.cos(z)) if kind == "sin" else (np.cos(z), -np.sin(z))
                argument_error = abs(k) * error + 2 * U * np.abs(z)
                term_errors += abs(outer) * (np.abs(slope) * argument_error
                                             + argument_error ** 2 / 2 + TRIG_ERROR)
                if abs(outer) != 1:
                    term_errors += 2 * U * np.abs(outer * f)
                value += outer * f
            values.append(value)
            errors.append(term_errors + U * np.abs(value))
        p = np.stack(values, axis=-1)
        error = np.maximum.reduce(errors)
    return p, error


def float_rounding(magnitude, fmt="rgba32f", whole_ulp=False):
    """Largest error of rounding a value of magnitude at most ``magnitude`` to the floats of
    ``fmt`` (float32: rgba32f, float16: rgba16f): half their spacing in its binade, U or U16 times
    2^floor(log2 m) (at least half the subnormal spacing), or the whole spacing where the
    conversion may round towards zero (GL leaves the conversion of a value written into a
    half-float target to the driver; llvmpipe's truncates). One float32 operation's rounding is
    ``float_rounding(|result|)``."""
    unit, smallest = {"rgba32f": (U, 2.0 ** -126), "rgba16f": (U16, 2.0 ** -14)}[fmt]
    binade = 2.0 ** np.floor(np.log2(np.maximum(np.abs(magnitude), smallest)))
    return (2 if whole_ulp else 1) * unit * binade


def decode_error(value, lo, hi):
    """How far a GPU's decode of RGBA8 values can be from numpy's (state_decode computes
    lo + u span in float32, two roundings; a driver may fuse them into one), per value of
    ``value`` (decoded values of the range [lo, hi], per component): none where u span is exact
    in float32 (the middle code, say: zero in a symmetric range), else the product's rounding
    plus the two sums' roundings."""
    lo32 = np.asarray(lo, np.float32)
    span32 = (np.asarray(hi, float) - np.asarray(lo, float)).astype(np.float32)
    value = np.asarray(value, float)
    code = np.round((value - lo32) / span32 * CODES)
    u = code.astype(np.float32) * np.float32(1 / CODES)  # unpack16's float32 product
    product = u.astype(float) * span32  # exact in float64
    rounded = product.astype(np.float32).astype(float)
    return np.where(rounded == product, 0.0,
                    np.abs(rounded - product) + 2 * float_rounding(value))


def _hash_error():
    """How far lib/hash.glsl's hash44 on a GPU can be from its numpy twin (twins/life.py), each
    output taken round the circle [0, 1) (what fract leaves). The first step, fract(p c), is one
    correctly rounded product both ways; then a driver may fuse and order the dot product
    p . (p.wzxy + 33.33) otherwise: four products up to 34.33 and three sums up to 137.3, each
    within its rounding of the exact, so the two sums differ by up to twice those; p + dot rounds
    once more each way (p <= 138.3); (p.xxyz + p.yzzw) * p.zywx then carries the difference
    through the sum (up to 276.6) and the product (up to 3.8e4), whose roundings add too."""
    products, sums, p, s = 34.33, 137.3, 138.3, 276.6
    dot = 2 * (4 * float_rounding(products) + 3 * float_rounding(sums))
    e_p = dot + 2 * float_rounding(p)
    e_s = 2 * e_p + 2 * float_rounding(s)
    return float(p * e_s + s * e_p + 2 * float_rounding(p * s))


# hash44's largest GPU-against-twin difference round the circle (0.050; llvmpipe's: 3.9e-3)
HASH_ERROR = _hash_error()


def read_jitter(texels, step, salt, span, part=0):
    """What a read under rounding "jitter" adds to each stored value, and how well that is known:
    (offsets (n, 2) in world units, their errors (n, 2)) for particles at integer ``texels``
    (n, 2) at step ``step``, a reader of ``salt`` (bindings.READ_SALTS), a range of ``span`` per
    axis, and
    a quantity's ``part`` (0: its first texel, the hash's first two outputs; 1: the last two).
    The offset spreads the hash's u (twins/life.py's step_hash) uniformly over the code less its
    dead zone each side: (u - 1/2)(1 - 2/64) codes. The GPU's u is within HASH_ERROR of the
    twin's round the circle; where the twin's is within HASH_ERROR of 0 or 1 the GPU's may have
    wrapped to the other end, so that particle's offset is known only to the whole spread."""
    from es2particles.twins.life import step_hash

    u = step_hash(texels, step, salt)[:, 2 * part:2 * part + 2].astype(np.float64)
    spread = (1 - 2 / 64) / CODES * np.asarray(span, float)  # world units a unit of u moves
    wraps = np.minimum(u, 1 - u) < HASH_ERROR
    error = np.where(wraps, spread, HASH_ERROR * spread) + 2 * U * np.abs(span)
    return (u - 0.5) * spread, error


def sqrt_error(value, error):
    """The largest |sqrt(max(x, 0)) - sqrt(max(value, 0))| for |x - value| <= error: at most
    min(error / m, sqrt(error)) with m = sqrt(value) > 0 (the slope is unbounded near 0); a value
    clamped to 0 stays within sqrt(max(value + error, 0))."""
    root = np.sqrt(np.maximum(value, 0))
    return np.where(root > 0, np.minimum(error / np.where(root > 0, root, 1), np.sqrt(error)),
                    np.sqrt(np.maximum(value + error, 0)))


# GLSL's precision (GLSL 4.x and ES 3.00; ES 1.00 states none): exp 3 + 2|x| ulp, division
# 2.5 ulp, inversesqrt 2 ulp, sqrt that of 1 / inversesqrt (4.5 ulp); normalize() is
# v * inversesqrt(v.v): 2 ulp and a product's rounding, 5 U of each component.
EXP_ULPS, DIVISION_ULPS, SQRT_ULPS, NORMALIZE = 3.0, 2.5, 4.5, 5 * U


def push_out_work(turn, turn_unsure, vn, e_vn, d, e_depth, an, e_an, moved, e_moved, speed,
                  e_speed, v2, e_v2):
    """The work the push-out takes from v^2 in the 2D and 3D responses, with its bound: 2 d a.n,
    but where the response turned the particle (``turn``: vn < 0; ``turn_unsure``: float32 may
    take the other side), over the depth its own move explains, ours = max(d, min(moved, 0)),
    at most vn^2 less what the response took (``speed``^2 in, ``v2`` out): min(2 ours a.n,
    max(vn^2 - (speed^2 - v2), 0)) + 2 (d - ours) a.n. Each input within its ``e_``."""
    full = 2 * d * an
    e_full = 2 * (e_depth * np.abs(an) + np.abs(d) * e_an + e_depth * e_an) + 2 * U * np.abs(full)
    ours = np.maximum(d, np.minimum(moved, 0))
    e_ours = np.maximum(e_depth, e_moved)  # max and min move by at most their inputs' errors
    mine = 2 * ours * an
    e_mine = 2 * (e_ours * np.abs(an) + np.abs(ours) * e_an + e_ours * e_an) + 2 * U * np.abs(mine)
    lost = speed * speed - v2
    e_lost = 2 * speed * e_speed + e_speed ** 2 + e_v2 + 2 * U * (speed * speed + v2)
    left = vn * vn - lost
    e_left = 2 * np.abs(vn) * e_vn + e_vn ** 2 + e_lost + U * (vn * vn + np.abs(left))
    normal = np.maximum(left, 0)
    deeper = 2 * (d - ours) * an
    e_gap = e_depth + e_ours
    e_deeper = 2 * (e_gap * np.abs(an) + np.abs(d - ours) * e_an + e_gap * e_an) \
        + 3 * U * np.abs(deeper)
    capped = np.minimum(mine, normal) + deeper
    e_capped = np.maximum(e_mine, e_left) + e_deeper + U * np.abs(capped)
    work = np.where(turn, capped, full)
    e_work = np.where(turn, e_capped, e_full)
    e_work = np.where(turn_unsure, np.maximum(e_capped, e_full) + np.abs(capped - full), e_work)
    return work, e_work


def push_out_rescale(turned, v2, e_v2, work, e_work, direction_error):
    """The push-out's energy rescale of the 2D and 3D collision steps with its bound: the
    float64 v * sqrt(max(v2 - work, 0) / v2) is sqrt(max(v2 - work, 0)) along v (``work``:
    :func:`push_out_work`). ``turned`` (n, k) is v, ``v2`` its squared length within ``e_v2``;
    ``direction_error(direction)``: the error of v's direction (its error across it over its
    length), per component. Returns (rescaled, bound); at rest in float64 the GPU's v may be off
    0, and rescaled to any direction."""
    number = v2 - work
    e_number = e_v2 + e_work + 3 * U * (v2 + np.abs(work))
    scale = np.sqrt(np.maximum(number, 0) / np.where(v2 > 0, v2, 1))
    rescaled = np.where((v2 > 0)[:, None], turned * scale[:, None], turned)
    magnitude = np.sqrt(np.maximum(number, 0))
    direction = turned / np.where(v2 > 0, np.sqrt(v2), 1)[:, None]
    e_rescaled = (sqrt_error(number, e_number)[:, None] * np.abs(direction)
                  + magnitude[:, None] * direction_error(direction)
                  + 2 * (SQRT_ULPS + DIVISION_ULPS + 1) * U * np.abs(rescaled))
    e_rescaled = np.where((v2 > 0)[:, None], e_rescaled,
                          np.sqrt(np.maximum(number + e_number, 0))[:, None])
    return rescaled, e_rescaled
