#version 100
// The exact density of a WebGL page with no blendable float target (es2particles/export/page.py):
// points are drawn in batches into u_batch, an RGBA8 (or half-float) target whose four channels
// each take a quarter of the batch, every hit adding u_hit (1/255: one code; or 1.0); this pass
// adds the batch's hits to the running whole count in u_total (lib/counts.glsl), ping-ponged.
// A channel at u_full (255 codes, or 2048, the last whole number a half float holds exactly)
// may have lost hits: the alpha flag says so, and stays.
precision highp float;
precision highp sampler2D;

varying vec2 v_uv;
uniform sampler2D u_total;
uniform sampler2D u_batch;
uniform float u_hit;   // what one hit adds to a channel of u_batch
uniform float u_full;  // hits a channel holds before it may saturate
#include "lib/counts.glsl"

void main()
{
    vec4 total = texture2D(u_total, v_uv);
    vec4 hits = floor(texture2D(u_batch, v_uv) / u_hit + 0.5);
    float full = (max(max(hits.r, hits.g), max(hits.b, hits.a)) >= u_full) ? 1.0 : 0.0;
    float flag = max(floor(total.a * 255.0 + 0.5), full);
    gl_FragColor = vec4(count_encode(count_decode(total) + hits.r + hits.g + hits.b + hits.a),
                        flag);
}
