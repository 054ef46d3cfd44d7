#version 100
// An opaque mesh of the 3D scene (floor, box, sphere, an obstacle), placed by u_model: the
// identity for a mesh in world coordinates, a moving mesh's rotation, uniform scale and
// translation (so normals turn by it too; mesh.frag normalises them).
// TEXTURED: with texture coordinates (the seed's textured cube).
precision highp float;
attribute vec3 a_position;
attribute vec3 a_normal;
uniform mat4 u_view_projection;
uniform mat4 u_model;
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
    vec4 world = u_model * vec4(a_position, 1.0);
    v_normal = (u_model * vec4(a_normal, 0.0)).xyz;
    v_world = world.xyz;
    gl_Position = u_view_projection * world;
}
