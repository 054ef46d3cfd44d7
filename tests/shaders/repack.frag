#version 100
// Test pass: decode a packed texel and encode it again (the byte-exactness test of the codec).
// The sampler keeps the ES default precision (lowp; Mesa samples it as half float): unpack16 must
// still recover the bytes exactly, by snapping each channel to the 1/255 grid.
precision highp float;
#include "lib/pack.glsl"
varying vec2 v_uv;
uniform sampler2D u_source;

void main()
{
    gl_FragColor = pack2x16(unpack2x16(texture2D(u_source, v_uv)));
}
