#version 100
// Screen-space trails (es2particles/frame/plan.py, plan_fade_trails): the brighter of the new
// picture and the last frame's times u_keep, less 0.6 of a code, so every trail loses at least
// a code a frame and fades out fully (rounded to nearest, x * 0.97 stays x below 17 codes: a
// ghost webgl-wind's plain fade never clears).
precision mediump float;
varying vec2 v_uv;
uniform sampler2D u_picture;
uniform sampler2D u_trail;
uniform float u_keep;

void main()
{
    vec3 kept = max(u_keep * texture2D(u_trail, v_uv).rgb - 0.6 / 255.0, 0.0);
    gl_FragColor = vec4(max(texture2D(u_picture, v_uv).rgb, kept), 1.0);
}
