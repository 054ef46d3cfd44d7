#version 100
// Density to colour: a log curve, so sparse and dense regions both show, then the gradient map.
// t = log(1 + exposure d / mean) / log(1 + exposure * HEADROOM), with mean the density of a pixel
// if every particle landed evenly at unit intensity (so --intensity brightens); the ramp texture
// maps t to a colour (GRADIENT) or grey.
// DENSITY_COUNTS: the density is a whole count in three bytes of an RGBA8 texture (a WebGL page
// with no blendable float target: density/add.frag), each count worth u_unit.
// HUE: the density's second channel holds its points' sum of a quantity's share (points.frag):
// the ramp colours a pixel by their mean, second over first, at a brightness that is full from
// HUE_HEADROOM times an even spread's density (u_mean) up and falls on a log curve below it.
precision highp float;
precision highp sampler2D;

varying vec2 v_uv;
uniform sampler2D u_density;
uniform float u_mean;      // particles / pixels: a particle of intensity i adds i
uniform float u_exposure;
#ifdef GRADIENT
uniform sampler2D u_ramp;  // 256 x 1, linear filtering
#include "lib/ramp.glsl"
#endif
#ifdef BACKGROUND
uniform sampler2D u_background;  // the scene's objects, drawn under the particles
#endif

#ifdef DENSITY_COUNTS
uniform float u_unit;
#include "lib/counts.glsl"
#endif

const float HEADROOM = 256.0;
const float HUE_HEADROOM = 4.0;

float density_at(vec2 uv)
{
#ifdef DENSITY_COUNTS
    return count_decode(texture2D(u_density, uv)) * u_unit;
#else
    return texture2D(u_density, uv).r;
#endif
}

void main()
{
    float d = density_at(v_uv);
    float t = log(1.0 + u_exposure * d / u_mean) / log(1.0 + u_exposure * HEADROOM);
    t = clamp(t, 0.0, 1.0);
#if defined(GRADIENT) && defined(HUE) && !defined(DENSITY_COUNTS)
    vec2 sums = texture2D(u_density, v_uv).rg;
    float mean = clamp(sums.g / max(sums.r, 1e-30), 0.0, 1.0);
    // full colour from HUE_HEADROOM times an even spread's density up: the hue is the picture
    float bright = clamp(log(1.0 + u_exposure * d / u_mean)
                         / log(1.0 + u_exposure * HUE_HEADROOM), 0.0, 1.0);
    vec3 colour = bright * ramp_colour(u_ramp, mean);
#elif defined(GRADIENT)
    vec3 colour = ramp_colour(u_ramp, t);
#else
    vec3 colour = vec3(t);
#endif
#ifdef BACKGROUND
    colour += texture2D(u_background, v_uv).rgb * (1.0 - t);
#endif
    gl_FragColor = vec4(colour, 1.0);
}
