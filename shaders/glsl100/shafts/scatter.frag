#version 100
// Light shafts, one pass of the chain (es2particles/render/shafts.py has the integral): each
// pixel sums TAPS samples of its input along its ray to the light's point L on the screen, at
// L + (v_uv - L) f, the factor f and the weight w each falling geometrically from tap to tap,
// so chained passes multiply into one sum of TAPS^passes samples. u_pass: (log2 of f's step,
// log2 of w's step, 1 / the sum of the weights): the output is a weighted mean, in [0, 1].
// SOURCE: the first pass, whose input is the occluders' transmittance, times the light's glow
// exp(-(d / u_glow)^2) at d picture heights from L; its samples sit mid-step, or dithered by a
// 4x4 Bayer pattern (JITTER).
precision highp float;
#ifndef TAPS
#define TAPS 12  // taps a pass: the plan defines it (a loop's bound is a constant in ES 2.0)
#endif
varying vec2 v_uv;
uniform sampler2D u_source;
uniform mat4 u_view_projection;
uniform vec3 u_light;
uniform vec3 u_pass;
#ifdef SOURCE
uniform float u_aspect;  // the picture's width over its height
uniform float u_glow;
#endif

// The light's point on the screen, in texture coordinates (a light behind the camera lands
// anywhere: the composite fades its shafts out).
vec2 light_point()
{
    vec4 clip = u_view_projection * vec4(u_light, 1.0);
    return clip.xy / max(clip.w, 1e-6) * 0.5 + 0.5;
}

#include "lib/bayer.glsl"

void main()
{
    vec2 light = light_point();
    float start = 0.0;
#ifdef SOURCE
    start = 0.5;
#ifdef JITTER
    start = (bayer4(gl_FragCoord.xy) + 0.5) / 16.0;
#endif
#endif
    float f = exp2(u_pass.x * start), w = exp2(u_pass.y * start);
    float df = exp2(u_pass.x), dw = exp2(u_pass.y);
    float sum = 0.0;
    for (int j = 0; j < TAPS; j++) {
        vec2 p = light + (v_uv - light) * f;
        // Nothing off the screen gives light: no pass can hold what it would be there (a chain's
        // later pass would read a clamped edge), and a ray leaving the screen never comes back.
        vec2 inside = step(0.0, p) * step(p, vec2(1.0));
        float s = texture2D(u_source, p).r * inside.x * inside.y;
#ifdef SOURCE
        vec2 d = (p - light) * vec2(u_aspect, 1.0);
        s *= exp(-dot(d, d) / (u_glow * u_glow));
#endif
        sum += w * s;
        f *= df;
        w *= dw;
    }
    sum *= u_pass.z;
    gl_FragColor = vec4(sum, sum, sum, 1.0);
}
