#version 100
// Test pass: pack the float value held in .x of an RGBA32F texture into 32 bits (one a texel).
precision highp float;
precision highp sampler2D;
#include "lib/pack.glsl"
varying vec2 v_uv;
uniform sampler2D u_source;

void main()
{
    gl_FragColor = pack32(texture2D(u_source, v_uv).x);
}
