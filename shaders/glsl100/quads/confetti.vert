#version 100
// The confetti: four vertices per particle (a_corner one of (+-1, +-1); ES 2.0 has no
// instancing, so the vertex buffer holds every particle's four, drawn through one static index
// buffer as two triangles), each placing its corner of a quad turned to face the particle's
// normal (the last surface it touched, lib/octahedral.glsl) at the position fetched from the
// state texture. A per-particle turn about the normal, shape, colour and lift come from the
// sequence at its texel (lib/sequence.glsl: alike on every driver). Unborn and dead particles
// are moved out of the clip volume. read_position(), read_normal(), read_life() and the
// uniforms are declared by the renderer (render/quads.py): u_half_size (world units), u_lift
// (off the surface along the normal, so a resting quad does not fight the floor's depth),
// u_light (a point), u_shapes (the shapes on offer: 0 disc, 1 square, 2 star) and
// u_shape_count, u_palette[PALETTE] (colours).
attribute vec2 a_texel;
attribute vec2 a_corner;
uniform mat4 u_view_projection;
varying vec2 v_corner;
varying vec3 v_colour;
varying float v_shape;
#include "lib/life.glsl"
#include "lib/octahedral.glsl"
#include "lib/sequence.glsl"

void main()
{
    vec3 p = read_position(a_texel);
    vec3 n = octahedral_decode(read_normal(a_texel));
    vec2 life = read_life(a_texel);
    vec3 h = particle_sequence(a_texel);  // alike on every driver: no piece changes shape
    vec3 side = normalize(cross(n, abs(n.y) < 0.99 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0)));
    float turn = 6.2831853 * h.x;
    vec3 u = side * cos(turn) + cross(n, side) * sin(turn);
    vec3 w = cross(n, u);
    // Lifted off its surface by a height of its own, so pieces piled flat do not fight for depth.
    float lift = u_lift * (0.5 + fract(h.x * 7.0));
    vec3 world = p + n * lift + (u * a_corner.x + w * a_corner.y) * u_half_size;
    gl_Position = u_view_projection * vec4(world, 1.0);
    v_corner = a_corner;
    v_shape = u_shapes[int(min(floor(h.y * u_shape_count), u_shape_count - 1.0))];
    vec3 colour = u_palette[0];
    for (int i = 1; i < PALETTE; ++i) {
        if (h.z * float(PALETTE) >= float(i)) {
            colour = u_palette[i];
        }
    }
    // Both faces lit alike: Lambert from the lamp, over an ambient floor.
    float lambert = abs(dot(n, normalize(u_light - world)));
    v_colour = colour * (0.35 + 0.65 * lambert);
    if (!life_alive(life)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    }
}
