#version 100
// What light a particle lets through, blended as a product into the light map (ZERO, SRC_COLOR):
// 1 - opacity times the sprite's alpha and the particle's fade, so a texel holds the share of
// the lamp's light that reaches it past every particle in front.
precision mediump float;
uniform sampler2D u_sprite;
uniform float u_lamp_opacity;
varying float v_fade;

void main()
{
    float stopped = u_lamp_opacity * texture2D(u_sprite, gl_PointCoord).a * v_fade;
    gl_FragColor = vec4(vec3(1.0 - stopped), 1.0);
}
