#version 100
// Bloom, step 2: one direction of a separable Gaussian blur (run twice: along x, then along y).
precision mediump float;
varying vec2 v_uv;
uniform sampler2D u_source;
uniform vec2 u_direction;  // one texel along x or y
uniform float u_sigma;     // in texels

#define TAPS 12

void main()
{
    vec3 sum = texture2D(u_source, v_uv).rgb;
    float total = 1.0;
    for (int i = 1; i <= TAPS; ++i) {
        float x = float(i);
        float w = exp(-0.5 * x * x / (u_sigma * u_sigma));
        sum += w * (texture2D(u_source, v_uv + x * u_direction).rgb
                    + texture2D(u_source, v_uv - x * u_direction).rgb);
        total += 2.0 * w;
    }
    gl_FragColor = vec4(sum / total, 1.0);
}
