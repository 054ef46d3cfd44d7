#version 100
// A minimal user pass: every particle's position moves by u_delta each step. Declare it with
//   graph.add("drift", "examples/drift.frag", writes="position", reads=["position"],
//             uniforms={"u_delta": (0.01, 0.0)})
precision highp float;
precision highp sampler2D;
#include "lib/state.glsl"

varying vec2 v_uv;
uniform sampler2D u_position;    // bound by the graph: last step's position
uniform vec4 u_position_range;   // its range, to decode it
uniform vec4 u_out_range;        // the written quantity's range, to encode
uniform vec2 u_delta;

void main()
{
    vec2 p = state_read(u_position, v_uv, u_position_range);
    gl_FragColor = state_encode(p + u_delta, u_out_range);
}
