// One particle life cycle, shared by the scenes that emit particles. A particle's life is the
// 2-component quantity (age, lifetime): age < 0 is not yet born (births are staggered at the
// start), 0 <= age < lifetime is alive, age >= lifetime is dead. Each step ages it by dt; a
// particle that is born or dies during the step is (re-)emitted, with randomness from a hash of
// its texel and the step number, computed alike in every pass of the scene, so passes that
// write different quantities agree without extra state. numpy twin: es2particles/life.py.
#include "lib/hash.glsl"

bool life_alive(vec2 life)
{
    return life.x >= 0.0 && life.x < life.y;
}

// Four numbers in [0, 1) for this particle and step (the emission's randomness).
vec4 life_random(vec2 uv)
{
    vec2 texel = floor(uv * u_state_size);
    return hash44(vec4(texel, mod(u_step, 4096.0), floor(u_step / 4096.0)));
}

// True where a particle of last step's ``life`` is born or dies during a step that ages it to
// ``aged``: such a particle is emitted now.
bool life_emits(vec2 life, vec2 aged)
{
    bool born = life.x < 0.0 && aged.x >= 0.0;
    bool ended = life.x < life.y && aged.x >= life.y;
    return born || ended;
}

// Fade with age: 1 at birth, 0 at the end of life.
float life_fade(vec2 life)
{
    return clamp(1.0 - life.x / max(life.y, 1e-6), 0.0, 1.0);
}
