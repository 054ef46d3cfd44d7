#version 100
// One point at the viewport's centre, u_size pixels across: the probe of the widest point the
// driver draws (egl.py's _probe_point_size), which its reported range may understate.
attribute vec2 a_position;
uniform float u_size;

void main()
{
    gl_Position = vec4(a_position, 0.0, 1.0);
    gl_PointSize = u_size;
}
