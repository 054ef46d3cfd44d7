#version 100
// The flame's grid source: a particle adds its count and its heat to its cell (additive
// blending); u_scale is a count's value in the target (1, or 1/255 in RGBA8).
precision mediump float;
varying float v_heat;
uniform float u_scale;

void main()
{
    gl_FragColor = vec4(u_scale, u_scale * v_heat, 0.0, 0.0);
}
