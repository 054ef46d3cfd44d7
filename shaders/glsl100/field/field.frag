#version 100
// A grid quantity as the picture (render/field.py): at each pixel's world point the quantity's
// magnitude, sampled by read_field_sample (defined as its sample_q: bilinear), over [0, u_top]
// through the gradient map (or grey), with the scene's objects over it where they are opaque.
// Declared for it: u_view (the world rectangle x0, y0, x1, y1 shown), u_top (the magnitude at
// the ramp's end) and the quantity's reads.
varying vec2 v_uv;
#ifdef GRADIENT
uniform sampler2D u_ramp;  // 256 x 1, linear filtering
#include "lib/ramp.glsl"
#endif
#ifdef BACKGROUND
uniform sampler2D u_background;  // the scene's objects
#endif

void main()
{
    vec2 point = mix(u_view.xy, u_view.zw, v_uv);
    float t = clamp(length(read_field_sample(point)) / u_top, 0.0, 1.0);
#ifdef GRADIENT
    vec3 colour = ramp_colour(u_ramp, t);
#else
    vec3 colour = vec3(t);
#endif
#ifdef BACKGROUND
    vec4 object = texture2D(u_background, v_uv);
    colour = mix(colour, object.rgb, object.a);
#endif
    gl_FragColor = vec4(colour, 1.0);
}
