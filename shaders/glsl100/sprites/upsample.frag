#version 100
// The sprites' buffer (premultiplied colour and coverage, drawn at a lower resolution: the ARM
// chapter's 640x360 under a 1080p picture) laid over the picture of the opaque scene, upsampled
// by UPSAMPLE_NEAREST (the buffer texel under the pixel), UPSAMPLE_BILINEAR (the hardware's
// filter) or UPSAMPLE_BILATERAL (the chapter's: the buffer texels around the pixel weighted by
// their distance and a linear factor of how near their scene distance is to the pixel's, so
// smoke beside an object's edge does not bleed over it; with no opaque scene,
// SCENE_DEPTH undefined, it is bilinear). ADDITIVE: the sprites
// glow (added); else they cover (over). lib/depth.glsl reads the scene's distance.
precision highp float;
#include "lib/pack.glsl"
#include "lib/depth.glsl"
uniform sampler2D u_image;
uniform sampler2D u_smoke;
uniform vec2 u_smoke_size;
varying vec2 v_uv;
#if defined(UPSAMPLE_BILATERAL) && defined(SCENE_DEPTH)
uniform float u_depth_falloff;  // the relative distance difference at which a texel weighs 0
#endif

vec4 upsampled(vec2 uv)
{
#if defined(UPSAMPLE_NEAREST)
    return texture2D(u_smoke, (floor(uv * u_smoke_size) + 0.5) / u_smoke_size);
#elif !(defined(UPSAMPLE_BILATERAL) && defined(SCENE_DEPTH))
    return texture2D(u_smoke, uv);  // bilinear (and bilateral with no scene to follow)
#else
    // Joint bilateral upsampling: the four buffer texels around the pixel, each weighted by its
    // bilinear weight times how near its scene distance is to the pixel's (a linear falloff),
    // so a texel across an object's edge from the pixel counts for little; where the four agree
    // in distance it is the bilinear filter.
    float here = scene_distance(uv);
    vec2 position = uv * u_smoke_size - 0.5;  // in buffer texels, from the first texel's centre
    vec2 base = floor(position);
    vec2 f = position - base;
    vec4 sum = vec4(0.0);
    float total = 0.0;
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            vec2 texel = base + vec2(float(i), float(j));
            vec2 centre = (texel + 0.5) / u_smoke_size;
            float bilinear = (i == 0 ? 1.0 - f.x : f.x) * (j == 0 ? 1.0 - f.y : f.y);
            float there = scene_distance(centre);
            float similar = max(1.0 - abs(there - here) / (u_depth_falloff * here), 0.0);
            float w = bilinear * similar + 1e-5 * bilinear;
            sum += w * texture2D(u_smoke, centre);
            total += w;
        }
    }
    return sum / total;
#endif
}

void main()
{
    vec4 picture = texture2D(u_image, v_uv);
    vec4 smoke = upsampled(v_uv);
#ifdef ADDITIVE
    gl_FragColor = vec4(picture.rgb + smoke.rgb, 1.0);
#else
    gl_FragColor = vec4(smoke.rgb + picture.rgb * (1.0 - smoke.a), 1.0);
#endif
}
