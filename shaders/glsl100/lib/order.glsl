// The slots of a sort order (es2particles/render/sort.py): one texel per slot, each holding a sort key
// and a particle index. Pure arithmetic on texels, so it compiles in vertex and fragment shaders
// alike: the sorting passes encode and compare slots with it, and a renderer's vertex shader
// decodes its i-th slot into the particle to draw (order_particle_uv). Include it after a
// `precision highp float` statement: every value below is an integer below 2^24, exact in highp
// (float32), and meaningless in mediump.
//
// Two formats (the numpy twin and the full story: es2particles/render/sort.py):
// - RGBA8 (the ES 2.0 baseline): one 32-bit word = key * 2^B + index over the four bytes, R and
//   G the high 16 bits, B and A the low 16. B index bits, 32 - B key bits. ORDER_HIGH_MOD is
//   2^max(B - 16, 0) (the index bits held in the high half), ORDER_LOW_MOD 2^min(B, 16) (those in
//   the low half) and ORDER_KEY_MAX the largest key, 2^(32 - B) - 1. Words compare as
//   (high16, low16) pairs: by key, then by index.
// - ORDER_FLOAT (RGBA32F): R = key, G = index, compared as the pair (R, G).
// Slots past the particle count hold padding: the largest key and an index >= the count, so they
// sort after every particle.

#ifndef ORDER_HIGH_MOD
#define ORDER_HIGH_MOD 1.0
#endif
#ifndef ORDER_LOW_MOD
#define ORDER_LOW_MOD 65536.0
#endif
#ifndef ORDER_KEY_MAX
#define ORDER_KEY_MAX 65535.0
#endif
// The largest float key (padding); real keys are clamped into +-this.
#define ORDER_FLOAT_MAX 1.0e38

// a mod m for a >= 0 and m a power of two: a / m is exact, so is the rest.
float order_mod(float a, float m)
{
    return a - floor(a / m) * m;
}

#ifndef ORDER_FLOAT
// The (high16, low16) halves of the word of an RGBA8 texel. The sampler returns byte / 255 with
// perhaps a little error: rounding recovers the byte.
vec2 order_words(vec4 texel)
{
    vec4 bytes = floor(texel * 255.0 + 0.5);
    return vec2(bytes.x * 256.0 + bytes.y, bytes.z * 256.0 + bytes.w);
}
#endif

// The particle index a slot's texel holds.
float order_index(vec4 texel)
{
#ifdef ORDER_FLOAT
    return texel.y;
#else
    vec2 word = order_words(texel);
    return order_mod(word.x, ORDER_HIGH_MOD) * ORDER_LOW_MOD + order_mod(word.y, ORDER_LOW_MOD);
#endif
}

// The key a slot's texel holds (an RGBA8 key is an integer in [0, ORDER_KEY_MAX]).
float order_key(vec4 texel)
{
#ifdef ORDER_FLOAT
    return texel.x;
#else
    vec2 word = order_words(texel);
    return floor(word.x / ORDER_HIGH_MOD) * (65536.0 / ORDER_LOW_MOD) + floor(word.y / ORDER_LOW_MOD);
#endif
}

// The texel of a slot holding (key, index); an RGBA8 key is an integer in [0, ORDER_KEY_MAX].
vec4 order_encode(float key, float index)
{
#ifdef ORDER_FLOAT
    return vec4(key, index, 0.0, 0.0);
#else
    // The key's bits below the high half: the key's low bits when the index takes fewer than 16
    // bits, none otherwise. Every product stays below 2^16.
    float below = 65536.0 / ORDER_LOW_MOD;
    float top = floor(key / below);
    float high = top * ORDER_HIGH_MOD + floor(index / ORDER_LOW_MOD);
    float low = (key - top * below) * ORDER_LOW_MOD + order_mod(index, ORDER_LOW_MOD);
    vec4 bytes = vec4(floor(high / 256.0), order_mod(high, 256.0),
                      floor(low / 256.0), order_mod(low, 256.0));
    // byte / 255 is stored as that byte under rounding, truncating and floor(256 c) stores alike
    // (see lib/pack.glsl).
    return bytes * (1.0 / 255.0);
#endif
}

// A slot of padding for index `index` (>= the particle count): after every particle.
vec4 order_padding(float index)
{
#ifdef ORDER_FLOAT
    return order_encode(ORDER_FLOAT_MAX, index);
#else
    return order_encode(ORDER_KEY_MAX, index);
#endif
}

// A texel as it was sampled, ready to be written again unchanged.
vec4 order_copy(vec4 texel)
{
#ifdef ORDER_FLOAT
    return texel;
#else
    return floor(texel * 255.0 + 0.5) * (1.0 / 255.0);
#endif
}

// True if slot texel a sorts before b: by key, then by index (so ties keep the particles' order).
bool order_less(vec4 a, vec4 b)
{
#ifdef ORDER_FLOAT
    vec2 x = a.xy;
    vec2 y = b.xy;
#else
    vec2 x = order_words(a);
    vec2 y = order_words(b);
#endif
    return x.x < y.x || (x.x == y.x && x.y < y.y);
}

// The centre of particle `index`'s state texel: particles are numbered row by row over a state
// texture of `state_size` texels (es2particles/state.py: Layout). The width is no power of two, so
// the row from one division may be one off in float32: it is corrected with exact products.
vec2 order_state_uv(float index, vec2 state_size)
{
    float row = floor(index / state_size.x);
    float column = index - row * state_size.x;
    if (column < 0.0) {
        row -= 1.0;
        column += state_size.x;
    } else if (column >= state_size.x) {
        row += 1.0;
        column -= state_size.x;
    }
    return (vec2(column, row) + 0.5) / state_size;
}

// The state texel of the particle held in the slot at `slot_uv` of `order` (a renderer's i-th
// vertex carries the i-th slot's uv: SortingNetwork.slot_uv()).
vec2 order_particle_uv(sampler2D order, vec2 slot_uv, vec2 state_size)
{
    return order_state_uv(order_index(texture2D(order, slot_uv)), state_size);
}
