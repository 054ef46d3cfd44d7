"""numpy twins of the GLSL codecs in ``shaders/glsl100/lib/pack.glsl`` and ``lib/state.glsl``.

Each function here has the name and the float32 arithmetic of its GLSL peer, in the same order, so
that the two can be read side by side and the bytes a GPU writes can be predicted exactly (under the
round-to-nearest store that GL prefers). They are also what uploads and downloads state.

The fixed-point grid: a value x in [0, 1] is stored as its nearest code k = round(65024 x),
k = 0..65024, in bytes H = k div 255, L = k mod 255 (so L never rounds up to 255, and H <= 254);
it reads back as (255 H + L) / 65024. 65024 steps, not 255 * 255 = 65025: an even count puts a
code at the middle of every range, so zero in a symmetric range (a velocity at rest) is stored
exactly. Results of edge values: x >= 1 and +Inf give 1.0 exactly; x <= 0, -Inf and NaN give 0.0.

32 bits a value (storage ``rgba8_32``, one value a texel): two such codes, the first k1 =
floor(65024 x), the second the nearest code of the rest, 65024 x - k1 (exact in float32). It reads
back as (k1 + k2 / 65024) / 65024: steps of 1 / 65024^2 (2.4e-10 of the range), finer than the
float32 a shader holds the value in, so a value computes in float32 and is stored to its float32
precision (within an ulp or two of the range's arithmetic, not 1/65024 of the range).
"""

import numpy as np

F32 = np.float32
CODES_PER_UNIT = 65024  # the grid step of a packed value is 1 / 65024 (an even count)
STORE_RULES = ("round", "truncate", "floor256")
# Dithered rounding is nearest within this fraction of a code (see pack16_dither in pack.glsl).
DITHER_DEAD_ZONE = F32(1 / 64)


# --- twins of lib/pack.glsl -------------------------------------------------------------------

def clamp_unit(x):
    """Clamp to [0, 1]; NaN gives 0 (a failed ``x >= 0`` comparison, as in GLSL)."""
    x = np.asarray(x, dtype=F32)
    with np.errstate(invalid="ignore"):
        return np.where(x >= 0, np.minimum(x, F32(1)), F32(0)).astype(F32)


def pack16_channels(x):
    """The two channel values (high, low) that ``pack16`` writes, as float32, before the store."""
    code = np.floor(clamp_unit(x) * F32(CODES_PER_UNIT) + F32(0.5))
    high = np.floor((code + F32(0.5)) * F32(1 / 255))
    return high * F32(1 / 255), (code - high * F32(255)) * F32(1 / 255)


def pack16(x, store="round"):
    """Bytes (..., 2) = (high, low) that a GPU stores for ``x`` under the given store rule."""
    if store == "round":
        # Both channels are exact multiples of 1/255, which a rounding store keeps exactly: the
        # bytes are the code's digits in base 255. Integer arithmetic here is ~5x faster than
        # going through the float channels, and gives the same bytes (tests check both ways).
        code = np.floor(clamp_unit(x) * F32(CODES_PER_UNIT) + F32(0.5)).astype(np.int32)
        high = code // 255
        return np.stack([high, code - 255 * high], axis=-1).astype(np.uint8)
    high, low = pack16_channels(x)
    return np.stack([store_unorm8(high, store), store_unorm8(low, store)], axis=-1)


def pack16_dither(x, u):
    """Bytes (..., 2) of ``pack16_dither``: stochastic rounding with noise ``u`` in [0, 1):
    k + 1 with probability f, where 65024 x = k + f."""
    s = clamp_unit(x) * F32(CODES_PER_UNIT)
    k = np.floor(s)
    f = s - k
    f = np.where(f < DITHER_DEAD_ZONE, F32(0), np.where(f > 1 - DITHER_DEAD_ZONE, F32(1), f))
    code = np.minimum(k + (np.asarray(u, F32) < f).astype(F32), F32(CODES_PER_UNIT))
    high = np.floor((code + F32(0.5)) * F32(1 / 255))
    return np.stack([store_unorm8(high * F32(1 / 255)),
                     store_unorm8((code - high * F32(255)) * F32(1 / 255))], axis=-1)


def unpack16(bytes2):
    """Decode bytes (..., 2) = (high, low) to float32 in [0, 1], as ``unpack16`` in GLSL does.

    The GLSL side snaps each sampled channel to the 1/255 grid first, which recovers the bytes.
    """
    b = np.asarray(bytes2).astype(F32)
    return (b[..., 0] * F32(255) + b[..., 1]) * F32(1.0 / CODES_PER_UNIT)


def pack2x16(x, store="round"):
    """Bytes (..., 4) of one RGBA8 texel holding two values, x of shape (..., 2)."""
    x = np.asarray(x, dtype=F32)
    # pack16 of (..., 2) values gives (..., 2, 2) = ((high, low) of x, (high, low) of y): that is
    # the texel's byte order already (and one pass over the array instead of two strided ones).
    return pack16(x, store).reshape(x.shape[:-1] + (4,))


def unpack2x16(texel):
    """Two float32 values (..., 2) from RGBA8 texel bytes (..., 4)."""
    texel = np.asarray(texel)
    return np.stack([unpack16(texel[..., 0:2]), unpack16(texel[..., 2:4])], axis=-1)


# --- twins of lib/state.glsl ------------------------------------------------------------------

def pack32(x):
    """Bytes (..., 4) = (high, low of the first code, high, low of the second) that a GPU stores
    for ``x`` in [0, 1] (``pack32`` in GLSL): 32-bit fixed point, nearest rounding."""
    s = clamp_unit(x) * F32(CODES_PER_UNIT)
    k1 = np.floor(s)
    return np.concatenate([pack16(k1 * F32(1 / CODES_PER_UNIT)), pack16(s - k1)], axis=-1)


def unpack32(texel):
    """Decode bytes (..., 4) of ``pack32`` to float32 in [0, 1], as ``unpack32`` in GLSL."""
    b = np.asarray(texel).astype(F32)
    k1 = b[..., 0] * F32(255) + b[..., 1]
    k2 = b[..., 2] * F32(255) + b[..., 3]
    return ((k1 + k2 * F32(1 / CODES_PER_UNIT)) * F32(1 / CODES_PER_UNIT)).astype(F32)


# Storage formats whose texels are RGBA8 bytes of fixed-point codes: values a texel.
PACKED = {"rgba8": 2, "rgba8_32": 1}


def parts(components, fmt):
    """Textures one quantity of ``components`` values spans: RGBA8 holds two 16-bit values per
    texel (``rgba8``) or one 32-bit value (``rgba8_32``), a float format up to four."""
    return -(-components // PACKED[fmt]) if fmt in PACKED else 1


def state_unit(value, lo, span):
    """World values (..., c) to [0, 1] (clamped, NaN to 0) for per-component ``lo`` and ``span``."""
    value = np.asarray(value, dtype=F32)
    with np.errstate(invalid="ignore", over="ignore"):
        return clamp_unit((value - np.asarray(lo, F32)) / np.asarray(span, F32))


def state_clamp(value, lo, span):
    """Float formats store the value itself, clamped into [lo, lo + span]; NaN gives lo, as
    ``state_clamp`` in GLSL (hi is summed in float32 there too)."""
    value, lo = np.asarray(value, dtype=F32), np.asarray(lo, F32)
    hi = (lo + np.asarray(span, F32)).astype(F32)
    with np.errstate(invalid="ignore"):
        return np.where(value >= lo, np.minimum(value, hi), lo).astype(F32)


def state_encode(value, lo, span, fmt="rgba8"):
    """Texel contents (..., parts, 4) for world values (..., c) under nearest rounding: RGBA8
    bytes, two values per texel (an odd last value pads with code 0) in ``rgba8``, one in
    ``rgba8_32``, or float RGBA holding the
    clamped values themselves (padded with 0)."""
    value = np.asarray(value, dtype=F32)
    c = value.shape[-1]
    if fmt == "rgba8":
        unit = state_unit(value, lo, span)
        if c % 2:
            unit = np.concatenate([unit, np.zeros(unit.shape[:-1] + (1,), F32)], axis=-1)
        return pack16(unit).reshape(value.shape[:-1] + (parts(c, fmt), 4))
    if fmt == "rgba8_32":
        return pack32(state_unit(value, lo, span))
    out = np.zeros(value.shape[:-1] + (1, 4), dtype=F32)
    out[..., 0, :c] = state_clamp(value, lo, span)
    return out


def state_decode(texels, lo, span, fmt="rgba8"):
    """World values (..., c) as float32 from texel contents (..., parts, 4), c = len(lo)."""
    c = len(lo)
    texels = np.asarray(texels)
    if fmt == "rgba8":
        unit = unpack16(texels.reshape(texels.shape[:-2] + (-1, 2)))[..., :c]
        return (np.asarray(lo, F32) + unit * np.asarray(span, F32)).astype(F32)
    if fmt == "rgba8_32":
        unit = unpack32(texels)[..., :c]
        return (np.asarray(lo, F32) + unit * np.asarray(span, F32)).astype(F32)
    return np.asarray(texels, dtype=F32)[..., 0, :c]


# --- what the GL does between the shader and the texture --------------------------------------

def store_unorm8(c, rule="round"):
    """Model of a driver converting a float channel in [0, 1] to an 8-bit byte.

    ``round`` is what the GL ES specs prefer; ``truncate`` (floor(255 c)) and ``floor256``
    (floor(256 c), clamped) are what some hardware does. The product is taken exactly (float64).
    """
    s = np.asarray(c, dtype=np.float64)
    if rule == "round":
        b = np.floor(s * 255 + 0.5)
    elif rule == "truncate":
        b = np.floor(s * 255)
    elif rule == "floor256":
        b = np.floor(s * 256)
    else:
        raise ValueError(f"store rule must be one of {STORE_RULES}, got {rule!r}")
    return np.clip(b, 0, 255).astype(np.uint8)


# --- the article's original formula, kept to show in tests what it gets wrong -----------------

def article_pack16(x, store="round"):
    """Bytes (high, low) of the article's ``pack``: high = fract(x) - fract(255 x)/255."""
    x = np.asarray(x, dtype=F32)
    low = x * F32(255) - np.floor(x * F32(255))
    high = (x - np.floor(x)) - low * F32(1 / 255)
    return np.stack([store_unorm8(high, store), store_unorm8(low, store)], axis=-1)


def article_unpack16(bytes2):
    """The article's ``unpack``: high + low/255 from the stored channels (no snapping)."""
    b = np.asarray(bytes2).astype(np.float64) / 255
    return b[..., 0] + b[..., 1] / 255
