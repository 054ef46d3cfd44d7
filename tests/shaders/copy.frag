#version 100
// Test pass: copy "value" (bound as last step's or this step's value by the graph).
precision highp float;
precision highp sampler2D;  // float sources need it: the ES default is lowp
#include "lib/state.glsl"
varying vec2 v_uv;
uniform sampler2D u_value;
uniform vec4 u_value_range;
uniform vec4 u_out_range;

void main()
{
    gl_FragColor = state_encode(state_read(u_value, v_uv, u_value_range), u_out_range);
}
