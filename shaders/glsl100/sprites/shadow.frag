#version 100
// A particle's opacity in the shadow map: its layer's channel, times the sprite's alpha over
// gl_PointCoord (the same radial falloff the image shows), added into the map.
precision mediump float;
uniform sampler2D u_sprite;
varying vec4 v_opacity;

void main()
{
    gl_FragColor = v_opacity * texture2D(u_sprite, gl_PointCoord).a;
}
