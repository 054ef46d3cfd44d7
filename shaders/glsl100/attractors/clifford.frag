#version 100
// Clifford attractor: x' = sin(a y) + c cos(a x), y' = sin(b x) + d cos(b y), k = (a, b, c, d).
// numpy twin: es2particles/scenes/clifford.py, clifford_map().
precision highp float;

vec2 attractor_map(vec2 p, vec4 k)
{
    return vec2(sin(k.x * p.y) + k.z * cos(k.x * p.x), sin(k.y * p.x) + k.w * cos(k.y * p.y));
}

#include "lib/attractor.glsl"
