#version 100
// A sprite's colour: its texture over gl_PointCoord, mixed with the tint, alpha from the texture,
// the particle's age and the opacity; premultiplied, so one output serves both blend modes
// (additive: ONE, ONE; over: ONE, ONE_MINUS_SRC_ALPHA). v_light is the light that reaches the
// particle (1 unless it is shadowed).
precision mediump float;
uniform sampler2D u_sprite;
uniform vec4 u_tint;  // rgb, and how much of it replaces the texture's colour
uniform float u_opacity;
varying float v_alpha;
varying float v_light;
#ifdef COLOUR
varying vec3 v_colour;  // the particle's own tint (a COLOUR role), in place of u_tint.rgb
#endif

void main()
{
    vec4 t = texture2D(u_sprite, gl_PointCoord);
    float a = t.a * v_alpha * u_opacity;
#ifdef COLOUR
    vec3 tint = v_colour;
#else
    vec3 tint = u_tint.rgb;
#endif
    gl_FragColor = vec4(mix(t.rgb, tint, u_tint.a) * (v_light * a), a);
}
