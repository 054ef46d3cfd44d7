#version 100
// The key pass of depth sorting (es2particles/render/sort.py: DepthSorter): each slot keeps the particle
// it held in the previous order and gets that particle's key for this frame, so the sorting passes
// start from last frame's order, nearly sorted (re-keying the permutation, as Latta 2004 does).
// The key puts the far particles first: the view depth d = dot(p - eye, forward) gives
// - RGBA8: (far - d) / (far - near) quantised onto the ORDER_KEY_MAX + 1 key levels, where
//   [near, far] is the depth range of the position quantity's box;
// - ORDER_FLOAT: -d.
// Slots holding padding (an index >= u_count) stay padding: decided by the index a slot holds,
// not by its place, so the pass permutes nothing whatever state a spread-out sort is in (padding
// never moves below the count anyway: every comparator keeps the smaller at the lower slot).
// read_position, u_state_size and u_count are declared by es2particles/bindings.py
// (stage_interface of quantity `position`).
#include "lib/order.glsl"

uniform sampler2D u_order;    // the previous order, read at this fragment's own slot
uniform vec3 u_eye;           // the camera's position
uniform vec3 u_forward;       // its unit viewing direction
uniform vec2 u_depth;         // RGBA8: (far, 1 / (far - near)), the depth range of the box
varying vec2 v_uv;

void main()
{
    // Built in a highp variable and written once: ES 1.00 declares gl_FragColor mediump, and a
    // driver may compute what is assigned straight to it at mediump (Mesa 22 did, in branches,
    // rounding float keys and indices above 2048 to half floats).
    highp vec4 slot;
    float index = order_index(texture2D(u_order, v_uv));
    if (index >= u_count) {
        slot = order_padding(index);
    } else {
        vec3 p = read_position(order_state_uv(index, u_state_size));
        float depth = dot(p - u_eye, u_forward);
#ifdef ORDER_FLOAT
        // Clamped so padding (ORDER_FLOAT_MAX, with a larger index) still sorts last; NaN fails
        // the comparison and goes first, with the farthest.
        float key = (-depth >= -ORDER_FLOAT_MAX) ? min(-depth, ORDER_FLOAT_MAX) : -ORDER_FLOAT_MAX;
#else
        float t = clamp_unit((u_depth.x - depth) * u_depth.y);
        float key = min(floor(t * ORDER_KEY_MAX + 0.5), ORDER_KEY_MAX);
#endif
        slot = order_encode(key, index);
    }
    gl_FragColor = slot;
}
