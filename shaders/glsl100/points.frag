#version 100
// Each point adds u_intensity to the accumulation target (additive blending): density.
precision mediump float;
uniform vec4 u_colour;
#ifdef AGE_FADE
varying float v_fade;
#endif

void main()
{
#ifdef AGE_FADE
    gl_FragColor = u_colour * v_fade;
#else
    gl_FragColor = u_colour;
#endif
}
