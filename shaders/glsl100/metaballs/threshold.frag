#version 100
// The liquid's metaballs, step 3 (the author's metaballs pass): white where the blurred discs'
// value (their red: post/blur.frag blurs the colour) reaches the threshold, nothing elsewhere
// (the author discards alpha below 0.1 into a cleared target: the same texels).
precision mediump float;
varying vec2 v_uv;
uniform sampler2D u_source;
uniform float u_threshold;

void main()
{
    gl_FragColor = vec4(step(u_threshold, texture2D(u_source, v_uv).r));
}
