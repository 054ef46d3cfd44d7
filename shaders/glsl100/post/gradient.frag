#version 100
// The gradient map over any rendering's picture: each pixel's brightness (Rec. 709 luma of its
// RGB) picks its colour along the ramp (lib/ramp.glsl), as the tone map does for a density.
#ifdef GL_FRAGMENT_PRECISION_HIGH
precision highp float;  // the luma picks a texel of 256: mediump's 2^-11 is a tenth of one
#else
precision mediump float;
#endif
varying vec2 v_uv;
uniform sampler2D u_source;
uniform sampler2D u_ramp;  // 256 x 1, linear filtering

#include "lib/ramp.glsl"

void main()
{
    float luma = dot(texture2D(u_source, v_uv).rgb, vec3(0.2126, 0.7152, 0.0722));
    gl_FragColor = vec4(ramp_colour(u_ramp, clamp(luma, 0.0, 1.0)), 1.0);
}
