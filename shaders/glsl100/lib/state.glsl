// Reading and writing one two-component particle quantity, whatever the storage format.
// A quantity's range uniform is vec4(lo.x, lo.y, span.x, span.y), span = hi - lo; values are
// clamped into [lo, hi] on write (never wrapped). numpy twins: es2particles/packing.py.
//
// The format is chosen by a define that the simulation injects:
//   STATE_RGBA8  (default) 16-bit fixed point, two values packed in one RGBA8 texel;
//   STATE_FLOAT  RGBA16F/RGBA32F, the world value stored as it is in .xy.
// STATE_DITHER makes the packed format round stochastically, with noise from a hash of the texel
// written (gl_FragCoord) and the step number: deterministic, different per particle and step.
#include "lib/pack.glsl"
#include "lib/hash.glsl"

uniform float u_step;  // the step being computed (set by the simulation)

#if !defined(STATE_FLOAT) && !defined(STATE_RGBA8)
#define STATE_RGBA8
#endif

vec2 state_unit(vec2 value, vec4 range)
{
    return clamp_unit((value - range.xy) / range.zw);
}

vec2 state_decode(vec4 texel, vec4 range)
{
#ifdef STATE_RGBA8
    return range.xy + unpack2x16(texel) * range.zw;
#else
    return texel.xy;
#endif
}

#ifdef STATE_DITHER
// Fragment shaders only (gl_FragCoord): the passes that write state.
vec2 state_noise()
{
    vec2 texel = floor(gl_FragCoord.xy);
    return hash44(vec4(texel, mod(u_step, 4096.0), floor(u_step / 4096.0) + 17.0)).xy;
}
#endif

vec4 state_encode(vec2 value, vec4 range)
{
#if defined(STATE_RGBA8) && defined(STATE_DITHER)
    vec2 x = state_unit(value, range);
    vec2 u = state_noise();
    return vec4(pack16_dither(x.x, u.x), pack16_dither(x.y, u.y));
#elif defined(STATE_RGBA8)
    return pack2x16(state_unit(value, range));
#else
    return vec4(range.xy + state_unit(value, range) * range.zw, 0.0, 1.0);
#endif
}

vec2 state_read(sampler2D quantity, vec2 uv, vec4 range)
{
    return state_decode(texture2D(quantity, uv), range);
}
