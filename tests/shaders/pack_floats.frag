#version 100
// Test pass: pack the float values held in .xy of an RGBA32F texture.
precision highp float;
precision highp sampler2D;  // float sources need it: the ES default is lowp
#include "lib/pack.glsl"
varying vec2 v_uv;
uniform sampler2D u_source;

void main()
{
    gl_FragColor = pack2x16(texture2D(u_source, v_uv).xy);
}
