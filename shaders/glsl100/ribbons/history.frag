#version 100
// Ribbons, the history (es2particles/frame/ribbons.py): u_bands bands of the particle texture,
// stacked; band u_band takes every particle's position now (rgb) and its age plus one (alpha;
// 0 where unborn or dead) where the scene has a life (LIFE), else 1; the other bands keep what
// the last frame's history (u_history) holds. read_position(), read_life() and u_state_size
// come from the renderer.
precision highp float;
#ifndef COMPONENTS
#define COMPONENTS 3
#endif
varying vec2 v_uv;
uniform sampler2D u_history;
uniform float u_band;
#ifdef LIFE
#include "lib/life.glsl"
#endif

// gl_FragColor is mediump in GLSL ES 1.00, and llvmpipe rounds a write inside a branch to half
// floats: the texel is kept in a highp variable and written once, outside any branch.
void main()
{
    float row = floor(v_uv.y * u_state_size.y * u_bands);
    float band = floor((row + 0.5) / u_state_size.y);
    vec4 texel = texture2D(u_history, v_uv);
    if (band == u_band) {
        vec2 uv = vec2(v_uv.x, (row - band * u_state_size.y + 0.5) / u_state_size.y);
#if COMPONENTS == 2
        vec3 p = vec3(read_position(uv), 0.0);
#else
        vec3 p = read_position(uv);
#endif
        float mark = 1.0;
#ifdef LIFE
        vec2 life = read_life(uv);
        mark = life_alive(life) ? life.x + 1.0 : 0.0;
#endif
        texel = vec4(p, mark);
    }
    gl_FragColor = texel;
}
