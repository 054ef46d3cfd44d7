#version 100
// Light shafts, the composite: the picture plus the last pass times u_colour (the light's
// colour times the chain's gain, es2particles/render/shafts.py), faded out as the light turns
// off the view: full while the cosine of its angle to the camera's direction is above u_fade, none
// at 90 degrees and beyond (a light behind the camera gives no shafts, never flipped ones).
precision mediump float;
varying vec2 v_uv;
uniform sampler2D u_image;
uniform sampler2D u_shafts;
uniform vec3 u_colour;
uniform float u_fade;
uniform highp vec3 u_light;
uniform highp vec3 u_eye;
uniform highp vec3 u_forward;

void main()
{
    highp float facing = dot(u_forward, normalize(u_light - u_eye));
    float fade = clamp(facing / u_fade, 0.0, 1.0);
    vec3 shafts = u_colour * (fade * texture2D(u_shafts, v_uv).r);
    gl_FragColor = vec4(min(texture2D(u_image, v_uv).rgb + shafts, 1.0), 1.0);
}
