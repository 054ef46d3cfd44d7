#version 100
// An opaque mesh of the 3D scene (floor, box, sphere, an obstacle): in world coordinates, or
// (MOVES) a moving mesh's rest pose placed by the scene's motion at u_motion_time
// (lib/motion.glsl: its rotation, uniform scale and translation; normals turn with it, and
// mesh.frag normalises them).
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
#ifdef MOVES
uniform float u_motion_time;
uniform vec4 u_motion_pivot;
uniform vec4 u_motion_spin;
uniform vec4 u_motion_sway;
uniform vec3 u_motion_offset;
#include "lib/motion.glsl"
#endif

void main()
{
#ifdef TEXTURED
    v_uv = a_uv;
#endif
#ifdef MOVES
    Pose pose = motion_pose(u_motion_time);
    v_world = motion_place(a_position, pose);
    v_normal = motion_turn(a_normal, pose);
#else
    v_world = a_position;
    v_normal = a_normal;
#endif
    gl_Position = u_view_projection * vec4(v_world, 1.0);
}
