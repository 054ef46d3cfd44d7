#version 100
// The flame: emission and absorption along each pixel's ray through the box [u_lo, u_hi]
// (es2particles/render/flame.py states the integral). The ray is cut into STEPS equal segments;
// each takes the field at one point (its midpoint, or a place dithered by the 4x4 Bayer pattern
// and the frame: JITTER) and is integrated exactly for a field constant over it: opacity
// a = 1 - exp(-K rho h), light added T a (E / K) B(temperature), T the light let through so far.
// The field: SOURCE_NOISE, a stretched sphere's distance displaced by rising simplex noise;
// SOURCE_GRID, the particles' cells (flame/splat.vert), read trilinearly from their atlas;
// SOURCE_STATE, a state quantity (density, temperature) on a 3D grid, read by its generated
// trilinear sample (field_sample, defined by the plan as sample_<quantity>).
precision highp float;
#ifndef STEPS
#define STEPS 64  // the plan defines it (a loop's bound is a constant in ES 2.0)
#endif
#if !defined(SOURCE_NOISE) && !defined(SOURCE_GRID) && !defined(SOURCE_STATE)
#define SOURCE_NOISE  // the plan defines one
#endif
varying vec2 v_uv;
uniform vec3 u_eye;
uniform vec3 u_forward;
uniform vec3 u_up;
uniform vec2 u_lens;      // tan(fov / 2) times the aspect, and tan(fov / 2)
uniform vec3 u_lo;
uniform vec3 u_hi;
uniform vec2 u_medium;    // K (1/m at density 1) and E / K
uniform vec3 u_background;
uniform sampler2D u_ramp; // the blackbody colour by temperature, 256 texels
// u_step: steps run, the noise's clock and the dither's frame (a state source's generated
// reads declare it: lib/state.glsl)
#if (defined(SOURCE_NOISE) || defined(JITTER)) && !defined(SOURCE_STATE)
uniform float u_step;
#endif
#ifdef ACCUMULATE
uniform float u_weight;   // 1 / K: this march's share of the K steps' average
#endif

#include "lib/ramp.glsl"

#ifdef JITTER
#include "lib/bayer.glsl"
#endif

#ifdef SOURCE_NOISE
#include "lib/noise.glsl"
uniform vec4 u_shape;     // radius, height, flicker, frequency (1/m)
uniform float u_rise;     // metres the noise rises a step

// (density, temperature) at p: the sphere of radius 1 stretched to radius u_shape.x across and
// from the base (y = 0) to u_shape.y, its widest a third of the way up; its distance pushed in
// and out by two octaves of noise, more towards the top; the density 1 at 0.3 radius inside.
vec2 field(vec3 p)
{
    float radius = u_shape.x, height = u_shape.y;
    float rise = clamp(p.y / height, 0.0, 1.0);
    float centre = height / 3.0;
    float axis = p.y < centre ? centre : height - centre;
    float d = (length(vec3(p.x / radius, (p.y - centre) / axis, p.z / radius)) - 1.0) * radius;
    // Noise moves d by at most 1.5 u_shape.z rise (|simplex3| <= 1): beyond, skip it.
    if (d > 1.5 * u_shape.z * rise) {
        return vec2(0.0);
    }
    // Stretched upwards: tongues, twice as tall as wide.
    vec3 n = vec3(p.x, 0.5 * (p.y - u_rise * u_step), p.z) * u_shape.w;
    d += u_shape.z * rise * (simplex3(n).w + 0.5 * simplex3(2.0 * n + 7.0).w);
    float density = clamp(-d / (0.3 * radius), 0.0, 1.0);
    return vec2(density, clamp(density * (1.2 - 0.8 * rise), 0.0, 1.0));
}
#endif

#ifdef SOURCE_GRID
uniform sampler2D u_grid; // (count, heat) of each cell's particles, z slices as tiles
uniform vec4 u_atlas;     // cells a side, tiles across, the atlas's width and height
uniform float u_density;  // a count's density

vec2 tile(float k)
{
    float row = floor((k + 0.5) / u_atlas.y);
    return vec2(k - row * u_atlas.y, row) * u_atlas.x;
}

// Trilinear: bilinear within the two z slices about p (texel centres clamped inside the tile,
// so no neighbour tile bleeds in), mixed. The temperature is the heat over the count.
vec2 field(vec3 p)
{
    float n = u_atlas.x;
    vec3 c = clamp((p - u_lo) / (u_hi - u_lo) * n - 0.5, 0.0, n - 1.0);
    float z0 = floor(c.z);
    vec2 xy = c.xy + 0.5;
    vec4 a = texture2D(u_grid, (tile(z0) + xy) / u_atlas.zw);
    vec4 b = texture2D(u_grid, (tile(min(z0 + 1.0, n - 1.0)) + xy) / u_atlas.zw);
    vec2 g = mix(a.xy, b.xy, c.z - z0);
    return vec2(g.x * u_density, clamp(g.y / max(g.x, 1e-6), 0.0, 1.0));
}
#endif

#ifdef SOURCE_STATE
// The state's (density, temperature) at p, clamped to [0, 1] as the ramp takes it.
vec2 field(vec3 p)
{
    return clamp(field_sample(p), 0.0, 1.0);
}
#endif

void main()
{
    vec2 ndc = v_uv * 2.0 - 1.0;
    vec3 side = normalize(cross(u_forward, u_up));
    vec3 up = cross(side, u_forward);
    vec3 dir = normalize(u_forward + ndc.x * u_lens.x * side + ndc.y * u_lens.y * up);
    // The box's slabs; a component of 0 becomes a tiny one of its sign (1/0 is undefined here).
    vec3 safe = sign(dir + 1e-30) * max(abs(dir), 1e-12);
    vec3 near = (u_lo - u_eye) / safe, far = (u_hi - u_eye) / safe;
    vec3 enter = min(near, far), leave = max(near, far);
    float t0 = max(max(max(enter.x, enter.y), enter.z), 0.0);
    float t1 = min(min(leave.x, leave.y), leave.z);
    vec3 light = vec3(0.0);
    float through = 1.0;
    if (t1 > t0) {
        float h = (t1 - t0) / float(STEPS);
        float start = 0.5;
#ifdef JITTER
        start = fract((bayer4(gl_FragCoord.xy) + 0.5) / 16.0 + 0.6180339887 * u_step);
#endif
        for (int i = 0; i < STEPS; i++) {
            vec2 f = field(u_eye + (t0 + (float(i) + start) * h) * dir);
            float a = 1.0 - exp(-u_medium.x * f.x * h);
            light += through * a * ramp_colour(u_ramp, f.y);
            through *= 1.0 - a;
        }
    }
    // The tone curve 1 - exp(-L): a hot core goes towards white, never past it.
    gl_FragColor = vec4(1.0 - exp(-(light * u_medium.y + through * u_background)), 1.0);
#ifdef ACCUMULATE
    gl_FragColor *= u_weight;  // one of the K steps' marches summed into the average
#endif
}
