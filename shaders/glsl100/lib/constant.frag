#version 100
// One colour everywhere: used to probe what a format and the driver's byte store do.
precision highp float;
uniform vec4 u_colour;

void main()
{
    gl_FragColor = u_colour;
}
