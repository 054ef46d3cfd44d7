#version 100
// Ribbons, the strips: the ribbon's colour, faded with age (added to the picture).
precision mediump float;
varying float v_fade;
uniform vec3 u_colour;

void main()
{
    gl_FragColor = vec4(u_colour * v_fade, 1.0);
}
