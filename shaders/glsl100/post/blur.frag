#version 100
// Bloom, step 2: one direction of a separable Gaussian blur (run twice: along x, then along y).
// 25 taps in 13 fetches: each pair of neighbouring taps is one linearly filtered fetch placed
// between them by their weights. Offsets and weights come from the host (post.py: blur_taps),
// so the shader computes no exp() per pixel.
precision mediump float;
varying vec2 v_uv;
uniform sampler2D u_source;   // linear filtering
uniform vec2 u_direction;     // one texel along x or y
uniform float u_centre;       // weight of the centre tap
uniform vec2 u_taps[6];       // (offset in texels, weight) of each pair

void main()
{
    vec3 sum = u_centre * texture2D(u_source, v_uv).rgb;
    for (int i = 0; i < 6; ++i) {
        vec2 step = u_taps[i].x * u_direction;
        sum += u_taps[i].y * (texture2D(u_source, v_uv + step).rgb
                              + texture2D(u_source, v_uv - step).rgb);
    }
    gl_FragColor = vec4(sum, 1.0);
}
