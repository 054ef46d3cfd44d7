#version 100
// One point per particle: fetch its position from the state texture (vertex texture fetch) at
// the texel this vertex names. GLSL ES 1.00 has no gl_VertexID, so a static buffer of texel
// coordinates, made once, is the index. read_position() and read_life(), the samplers behind
// them and u_view, u_point_size, u_target_size are declared by the renderer
// (render.point_uniforms, written by es2particles/bindings.py).
attribute vec2 a_texel;
#ifdef AGE_FADE
#include "lib/life.glsl"
varying float v_fade;
#endif
#ifdef HUE
// HUE_READ reads the quantity whose magnitude over [0, u_hue_top] colours the point.
varying float v_hue;
#endif

void main()
{
    vec2 p = read_position(a_texel);
    // The point's square is put with its lower-left corner on a pixel corner. A rasteriser
    // places a vertex to its own sub-pixel precision, so an unsnapped point near a pixel's edge
    // lands on either side (from the same positions, 0.6% of llvmpipe's density pixels and 9.4%
    // of Chromium's differed from floor binning); snapped, every driver lights the same pixels:
    // for size 1, pixel floor(x) of x = (p - view origin) / view size * target size.
    vec2 pixel = (p - u_view.xy) / u_view.zw * u_target_size;
    vec2 corner = floor(pixel - 0.5 * u_point_size + 0.5);
    gl_Position = vec4((corner + 0.5 * u_point_size) / u_target_size * 2.0 - 1.0, 0.0, 1.0);
    gl_PointSize = u_point_size;
#ifdef HUE
    v_hue = clamp(length(HUE_READ(a_texel)) / u_hue_top, 0.0, 1.0);
#endif
#ifdef AGE_FADE
    // life = (age, lifetime): fade out as the particle gets older; unborn (age < 0) and dead
    // (age >= lifetime) ones are moved outside the clip volume, so they are never drawn.
    vec2 life = read_life(a_texel);
    v_fade = life_fade(life);
    if (!life_alive(life)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    }
#endif
}
