#version 100
// An opaque mesh of the 3D scene (floor, box, sphere), in world coordinates already.
// TEXTURED: with texture coordinates (the seed's textured cube).
precision highp float;
attribute vec3 a_position;
attribute vec3 a_normal;
uniform mat4 u_view_projection;
varying vec3 v_normal;
varying vec3 v_world;
#ifdef TEXTURED
attribute vec2 a_uv;
varying vec2 v_uv;
#endif

void main()
{
#ifdef TEXTURED
    v_uv = a_uv;
#endif
    v_normal = a_normal;
    v_world = a_position;
    gl_Position = u_view_projection * vec4(a_position, 1.0);
}
