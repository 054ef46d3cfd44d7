// Reading and writing particle quantities, whatever the storage format. A pass never declares
// its quantities itself: the graph writes, for each quantity the pass reads or writes, its
// samplers (u_<q>, and u_<q>_1 for a second RGBA8 part), its range uniforms u_<q>_lo and
// u_<q>_span (vec4: one number per component) and the accessors read_<q>(uv) and
// write_<q>(value), built on the functions below (es2particles/bindings.py writes them).
// numpy twins: es2particles/packing.py.
//
// Each quantity's format decides which functions its accessors use: RGBA8 is 16-bit fixed point
// over [lo, hi], two values packed in one texel (state_decode, state_encode), or 32-bit, one
// value a texel (rgba8_32: state_decode32, state_encode32); RGBA16F/RGBA32F
// hold the value itself, clamped into [lo, hi], up to four per texel (state_clamp).
// STATE_DITHER makes the packed format round stochastically, with noise from a hash of the texel
// written (gl_FragCoord) and the step number: deterministic, different per particle and step.
// STATE_JITTER (rounding "jitter") writes the nearest code and offsets every read of packed state
// within its code, by a hash of the texel read and the step (state_jitter): a stored value reads
// as a sample of the interval of values its code stands for, not as the interval's centre.
#include "lib/pack.glsl"
#include "lib/hash.glsl"

uniform float u_step;  // the step being computed (set by the simulation)

// Four numbers in [0, 1) for integer texel ``texel`` at this step: the randomness of every
// per-particle, per-step choice (emission, dithered writes, jittered reads), each kind told
// apart by its ``salt``. The step goes in as two inputs below 4096 (hash44's precision).
// numpy twin: twins/life.py, step_hash().
vec4 step_hash(vec2 texel, float salt)
{
    return hash44(vec4(texel, mod(u_step, 4096.0), floor(u_step / 4096.0) + salt));
}

vec2 state_unit(vec2 value, vec2 lo, vec2 span)
{
    return clamp_unit((value - lo) / span);
}

#ifdef STATE_DITHER
// Fragment shaders only (gl_FragCoord): the passes that write state. .xy round the first part
// of a quantity, .zw the second.
vec4 state_noise()
{
    return step_hash(floor(gl_FragCoord.xy), 17.0);
}
#else
vec4 state_noise()
{
    return vec4(0.5);  // unused: nearest rounding
}
#endif

// One RGBA8 texel: two values over their ranges.
vec2 state_decode(vec4 texel, vec2 lo, vec2 span)
{
    return lo + unpack2x16(texel) * span;
}

// The offsets (in units of the range: a code is 1/65024) of the values at texel ``texel``
// (integer coordinates, or a texel's centre), .xy for a quantity's first part and .zw for its
// second. Uniform within the code, less DITHER_DEAD_ZONE each side: a value at rest, read and
// written back to the nearest code, keeps its code, as float32 places the read to within the
// dead zone. ``salt`` tells readers apart: a pass's read and a draw's of the same state get
// independent offsets. Zero without STATE_JITTER. The tests compute it from step_hash's twin:
// tests/bounds.py, read_jitter().
vec4 state_jitter(vec2 texel, float salt)
{
#ifdef STATE_JITTER
    vec4 u = step_hash(floor(texel), salt);
    return (u - 0.5) * ((1.0 - 2.0 * DITHER_DEAD_ZONE) / 65024.0);
#else
    return vec4(0.0);
#endif
}

// One RGBA8 texel as a read sees it: decoded, plus its jitter (state_jitter) under STATE_JITTER.
vec2 state_read(vec4 texel, vec2 lo, vec2 span, vec2 jitter)
{
#ifdef STATE_JITTER
    return lo + (unpack2x16(texel) + jitter) * span;
#else
    return state_decode(texel, lo, span);
#endif
}

vec4 state_encode(vec2 value, vec2 lo, vec2 span, vec2 noise)
{
    vec2 x = state_unit(value, lo, span);
#ifdef STATE_DITHER
    return vec4(pack16_dither(x.x, noise.x), pack16_dither(x.y, noise.y));
#else
    return pack2x16(x);
#endif
}

// 32-bit packed state ("rgba8_32"): one value a texel, always to the nearest code (its step,
// 1/65024^2 of the range, is below float32's: jittered reads and dithered writes would be lost in
// the arithmetic around them).
float state_decode32(vec4 texel, float lo, float span)
{
    return lo + unpack32(texel) * span;
}

vec4 state_encode32(float value, float lo, float span)
{
    return pack32(clamp_unit((value - lo) / span));
}

// Float formats: the value itself, clamped into [lo, lo + span]. Not clamp(): clamp(NaN, ...) is
// undefined in GLSL; a failed comparison is not, so NaN gives lo.
vec4 state_clamp(vec4 value, vec4 lo, vec4 span)
{
    vec4 hi = lo + span;
    return vec4(value.x >= lo.x ? min(value.x, hi.x) : lo.x,
                value.y >= lo.y ? min(value.y, hi.y) : lo.y,
                value.z >= lo.z ? min(value.z, hi.z) : lo.z,
                value.w >= lo.w ? min(value.w, hi.w) : lo.w);
}
