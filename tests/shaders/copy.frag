#version 100
// Test pass: copy "position" (bound as last step's or this step's value by the graph).
precision highp float;
precision highp sampler2D;  // float sources need it: the ES default is lowp
#include "lib/state.glsl"
varying vec2 v_uv;
uniform sampler2D u_position;
uniform vec4 u_position_range;
uniform vec4 u_out_range;

void main()
{
    gl_FragColor = state_encode(state_read(u_position, v_uv, u_position_range), u_out_range);
}
