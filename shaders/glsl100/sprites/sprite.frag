#version 100
// A sprite's colour: its texture over gl_PointCoord, mixed with the tint, alpha from the texture,
// the particle's age and the opacity; premultiplied, so one output serves both blend modes
// (additive: ONE, ONE; over: ONE, ONE_MINUS_SRC_ALPHA). v_light is the light that reaches the
// particle (1 unless it is shadowed). OCCLUDER: the light it lets through instead.
precision mediump float;
uniform sampler2D u_sprite;
uniform vec4 u_tint;  // rgb, and how much of it replaces the texture's colour
uniform float u_opacity;
varying float v_alpha;
varying float v_light;
#ifdef COLOUR
varying vec3 v_colour;  // the particle's own tint (a COLOUR role), in place of u_tint.rgb
#endif
#if defined(ORIENTATION) || defined(HEADING)
varying vec2 v_turn;  // (cos, sin) of the texture's turn, counterclockwise on screen
#endif
#ifdef SOFT
// Soft particles (the ARM chapter's): the sprite fades over u_soft as it nears the opaque scene
// behind it, and is gone behind it (drawn into a buffer with no depth test; lib/depth.glsl).
precision highp float;
#include "lib/pack.glsl"
#include "lib/depth.glsl"
uniform float u_soft;
uniform vec2 u_target_size;  // the buffer's pixels: gl_FragCoord over it is a screen position
#endif

void main()
{
#if defined(ORIENTATION) || defined(HEADING)
    // gl_PointCoord's t runs down the screen: this turn of it is counterclockwise on screen.
    vec2 c = gl_PointCoord - 0.5;
    float s = v_turn.y, k = v_turn.x;
    vec2 uv = vec2(k * c.x - s * c.y, s * c.x + k * c.y) + 0.5;
    vec4 t = texture2D(u_sprite, uv);
    if (uv != clamp(uv, 0.0, 1.0)) {
        t = vec4(0.0);  // a corner turned out of the texture
    }
#else
    vec4 t = texture2D(u_sprite, gl_PointCoord);
#endif
    float a = t.a * v_alpha * u_opacity;
#ifdef COLOUR
    vec3 tint = v_colour;
#else
    vec3 tint = u_tint.rgb;
#endif
#if defined(SOFT) && defined(SCENE_DEPTH)
    float gap = scene_distance(gl_FragCoord.xy / u_target_size) - view_distance(gl_FragCoord.z);
    a *= clamp(gap / u_soft, 0.0, 1.0);
#endif
#ifdef OCCLUDER
    // Light shafts' occluders (render/shafts.py): drawn with the multiply blend, each sprite
    // lets 1 - its opacity of the light through.
    gl_FragColor = vec4(vec3(1.0 - a), 1.0);
#else
    gl_FragColor = vec4(mix(t.rgb, tint, u_tint.a) * (v_light * a), a);
#endif
}
