#version 100
// The opacity shadow map's pass: each particle seen from the light as a point sprite of its world
// size (u_light_size.x over its distance from the light, times the sprites' own size factor:
// lib/sprite.glsl; the image's sprites shrink with their distance from the eye alike),
// adding its opacity (faded with age, as the sprites) to the channel of its depth layer, with
// additive blending (lib/shadow.glsl; es2particles/render/shadow.py).
attribute vec2 a_texel;
varying vec4 v_opacity;
#include "lib/sprite.glsl"
#include "lib/shadow.glsl"

void main()
{
    vec3 p = read_position(a_texel);
    vec2 life = sprite_life(a_texel);
    gl_Position = u_light_view_projection * vec4(p, 1.0);
    gl_PointSize = shadow_point_size(p, a_texel, life);
    float layer = floor(shadow_layer(p));
    v_opacity = vec4(equal(vec4(layer), vec4(0.0, 1.0, 2.0, 3.0)))
        * (life_fade(life) * u_shadow_opacity);
    if (!life_alive(life)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    }
}
