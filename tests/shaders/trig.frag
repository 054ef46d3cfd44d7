#version 100
// Test pass: (trig_sin, trig_cos, sin, cos) of the float in .x of an RGBA32F texture.
precision highp float;
precision highp sampler2D;
#include "lib/trig.glsl"
varying vec2 v_uv;
uniform sampler2D u_source;

void main()
{
    float x = texture2D(u_source, v_uv).x;
    gl_FragColor = vec4(trig_sin_cos(x), sin(x), cos(x));
}
