#version 100
// Test pass: value = last step's value + u_delta (ping-pong test).
precision highp float;
precision highp sampler2D;  // float sources need it: the ES default is lowp
#include "lib/state.glsl"
varying vec2 v_uv;
uniform sampler2D u_value;
uniform vec4 u_value_range;
uniform vec4 u_out_range;
uniform vec2 u_delta;

void main()
{
    gl_FragColor = state_encode(state_read(u_value, v_uv, u_value_range) + u_delta, u_out_range);
}
