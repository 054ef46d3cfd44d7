#version 100
// Each point adds u_colour to the accumulation target (additive blending): density. With HUE its
// second channel gets the colour's share, v_hue (0 to 1) of it: the tone map divides the two.
precision mediump float;
uniform vec4 u_colour;
#ifdef AGE_FADE
varying float v_fade;
#endif
#ifdef HUE
varying float v_hue;
#endif

void main()
{
    vec4 colour = u_colour;
#ifdef HUE
    colour *= vec4(1.0, v_hue, 0.0, 0.0);
#endif
#ifdef AGE_FADE
    colour *= v_fade;
#endif
    gl_FragColor = colour;
}
