#version 100
// Ribbons, the strips (es2particles/frame/ribbons.py): a corner of the segment between ranks
// a_segment and a_segment + 1 of a particle's positions (rank 0 the newest, in band u_newest of
// the history), a_corner its end (< 2: the newer) and side. Pushed across the segment's screen
// direction and out past its end by u_half_width (clip units), faded by its rank; a segment whose ends are empty,
// behind the camera or of two lives (the newer end younger) is put outside the clip volume.
attribute vec2 a_texel;
attribute float a_segment;
attribute float a_corner;
uniform sampler2D u_history;
uniform float u_bands;
uniform float u_newest;
uniform vec2 u_half_width;
#ifdef VIEW_2D
uniform vec4 u_view;  // the world rectangle: origin, size
#else
uniform mat4 u_view_projection;
#endif
varying float v_fade;

vec4 at_rank(float rank)
{
    float band = mod(u_newest - rank + u_bands, u_bands);
    return texture2D(u_history, vec2(a_texel.x, (band + a_texel.y) / u_bands));
}

vec4 clip(vec3 p)
{
#ifdef VIEW_2D
    return vec4((p.xy - u_view.xy) / u_view.zw * 2.0 - 1.0, 0.0, 1.0);
#else
    return u_view_projection * vec4(p, 1.0);
#endif
}

void main()
{
    vec4 newer = at_rank(a_segment), older = at_rank(a_segment + 1.0);
    vec4 c0 = clip(newer.xyz), c1 = clip(older.xyz);
    bool end = a_corner > 1.5;
    float side = (a_corner == 0.0 || a_corner == 2.0) ? -1.0 : 1.0;
    vec4 here = end ? c1 : c0;
    vec2 d = c1.xy / max(c1.w, 1e-6) - c0.xy / max(c0.w, 1e-6);
    d /= u_half_width;  // in pixels: the direction as it looks
    vec2 along = length(d) > 1e-6 ? d / length(d) : vec2(1.0, 0.0);
    // Across by half the width, and out past each end by as much (square caps: a segment
    // shorter than a pixel, a slow particle's, still covers its pixel).
    vec2 push = side * vec2(-along.y, along.x) + (end ? along : -along);
    gl_Position = here + vec4(push * u_half_width * here.w, 0.0, 0.0);
    v_fade = 1.0 - (a_segment + (end ? 1.0 : 0.0)) / (u_bands - 1.0);
    bool empty = newer.a == 0.0 || older.a == 0.0 || newer.a < older.a;
    if (empty || c0.w <= 0.0 || c1.w <= 0.0) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    }
}
