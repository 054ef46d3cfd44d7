#version 100
// The fountain's passes, as the JOGL chapter's: particles leave an emitter on the floor with a
// random azimuth, a horizontal and a vertical speed from their ranges, fly parabolas under
// gravity (and drag, integrated exactly), fade with age, and die at their lifetime or through the
// floor (FLOOR_KILL: re-emitted at once, as the seed) or bounce off it. One file, three passes
// (WRITE_VELOCITY, WRITE_POSITION, WRITE_LIFE) computing the same particle, as collision.frag.
// Uniforms, declared by the graph from the scene (scenes/fountain.py): u_dt, u_gravity (vec3),
// u_drag, u_bounce, u_max_speed, u_lifetime; the point emitters' u_emitters and u_speed are
// lib/emitters.glsl's, which launches each particle from one of them.
// numpy twin: es2particles/twins/fountain.py.
#include "lib/life.glsl"
#include "lib/drag.glsl"
#include "lib/emitters.glsl"

struct Particle {
    vec3 x;
    vec3 v;
    vec2 life;
};

Particle emit(vec2 uv)
{
    vec4 r = life_random(uv);
    Particle p;
    p.v = emitter_launch(uv, r, p.x);
    p.life = vec2(0.0, mix(u_lifetime.x, u_lifetime.y, r.w));
    return p;
}

Particle particle_step(vec3 x, vec3 v, vec2 life, vec2 uv)
{
    if (!(finite(x) && finite(v) && finite(life))) {
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
        vec2 drag = exact_drag(u_drag, u_dt);
        p.v = clamp(p.v * drag.x + u_gravity * drag.y, -u_max_speed, u_max_speed);
        p.x += p.v * u_dt;
        // Out of the position range (beyond the floor's edge, above the top) a write would clamp
        // it onto an invisible wall: it dies and is re-emitted, as through the floor.
        vec3 hi = u_position_lo.xyz + u_position_span.xyz;
        if (p.x.x < u_position_lo.x || p.x.z < u_position_lo.z || p.x.x > hi.x || p.x.y > hi.y
                || p.x.z > hi.z) {
            return emit(uv);
        }
        if (p.x.y < 0.0) {
#ifdef FLOOR_KILL
            return emit(uv);
#else
            // Met the floor within the step: back onto it, rising with the bounce's share of
            // the speed it had there (the speed gained falling the depth below it is taken
            // off: v^2 + 2 g depth, g < 0), so a bounce never gives energy and a particle at
            // rest stays at rest. numpy twin: twins/fountain.py.
            float depth = -p.x.y;
            p.x.y = 0.0;
            p.v.y = u_bounce * sqrt(max(p.v.y * p.v.y + 2.0 * u_gravity.y * depth, 0.0));
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
