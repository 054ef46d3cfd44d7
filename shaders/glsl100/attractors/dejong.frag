#version 100
// Peter de Jong attractor: x' = sin(a y) - cos(b x), y' = sin(c x) - cos(d y), k = (a, b, c, d).
// numpy twin: es2particles/scenes/dejong.py, dejong_map().
precision highp float;

vec2 attractor_map(vec2 p, vec4 k)
{
    return vec2(sin(k.x * p.y) - cos(k.y * p.x), sin(k.z * p.x) - cos(k.w * p.y));
}

#include "lib/attractor.glsl"
