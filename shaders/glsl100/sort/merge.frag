#version 100
// One pass of Batcher's odd-even merge sort over the slots of a sort order (es2particles/render/sort.py):
// the pass of merge size u_p and comparator distance u_k. Each fragment is one slot x; a
// comparator joins slots a and a + k where, with c = k mod p,
//     a >= c,  (a - c) mod 2k < k,  and a and a + k lie in one block of 2p slots.
// The lower slot of a comparator keeps the smaller of the two, the upper one the larger, both from
// the same comparison, so a pass permutes the slots and leaves a sorted order as it is (which is
// what spreading the passes over frames needs). Slots in no comparator copy themselves.
// All numbers are integers below 2^24 (p, k and the slot count are powers of two).
precision highp float;
precision highp sampler2D;
#include "lib/order.glsl"

uniform sampler2D u_order;    // the order before this pass
uniform vec2 u_order_size;    // its width and height in slots (powers of two)
uniform float u_p;            // this pass's merge size: 1, 2, 4, ..., slots / 2
uniform float u_k;            // this pass's comparator distance: p, p / 2, ..., 1
varying vec2 v_uv;

vec4 slot_texel(float slot)
{
    vec2 cell = vec2(order_mod(slot, u_order_size.x), floor(slot / u_order_size.x));
    return texture2D(u_order, (cell + 0.5) / u_order_size);
}

void main()
{
    vec2 cell = floor(v_uv * u_order_size);
    float x = cell.y * u_order_size.x + cell.x;
    float c = (u_k == u_p) ? 0.0 : u_k;  // k mod p: k is p or a smaller power of two
    float r = x - c;
    float phase = order_mod(max(r, 0.0), 2.0 * u_k);
    float block = order_mod(x, 2.0 * u_p);  // x's place in its block of 2p slots
    vec4 own = texture2D(u_order, v_uv);
    // Written once from a highp variable: ES 1.00's gl_FragColor is mediump, and a driver may
    // round what is assigned straight to it (see sort/key.frag).
    highp vec4 result = own;
    if (r >= 0.0 && phase < u_k && block + u_k < 2.0 * u_p) {
        // the lower slot of a comparator: keep the smaller
        vec4 other = slot_texel(x + u_k);
        result = order_less(other, own) ? other : own;
    } else if (r >= u_k && phase >= u_k && block >= u_k) {
        // the upper slot: keep the larger (the same comparison, seen from the other side)
        vec4 other = slot_texel(x - u_k);
        result = order_less(own, other) ? other : own;
    }
    gl_FragColor = order_copy(result);
}
