// A sprite's size factor, the same in the image (sprites/sprite.vert) and in the shadow map
// (sprites/shadow.vert), so a particle's shadow has its sprite's footprint: a per-particle spread
// of +-spread from a hash of its texel (random sizes, as the JOGL seed) and its growth with age
// (lib/life.glsl, GROWTH). The pixel size is this times the size at distance 1 over the
// particle's distance from the eye (or the light).
#include "lib/life.glsl"

float sprite_scale(vec2 texel, vec2 life, float spread)
{
    float random = hash44(vec4(floor(texel * u_state_size), 11.0, 13.0)).x;
    return mix(1.0 - spread, 1.0 + spread, random) * life_growth(life);
}
