#version 100
// The ARM chapter's shadows, step 2: each particle seen from the lamp as a point sprite of its
// world size (u_light_size.x over its distance from the lamp, times the sprites' own size
// factor: lib/sprite.glsl), drawn into the light map with depth test and no depth writes, so a
// particle behind the object (seen from the lamp) stops no light. read_position() (and
// read_life()) are declared by the renderer (render/lamp.py).
attribute vec2 a_texel;
uniform mat4 u_lamp_view_projection;
uniform vec3 u_lamp;
uniform vec4 u_light_size;  // sprite pixels in the map at distance 1, size spread, size range
varying float v_fade;
#include "lib/sprite.glsl"

void main()
{
    vec3 p = read_position(a_texel);
    vec2 life = sprite_life(a_texel);
    gl_Position = u_lamp_view_projection * vec4(p, 1.0);
    float size = u_light_size.x * sprite_scale(a_texel, life, u_light_size.y)
        / max(distance(u_lamp, p), 1e-6);
    gl_PointSize = clamp(size, u_light_size.z, u_light_size.w);
    v_fade = life_fade(life);
    if (!life_alive(life)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    }
}
