#version 100
// The fountain's passes, as the JOGL chapter's: particles leave an emitter on the floor with a
// random azimuth, a horizontal and a vertical speed from their ranges, fly parabolas under
// gravity (and drag, integrated exactly), fade with age, and die at their lifetime or through the
// floor (FLOOR_KILL: re-emitted at once, as the seed) or bounce off it. One file, three passes
// (WRITE_VELOCITY, WRITE_POSITION, WRITE_LIFE) computing the same particle, as collision.frag.
// Uniforms, declared by the graph from the scene (scenes/fountain.py): u_dt, u_gravity (vec3),
// u_drag, u_bounce, u_max_speed, u_speed (horizontal min, max, vertical min, max), u_lifetime,
// u_emitters[EMITTERS] (x, y, z of each emitter; a particle's is chosen by its texel index).
// numpy twin: es2particles/twins/fountain.py.
#include "lib/life.glsl"

struct Particle {
    vec3 x;
    vec3 v;
    vec2 life;
};

vec3 emitter_of(vec2 uv)
{
    vec2 texel = floor(uv * u_state_size);
    float k = mod(texel.y * u_state_size.x + texel.x, float(EMITTERS));
    vec3 e = u_emitters[0].xyz;
    for (int i = 1; i < EMITTERS; ++i) {  // ES 1.00 fragment shaders index uniforms by constants
        if (float(i) == k) {
            e = u_emitters[i].xyz;
        }
    }
    return e;
}

Particle emit(vec2 uv)
{
    vec4 r = life_random(uv);
    float azimuth = 6.2831853 * r.x;
    float across = mix(u_speed.x, u_speed.y, r.y);
    Particle p;
    p.x = emitter_of(uv);
    p.v = vec3(cos(azimuth) * across, mix(u_speed.z, u_speed.w, r.z), sin(azimuth) * across);
    p.life = vec2(0.0, mix(u_lifetime.x, u_lifetime.y, r.w));
    return p;
}

bool finite(vec3 a)
{
    return abs(a.x) < 1e30 && abs(a.y) < 1e30 && abs(a.z) < 1e30;
}

Particle particle_step(vec3 x, vec3 v, vec2 life, vec2 uv)
{
    if (!(finite(x) && finite(v) && abs(life.x) < 1e30 && abs(life.y) < 1e30)) {
        return emit(uv);
    }
    Particle p;
    p.x = x;
    p.v = v;
    p.life = vec2(life.x + u_dt, life.y);
    if (life_emits(life, p.life, u_dt)) {
        return emit(uv);
    }
    if (life_alive(life)) {
        // Semi-implicit Euler with drag in its exact exponential form (stable for any k dt).
        float kh = u_drag * u_dt;
        float decay = exp(-kh);
        float gain = (kh < 1e-3) ? u_dt * (1.0 - 0.5 * kh) : (1.0 - decay) / u_drag;
        p.v = clamp(p.v * decay + u_gravity * gain, -u_max_speed, u_max_speed);
        p.x += p.v * u_dt;
        if (p.x.y < 0.0) {
#ifdef FLOOR_KILL
            return emit(uv);
#else
            p.x.y = -p.x.y * u_bounce;
            p.v.y = -p.v.y * u_bounce;
#endif
        }
    }
    return p;
}

void main()
{
    Particle p = particle_step(read_position(v_uv), read_velocity(v_uv), read_life(v_uv), v_uv);
#if defined(WRITE_LIFE)
    write_life(p.life);
#elif defined(WRITE_POSITION)
    write_position(p.x);
#else
    write_velocity(p.v);
#endif
}
