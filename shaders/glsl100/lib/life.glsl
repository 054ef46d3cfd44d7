// One particle life cycle, shared by the scenes that emit particles. A particle's life is the
// 2-component quantity (age, lifetime): age < 0 is not yet born (births are staggered at the
// start), 0 <= age < lifetime is alive, age >= lifetime is dead. It is kept in RGBA8 over a range
// where one step is one code, so the clock is exact (es2particles/twins/life.py). Each step ages
// it by dt; a
// particle that is born or dies during the step is (re-)emitted, with randomness from a hash of
// its texel and the step number, computed alike in every pass of the scene, so passes that
// write different quantities agree without extra state. numpy twin: es2particles/life.py.
#include "lib/hash.glsl"
// step_hash (the generated interface has it in already)
#include "lib/state.glsl"

// False for NaN (every comparison with NaN fails) and for +-Inf: non-finite state (only float
// formats can hold it) is caught by the emitting scenes' steps and the particle re-emitted.
bool finite(vec2 a)
{
    return abs(a.x) < 1e30 && abs(a.y) < 1e30;
}

bool finite(vec3 a)
{
    return abs(a.x) < 1e30 && abs(a.y) < 1e30 && abs(a.z) < 1e30;
}

bool life_alive(vec2 life)
{
    return life.x >= 0.0 && life.x < life.y;
}

// Four numbers in [0, 1) for this particle and step (the emission's randomness).
vec4 life_random(vec2 uv)
{
    return step_hash(floor(uv * u_state_size), 0.0);
}

// True where a particle of last step's ``life`` is born or dies during the step of length dt
// that ages it to ``aged``: such a particle is emitted now. Ages and lifetimes are whole steps,
// so each test sits half a step from the grid: float32 decodes of one step count can differ in
// the last bit, and an exact comparison then skipped an emission for good.
bool life_emits(vec2 life, vec2 aged, float dt)
{
    float half_step = 0.5 * dt;
    bool born = life.x < -half_step && aged.x > -half_step;
    bool ended = life.x < life.y - half_step && aged.x > life.y - half_step;
    return born || ended;
}

// How much of its life a particle has lived: 0 at birth, 1 at the end.
float life_share(vec2 life)
{
    return clamp(life.x / max(life.y, 1e-6), 0.0, 1.0);
}

// Fade with age: 1 at birth, 0 at the end of life.
float life_fade(vec2 life)
{
    return 1.0 - life_share(life);
}

#ifdef GROWTH
uniform float u_growth;

// A sprite's size factor with age: 1 at birth, u_growth at the end of life (smoke puffs spread).
float life_growth(vec2 life)
{
    return mix(1.0, u_growth, life_share(life));
}
#else
float life_growth(vec2 life)
{
    return 1.0;
}
#endif
