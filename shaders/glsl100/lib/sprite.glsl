// A sprite's size factor, the same in the image (sprites/sprite.vert) and in the shadow map
// (sprites/shadow.vert), so a particle's shadow has its sprite's footprint: a per-particle spread
// of +-spread from a hash of its texel (random sizes, as the JOGL seed) and its growth with age
// (lib/life.glsl, GROWTH). The pixel size is this times the size at distance 1 over the
// particle's distance from the eye (or the light).
// FADE: the particle's life clock, read_life(); without it, alive at age 0 forever. SIZE: the
// particle's own size factor, read_size_factor() (a size role).
#include "lib/life.glsl"

vec2 sprite_life(vec2 texel)
{
#ifdef FADE
    return read_life(texel);
#else
    return vec2(0.0, 1.0);
#endif
}

float sprite_scale(vec2 texel, vec2 life, float spread)
{
    float random = hash44(vec4(floor(texel * u_state_size), 11.0, 13.0)).x;
    float scale = mix(1.0 - spread, 1.0 + spread, random) * life_growth(life);
#ifdef SIZE
    scale *= read_size_factor(texel);
#endif
    return scale;
}
