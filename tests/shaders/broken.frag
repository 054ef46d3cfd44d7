#version 100
// Test shader with a deliberate error on line 9 (an undeclared name).
precision highp float;
#include "lib/pack.glsl"
varying vec2 v_uv;

void main()
{
    gl_FragColor = pack2x16(v_uv) + undeclared_name;
}
