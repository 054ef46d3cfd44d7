#version 100
// Clifford attractor: x' = sin(a y) + c cos(a x), y' = sin(b x) + d cos(b y), k = (a, b, c, d).
// numpy twin: es2particles/scenes/clifford.py, clifford_map().
precision highp float;
// trig_sin, trig_cos: the same values on every driver (the built-ins differ by up to 4e-4)
#include "lib/trig.glsl"

vec2 attractor_map(vec2 p, vec4 k)
{
    return vec2(trig_sin(k.x * p.y) + k.z * trig_cos(k.x * p.x),
                trig_sin(k.y * p.x) + k.w * trig_cos(k.y * p.y));
}

#include "lib/attractor.glsl"
