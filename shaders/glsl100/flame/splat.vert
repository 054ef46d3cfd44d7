#version 100
// The flame's grid source: each live particle one point of one pixel on its cell's texel of the
// atlas (u_atlas: cells a side, tiles across, the atlas's size; tile k holds z slice k), adding
// its count and its heat (1 at birth, 0 at the end of life); particles outside the box [u_lo,
// u_hi], unborn or dead ones are moved outside the clip volume. read_position(), read_life() and
// the uniforms come from the renderer (es2particles/render/flame.py).
attribute vec2 a_texel;
#include "lib/life.glsl"
varying float v_heat;

void main()
{
    vec3 p = read_position(a_texel);
    vec2 life = read_life(a_texel);
    vec3 c = floor((p - u_lo) / (u_hi - u_lo) * u_atlas.x);
    float row = floor((c.z + 0.5) / u_atlas.y);
    vec2 texel = vec2(c.z - row * u_atlas.y, row) * u_atlas.x + c.xy + 0.5;
    gl_Position = vec4(texel / u_atlas.zw * 2.0 - 1.0, 0.0, 1.0);
    gl_PointSize = 1.0;
    v_heat = life_fade(life);
    bool inside = all(greaterThanEqual(c, vec3(0.0))) && all(lessThan(c, vec3(u_atlas.x)));
    if (!life_alive(life) || !inside) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    }
}
