#version 100
// Peter de Jong attractor: x' = sin(a y) - cos(b x), y' = sin(c x) - cos(d y), ITERATIONS times.
// Stateful: start from last step's position. RESEED (the article's way): start every frame from
// the texel grid mapped over the position range, so only the coefficients carry time.
// numpy twin: es2particles/scenes/dejong.py, dejong_map().
precision highp float;
precision highp sampler2D;
#include "lib/state.glsl"

#ifndef ITERATIONS
#define ITERATIONS 3
#endif

varying vec2 v_uv;
uniform vec4 u_coefficients;  // a, b, c, d
uniform vec4 u_out_range;
#ifndef RESEED
uniform sampler2D u_position;
uniform vec4 u_position_range;
#endif

vec2 dejong(vec2 p, vec4 k)
{
    return vec2(sin(k.x * p.y) - cos(k.y * p.x), sin(k.z * p.x) - cos(k.w * p.y));
}

void main()
{
    vec2 grid = u_out_range.xy + v_uv * u_out_range.zw;
#ifdef RESEED
    vec2 p = grid;
#else
    vec2 p = state_read(u_position, v_uv, u_position_range);
    // A non-finite position (only float formats can hold one) restarts from the grid.
    if (!(abs(p.x) < 1e30 && abs(p.y) < 1e30)) {
        p = grid;
    }
#endif
    for (int i = 0; i < ITERATIONS; ++i) {
        p = dejong(p, u_coefficients);
    }
    gl_FragColor = state_encode(p, u_out_range);
}
