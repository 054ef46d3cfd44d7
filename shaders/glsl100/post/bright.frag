#version 100
// Bloom, step 1: keep what is brighter than the threshold (drawn at reduced resolution, so the
// linear filter of the source averages a few pixels on the way down).
precision mediump float;
varying vec2 v_uv;
uniform sampler2D u_source;
uniform float u_threshold;

void main()
{
    vec3 c = texture2D(u_source, v_uv).rgb;
    float luma = dot(c, vec3(0.2126, 0.7152, 0.0722));
    float keep = max(luma - u_threshold, 0.0) / max(luma, 1e-4);
    gl_FragColor = vec4(c * keep, 1.0);
}
