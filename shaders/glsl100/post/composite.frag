#version 100
// Bloom, step 3: the image plus the blurred bright parts of every level (added, then clamped).
precision mediump float;
varying vec2 v_uv;
uniform sampler2D u_source;
uniform sampler2D u_bloom0;
uniform sampler2D u_bloom1;
uniform float u_intensity;

void main()
{
    vec3 glow = texture2D(u_bloom0, v_uv).rgb + texture2D(u_bloom1, v_uv).rgb;
    gl_FragColor = vec4(min(texture2D(u_source, v_uv).rgb + u_intensity * glow, 1.0), 1.0);
}
