// 16-bit fixed point in two 8-bit channels (the ES 2.0 way to keep particle state in RGBA8).
// A value x in [0,1] is stored as its nearest code k = round(65024x), k = 0..65024: high byte
// floor(k/255), low byte k mod 255 (so the low byte never rounds up to 255, and high <= 254). It
// reads back as (255 high + low) / 65024. 65024 steps, not the article's 255 * 255 = 65025: an
// even count puts a code at the middle of every range, so zero in a symmetric range (a velocity
// at rest) is stored exactly, where 65025 stored it as half a code.
// numpy twins: es2particles/twins/pack.py.
//
// Differences from the article's formula, on purpose:
// - The high byte is floor(k/255)/255, never fract(x) - fract(255x)/255: that difference can land
//   just below H/255, and a driver that truncates on store then loses a whole high step (1/255).
//   H/255 is stored as H under round-to-nearest, truncation and floor(c*256) alike; so is the low
//   byte, because the shader rounds it (below) instead of the store.
// - x is clamped to [0,1] first, so 1.0 stays 1.0 (bytes 254, 254) instead of fract() wrapping to 0.
// - NaN maps to 0 (the comparison below is false for NaN), +Inf to 1, -Inf to 0.
// - Unpacking snaps each channel to the 1/255 grid, so the decode is exact even when the sampler
//   returns a channel with a little error.

// Dithered rounding rounds to the nearest code within this fraction of one (1/64 code).
#define DITHER_DEAD_ZONE 0.015625

float clamp_unit(float x)
{
    // Not clamp(): clamp(NaN, 0, 1) is undefined in GLSL; a failed comparison is not.
    return (x >= 0.0) ? min(x, 1.0) : 0.0;
}

vec2 clamp_unit(vec2 x)
{
    return vec2(clamp_unit(x.x), clamp_unit(x.y));
}

vec2 pack16(float x)
{
    // Round to the nearest code here rather than leave the low byte's rounding to the store, which
    // GL ES only prefers to be round-to-nearest: both channels are then exact multiples of 1/255,
    // stored exactly under rounding, truncation and floor(c*256) alike, and an unpacked value
    // re-packs to the same bytes (floor(255x) of a decoded H/255 can land on H-1 in float32).
    float code = floor(clamp_unit(x) * 65024.0 + 0.5);
    float high = floor((code + 0.5) * (1.0 / 255.0));  // +0.5 keeps clear of H-1 at multiples
    return vec2(high, code - high * 255.0) * (1.0 / 255.0);
}

vec2 pack16_dither(float x, float u)
{
    // Stochastic rounding: with u uniform in [0,1), the code is k + 1 with probability f, where
    // s = 65024x = k + f, so its expected value is exactly s: a change smaller than a code still
    // moves the value on average instead of being lost. k and f are taken apart (both exact in
    // float32) rather than floor(s + u): in float32 k + u rounds up to k + 1 when u is within half
    // an ulp of 1, which biased every write upward (+2.1 codes after 2000 writes at rest).
    // Within DITHER_DEAD_ZONE of a code, s is that code: world-unit float32 arithmetic places s
    // only to a few ulps (ulp(65024) = 2^-7), and dithering that error is a bias of its own
    // (+0.10 codes after 2000 writes at rest without the zone). A value at rest stays exactly.
    float s = clamp_unit(x) * 65024.0;
    float k = floor(s);
    float f = s - k;
    f = (f < DITHER_DEAD_ZONE) ? 0.0 : ((f > 1.0 - DITHER_DEAD_ZONE) ? 1.0 : f);
    float code = min(k + ((u < f) ? 1.0 : 0.0), 65024.0);
    float high = floor((code + 0.5) * (1.0 / 255.0));
    return vec2(high, code - high * 255.0) * (1.0 / 255.0);
}

float unpack16(vec2 channels)
{
    vec2 bytes = floor(channels * 255.0 + 0.5);
    return (bytes.x * 255.0 + bytes.y) * (1.0 / 65024.0);
}

vec4 pack2x16(vec2 x)
{
    return vec4(pack16(x.x), pack16(x.y));
}

vec2 unpack2x16(vec4 texel)
{
    return vec2(unpack16(texel.xy), unpack16(texel.zw));
}

// 32-bit fixed point in the four channels of one texel (storage "rgba8_32"): two codes, the
// first k1 = floor(65024x), the second the nearest code of the rest 65024x - k1 (exact in
// float32). It reads back as (k1 + k2/65024)/65024: steps of 1/65024^2, finer than the float32
// the value is computed in, so state keeps a shader's float32 precision over its range.
vec4 pack32(float x)
{
    float scaled = clamp_unit(x) * 65024.0;
    float k1 = floor(scaled);
    return vec4(pack16(k1 * (1.0 / 65024.0)), pack16(scaled - k1));
}

float unpack32(vec4 texel)
{
    vec4 bytes = floor(texel * 255.0 + 0.5);
    return (bytes.x * 255.0 + bytes.y + (bytes.z * 255.0 + bytes.w) * (1.0 / 65024.0))
           * (1.0 / 65024.0);
}
