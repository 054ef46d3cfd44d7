#version 100
// The one vertex shader of every full-screen pass: a single triangle that covers the viewport
// (cheaper than two: no diagonal seam to shade twice). v_uv runs over [0,1] on the screen, so a
// fragment reads the texel it writes.
attribute vec2 a_position;
varying vec2 v_uv;

void main()
{
    v_uv = a_position * 0.5 + 0.5;
    gl_Position = vec4(a_position, 0.0, 1.0);
}
