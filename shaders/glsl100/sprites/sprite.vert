#version 100
// One textured billboard per particle (an ES 2.0 point sprite): the position fetched from the
// state texture (vertex texture fetch), the size attenuated with the eye distance d as the GL
// point parameters do, size * sqrt(1 / (a + b d + c d^2)), times a per-particle factor (random
// sizes, as the seed, and growth with age: lib/sprite.glsl), clamped to the driver's point-size
// range; below the fade threshold the sprite keeps the threshold size and fades by
// (size / threshold)^2. The renderer's inputs are roles (es2particles/render/sprites.py), each
// read as the quantity the scene maps to it, by the role's name: read_position() always;
// FADE: read_life(), (age, lifetime): alpha falls with age, unborn and dead particles are not
// drawn (without it every particle is alive at age 0); SIZE: read_size_factor(), a factor of the
// size (lib/sprite.glsl, so the shadow map's footprint has it too);
// COLOUR: read_colour(), the particle's tint; ORIENTATION: read_orientation(), the angle its
// texture turns by (sprite.frag); HEADING: read_heading(), a velocity: the texture turns to point
// its +x the way the particle moves on the screen. They and the uniforms are declared by the renderer
// (es2particles/gl/bindings.py).
// SORTED: vertex i draws the particle in slot i of the order texture (es2particles/render/sort.py), so
// the sprites are drawn back to front. SHADOWED: the light reaching the particle through the
// opacity shadow map (es2particles/render/shadow.py, lib/shadow.glsl) shades it.
attribute vec2 a_texel;
uniform mat4 u_view_projection;
varying float v_alpha;
varying float v_light;
#ifdef COLOUR
varying vec3 v_colour;
#endif
#if defined(ORIENTATION) || defined(HEADING)
varying vec2 v_turn;  // (cos, sin) of the texture's turn, counterclockwise on screen
#endif
#ifdef HEADING
uniform float u_aspect;  // the picture's width over its height: NDC x to pixels, as y
#endif
#include "lib/sprite.glsl"
#ifdef SORTED
#include "lib/order.glsl"
uniform sampler2D u_order;
#endif
#ifdef SHADOWED
#include "lib/shadow.glsl"
#endif

void main()
{
#ifdef SORTED
    vec2 texel = order_particle_uv(u_order, a_texel, u_state_size);
#else
    vec2 texel = a_texel;
#endif
    vec3 p = read_position(texel);
    vec2 life = sprite_life(texel);
    gl_Position = u_view_projection * vec4(p, 1.0);
    float d = distance(u_eye, p);
    float size = u_size.x * sprite_scale(texel, life, u_size.y)
        * sqrt(1.0 / (u_attenuation.x + u_attenuation.y * d + u_attenuation.z * d * d));
#ifdef COLOUR
    v_colour = read_colour(texel);
#endif
#ifdef ORIENTATION
    float angle = read_orientation(texel);
    v_turn = vec2(cos(angle), sin(angle));
#endif
#ifdef HEADING
    // The velocity's direction on the screen: the particle's place and a step ahead of it
    // (a hundredth of the eye's distance), both projected; none (0) for a still particle.
    vec3 v = read_heading(texel);
    float speed = length(v);
    vec4 ahead = u_view_projection * vec4(p + v * (0.01 * d / max(speed, 1e-20)), 1.0);
    vec2 along = (ahead.xy / ahead.w - gl_Position.xy / gl_Position.w) * vec2(u_aspect, 1.0);
    v_turn = speed > 0.0 && dot(along, along) > 0.0 ? normalize(along) : vec2(1.0, 0.0);
#endif
    float fade = 1.0;
    if (size < u_fade) {
        fade = (size / u_fade) * (size / u_fade);
        size = u_fade;
    }
    gl_PointSize = clamp(size, u_size.z, u_size.w);
    v_alpha = life_fade(life) * fade;
#ifdef SHADOWED
    v_light = shadow_light(p, texel, life);
#else
    v_light = 1.0;
#endif
    if (!life_alive(life)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    }
}
