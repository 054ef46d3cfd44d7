#version 100
// Peter de Jong attractor: x' = sin(a y) - cos(b x), y' = sin(c x) - cos(d y), k = (a, b, c, d).
// numpy twin: es2particles/scenes/dejong.py, dejong_map().
precision highp float;
// trig_sin, trig_cos: the same values on every driver (the built-ins differ by up to 4e-4)
#include "lib/trig.glsl"

vec2 attractor_map(vec2 p, vec4 k)
{
    return vec2(trig_sin(k.x * p.y) - trig_cos(k.y * p.x), trig_sin(k.z * p.x) - trig_cos(k.w * p.y));
}

#include "lib/attractor.glsl"
