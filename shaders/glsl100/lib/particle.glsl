// One step of a collision-scene particle: forces, sub-stepped integration, collision response
// against the distance/normal field, lifetime and respawn. Every pass of the scene calls
// particle_step() with the same inputs, so each computes the same particle and writes its own
// part of it (ES 2.0: one render target per pass). numpy twin: es2particles/twins/particle.py.
#include "lib/state.glsl"
#include "lib/life.glsl"
#include "lib/drag.glsl"

// MAX_SUBSTEPS: the loop bound, the most sub-steps any particle of the scene can need (the
// scene computes it from its parameters and refuses those that would need more than 4096).
#ifndef MAX_SUBSTEPS
#define MAX_SUBSTEPS 256
#endif

// Its uniforms are declared by the graph from the scene's Physics (scenes/collision.py):
//   u_dt, u_emit, u_emitter (position.xy, direction, spread), u_speed and u_lifetime (ranges),
// and, for the passes that move particles (not WRITE_LIFE): u_max_speed (the velocity range,
// held at every sub-step), u_gravity, u_drag (k of v' = -k v,
// integrated exactly), u_spring (centre.xy, omega^2), u_sliding (s: 1 bounces along the normal,
// 0 slides), u_bounce (r: the speed kept on contact), u_cell (a sub-step moves at most half of
// it), u_fixed_substeps (0: each particle picks its count), the field texture u_field (RG:
// packed distance, BA: 127 normal + 127), u_field_rect (x0, y0, width, height),
// u_field_cells and u_field_range (the distance's (lo, lo, span, span)).

struct Particle {
    vec2 x;
    vec2 v;
    vec2 life;  // age, lifetime; age < 0: not yet born
};

#ifndef WRITE_LIFE  // motion: forces, collision, integration
void field_sample(vec2 p, out float d, out vec2 n)
{
    vec2 cell = clamp(floor((p - u_field_rect.xy) / u_field_rect.zw * u_field_cells),
                      vec2(0.0), u_field_cells - 1.0);
    vec4 t = texture2D(u_field, (cell + 0.5) / u_field_cells);
    // 8 bits per component leave |n| up to ~0.5% off 1, and the response scales the speed by it.
    // Components over 254 steps around 127, so 0 and +-1 are exact (see CollisionField.texels).
    n = normalize((floor(t.zw * 255.0 + 0.5) - 127.0) * (1.0 / 127.0));
    // The texel holds the distance at the cell's centre; carry it to the particle along the
    // normal (first order: exact for a flat surface). Without this a push-out could move a
    // particle up to half a cell too far, and a resting particle would gain energy.
    vec2 centre = u_field_rect.xy + (cell + 0.5) / u_field_cells * u_field_rect.zw;
    d = u_field_range.x + unpack16(t.xy) * u_field_range.z + dot(n, p - centre);
}

vec2 acceleration(vec2 x)
{
    return u_gravity + u_spring.z * (u_spring.xy - x);
}

// moved: the sub-step's move along n (negative: into the surface).
void respond(inout vec2 x, inout vec2 v, vec2 a, float d, vec2 n, float moved)
{
    float vn = dot(v, n);
    float an = dot(a, n);
    float work = 2.0 * d * an;  // the push-out's work against the acceleration, in v^2
    if (vn < 0.0) {
        // The chapter's response: v' = |v| (n s + t (1 - s)) r, t the tangent along the motion.
        // A head-on hit (v along n) has no direction to slide in: its whole speed goes back along
        // the normal, v' = |v| r n. Symmetric: a straight drop bounces straight up, and a particle
        // resting on a face stays where it is (a fixed or random turn made it slide or wander).
        float speed = length(v);
        vec2 along = v - vn * n;
        float along_length = length(along);
        if (along_length > 1e-6 * speed) {
            v = speed * (n * u_sliding + along / along_length * (1.0 - u_sliding)) * u_bounce;
        } else {
            v = speed * n * u_bounce;
        }
        // The work taken from a turned particle, over the depth its own move explains: at most
        // its normal speed's share vn^2 (a frictionless slide keeps the rest, turned along the
        // surface), less what the response took already; over any deeper part, the whole work.
        // The whole work, taken from what the response had turned along the surface, held
        // particles still on slopes (issue 45). What is left unpaid (where the work exceeds vn^2:
        // a normal speed under 2 a.n h) is at most (a.n h)^2 / 2, below the (a h)^2 / 2 the
        // sub-step's semi-implicit flight loses: a contact still adds no energy.
        float ours = max(d, min(moved, 0.0));
        work = min(2.0 * ours * an, max(vn * vn - (speed * speed - dot(v, v)), 0.0))
            + 2.0 * (d - ours) * an;
    }
    // Out of the object along the normal by the penetration depth, the work taken from the
    // kinetic energy.
    x -= d * n;
    float v2 = dot(v, v);
    if (v2 > 0.0) {
        v *= sqrt(max(v2 - work, 0.0) / v2);
    }
}

void collide(inout vec2 x, inout vec2 v, vec2 a, vec2 before)
{
    float d;
    vec2 n;
    field_sample(x, d, n);
    if (d < 0.0) {
        // Inside, yet moved along the outward normal: no particle enters through the face a
        // normal belongs to that way, so it came in through the other side of a thin wall, whose
        // cell holds the far face's normal (the one on the medial axis, or a wall whose faces sit
        // on cell centres). It leaves by the side it came from: the normal turned round, no deeper
        // than the move's part along it, which puts it back level with where it was. Sub-steps of
        // at most half a cell mean it cannot have come from further. Only a wall up to two cells
        // thick has such cells: a particle deeper than that is inside a thick object (an emitter
        // there, say), and is pushed out by its depth whichever way it moves.
        vec2 moved = x - before;
        if (dot(moved, n) > 0.0 && d > -2.0 * u_cell) {
            n = -n;
            d = dot(moved, n);
        }
        respond(x, v, a, d, n, dot(moved, n));
    }
    // Walls and floor, the edges of the scene rectangle: exact planes, so a corner holds no
    // cell whose one normal hides the other wall.
    vec2 lo = u_field_rect.xy;
    vec2 hi = u_field_rect.xy + u_field_rect.zw;
    if (x.x < lo.x) {
        respond(x, v, a, x.x - lo.x, vec2(1.0, 0.0), x.x - before.x);
    }
    if (x.x > hi.x) {
        respond(x, v, a, hi.x - x.x, vec2(-1.0, 0.0), before.x - x.x);
    }
    if (x.y < lo.y) {
        respond(x, v, a, x.y - lo.y, vec2(0.0, 1.0), x.y - before.y);
    }
    if (x.y > hi.y) {
        respond(x, v, a, hi.y - x.y, vec2(0.0, -1.0), before.y - x.y);
    }
}

void integrate(inout vec2 x, inout vec2 v)
{
    // Sub-steps: each moves at most half a field cell (no tunnelling through a wall one cell
    // thick). A spring needs one fixed count for every step (see Physics.fixed_substeps).
    float reach = (length(v) + length(acceleration(x)) * u_dt) * u_dt;
    float n = (u_fixed_substeps > 0.0) ? u_fixed_substeps : ceil(reach / (0.5 * u_cell));
    n = clamp(n, 1.0, float(MAX_SUBSTEPS));
    float h = u_dt / n;
    vec2 drag = exact_drag(u_drag, h);
    for (int i = 0; i < MAX_SUBSTEPS; ++i) {
        if (float(i) >= n) {
            break;
        }
        vec2 a = acceleration(x);
        vec2 before = x;
        // The velocity range holds at every sub-step, not only when the velocity is stored: no
        // particle is then faster than its corner, which bounds the sub-steps any can need.
        v = clamp(v * drag.x + a * drag.y, -u_max_speed, u_max_speed);
        x += v * h;
        collide(x, v, a, before);
        v = clamp(v, -u_max_speed, u_max_speed);
    }
}
#endif

Particle spawn(vec2 uv)
{
    vec4 r = life_random(uv);
    float angle = u_emitter.z + (r.x - 0.5) * u_emitter.w;
    vec2 direction = vec2(cos(angle), sin(angle));
    // Placed as if born at a random moment within the step, so a stream leaves the emitter
    // smoothly rather than in one bunch per step; its age starts at 0 (the life clock counts
    // whole steps: see lib/life.glsl).
    float since = r.w * u_dt;
    Particle p;
    p.v = direction * mix(u_speed.x, u_speed.y, r.y);
    p.x = u_emitter.xy + p.v * since;
    p.life = vec2(0.0, mix(u_lifetime.x, u_lifetime.y, r.z));
#ifndef WRITE_LIFE
    // An emitter inside an object: the new particle leaves it at once, as a sub-step's collision
    // would move it out (it has not moved yet, so it is judged where it stands).
    collide(p.x, p.v, acceleration(p.x), p.x);
#endif
    return p;
}

Particle particle_step(vec2 x, vec2 v, vec2 life, vec2 uv)
{
    if (!(finite(x) && finite(v) && finite(life))) {
        // Non-finite state (only float formats can hold it) is contained here: the particle is
        // re-emitted, or parked dead without an emitter; it never reaches a neighbour or the
        // image. Every pass sees the same inputs, so all three agree.
        if (u_emit > 0.5) {
            return spawn(uv);
        }
        Particle parked;
        parked.x = u_emitter.xy;
        parked.v = vec2(0.0);
        parked.life = vec2(0.0);  // age >= lifetime: dead, not drawn, not re-emitted
        return parked;
    }
    Particle p;
    p.x = x;
    p.v = v;
    p.life = vec2(life.x + u_dt, life.y);
    if (life_emits(life, p.life, u_dt) && u_emit > 0.5) {
        return spawn(uv);
    }
    if (life_alive(life)) {
#ifndef WRITE_LIFE
        integrate(p.x, p.v);
#endif
    }
    return p;
}
