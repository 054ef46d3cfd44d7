#version 100
// The opacity shadow map's pass: each particle seen from the light as a point sprite of its world
// size (u_light_size.x / its depth, times the same per-particle size and growth as the sprites),
// adding its opacity (faded with age, as the sprites) to the channel of its depth layer, with
// additive blending (lib/shadow.glsl; es2particles/shadow.py).
attribute vec2 a_texel;
uniform vec4 u_light_size;  // pixels at depth 1, size spread, point size range
uniform float u_shadow_opacity;  // a sprite's opacity, in units of the map
varying vec4 v_opacity;
#include "lib/life.glsl"
#include "lib/shadow.glsl"

void main()
{
    vec3 p = read_position(a_texel);
    vec2 life = read_life(a_texel);
    gl_Position = u_light_view_projection * vec4(p, 1.0);
    float random = hash44(vec4(floor(a_texel * u_state_size), 11.0, 13.0)).x;
    float size = u_light_size.x * mix(1.0 - u_light_size.y, 1.0 + u_light_size.y, random)
        * life_growth(life) / max(gl_Position.w, 1e-6);
    gl_PointSize = clamp(size, u_light_size.z, u_light_size.w);
    float layer = floor(shadow_layer(p));
    v_opacity = vec4(equal(vec4(layer), vec4(0.0, 1.0, 2.0, 3.0)))
        * (life_fade(life) * u_shadow_opacity);
    if (!life_alive(life)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    }
}
