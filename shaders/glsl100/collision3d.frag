#version 100
// The 3D collision scene's passes, as the ARM chapter's: particles leave a disc above an object,
// fall under gravity, a constant force and Stokes friction (drag integrated exactly), with some
// randomness in flight, and bounce and slide off the object (a voxel field, lib/field3d.glsl; it
// may turn and sway) and the floor y = 0, by the chapter's response (Listing 2.3) in the frame of
// the moving surface. One file, three passes (WRITE_VELOCITY, WRITE_POSITION, WRITE_LIFE), each
// computing the same particle (the life pass too: a particle that leaves the position range dies
// and is emitted again, which it learns only by moving). numpy twin: es2particles/twins/collision3d.py.
// Uniforms (scenes/collision3d.py): u_dt, u_lifetime, u_emitter (point, disc radius), u_launch
// (velocity, its random spread across), u_gravity (gravity plus force /
// mass), u_drag (6 pi eta r / m), u_jitter (random acceleration, per sqrt(s)), u_max_speed,
// u_sliding, u_bounce, u_substep (the longest sub-step move, world units), u_surface_speed (the
// fastest the object's surface moves), lib/field3d.glsl's and lib/motion.glsl's (the object's pose).
// ORIENTED (the confetti, scenes/confetti.py): a fourth quantity, normal, the octahedral unit
// vector a particle's quad faces (lib/octahedral.glsl), and its pass WRITE_NORMAL: drawn at
// random at birth, set to the normal of the last surface touched in a step (the object's, turned
// with it, or the floor's), else turning at u_tumble radians a second about an axis of its own.
#include "lib/life.glsl"
#include "lib/drag.glsl"

// MAX_SUBSTEPS: the most sub-steps any particle can need (the scene computes it).
#ifndef MAX_SUBSTEPS
#define MAX_SUBSTEPS 64
#endif

struct Particle {
    vec3 x;
    vec3 v;
    vec2 life;
    vec3 n;  // ORIENTED: the way its quad faces
};

// The normal of the last surface a sub-step touched this step (zero: none).
vec3 touched;

// Four more numbers in [0, 1) per particle and step (life_random's are the emission's).
vec4 flight_random(vec2 uv)
{
    return step_hash(floor(uv * u_state_size), 53.0);
}

#include "lib/field3d.glsl"
#include "lib/motion.glsl"
#include "lib/trig.glsl"
#include "lib/sequence.glsl"

// A unit tangent of n at the angle 2 pi turn.
vec3 random_tangent(vec3 n, float turn)
{
    vec3 side = normalize(cross(n, abs(n.y) < 0.99 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0)));
    float angle = 6.2831853 * turn;
    return side * cos(angle) + cross(n, side) * sin(angle);
}

// The chapter's response, v' = |v| (n s + t (1 - s)) r, in the frame of the surface (v is the
// velocity relative to it). Unlike Listing 2.3, whose t = cross(n, v) turns a particle sideways,
// t is the tangent along the motion (a particle slides on the way it was going), or a random one
// where v is along n (the chapter's getRandomTangentDir). Then out along n by the depth d < 0,
// the push-out's work against the acceleration taken from the kinetic energy; from a turned
// particle, over the depth its own move explains (``moved``: the sub-step's move along n), at
// most its normal speed's share vn^2 (a frictionless slide keeps the rest, turned along the
// surface) less what the response took already: the whole work, taken from what the response
// had turned along the surface, held particles still on slopes (issue 45). What is left unpaid
// is at most (a.n h)^2 / 2, below what the sub-step's semi-implicit flight loses.
void respond(inout vec3 x, inout vec3 v, vec3 a, float d, vec3 n, float turn, float moved)
{
    float vn = dot(v, n);
    float an = dot(a, n);
    float work = 2.0 * d * an;
    if (vn < 0.0) {
        float speed = length(v);
        vec3 along = v - vn * n;
        float along_length = length(along);
        vec3 t = along_length > 1e-6 * speed ? along / along_length : random_tangent(n, turn);
        v = speed * (n * u_sliding + t * (1.0 - u_sliding)) * u_bounce;
        // Over the depth its own move explains: at most the normal speed's share vn^2, less
        // what the response took already; over any deeper part, the whole work
        float ours = max(d, min(moved, 0.0));
        work = min(2.0 * ours * an, max(vn * vn - (speed * speed - dot(v, v)), 0.0))
            + 2.0 * (d - ours) * an;
    }
    x -= d * n;
    float v2 = dot(v, v);
    if (v2 > 0.0) {
        v *= sqrt(max(v2 - work, 0.0) / v2);
    }
}

// Collision with the object (at pose) and the floor after a sub-step that started at object-space
// point q_before. A particle inside that moved along the outward normal (in object space), from
// where the surface faces the other way, came through the far side of a thin wall: it leaves by
// the side it came from (see collide() in lib/particle.glsl); sub-steps move at most half a voxel
// relative to the object.
void collide(inout vec3 x, inout vec3 v, vec3 a, vec3 q_before, vec3 x_before, Pose pose,
             float turn)
{
    vec3 q = motion_unplace(x, pose);
    float d;
    vec3 n;
    field_sample(q, d, n);
    if (d < 0.0) {
        // Only from a quarter voxel deep: a particle that came through the far side of a wall
        // reads at least half a voxel of depth there (walls are a voxel thick or more, sub-steps
        // at most half a voxel), where a sliding one barely inside reads less; turned round, it
        // would be pushed in.
        // And only where the surface it came from faces away from this one: by a fast-spinning
        // object's leading edge, a particle the face pushes slides round the corner relative to
        // the object, along the next face's normal, and turned round it would be pushed deeper
        // (433-597 particle-steps deeper than a voxel a run at 3600 degrees/s; none now).
        vec3 moved = q - q_before;
        if (dot(moved, n) > 0.0 && d > -2.0 * u_voxel && d < -0.25 * u_voxel) {
            float d_before;
            vec3 n_before;
            field_sample(q_before, d_before, n_before);
            if (dot(n_before, n) < 0.0) {
                n = -n;
                d = dot(moved, n);
            }
        }
        vec3 surface = motion_surface_velocity(x, pose);
        vec3 relative = v - surface;
        vec3 world = motion_turn(n, pose);
        respond(x, relative, a, d * u_motion_pivot.w, world, turn,
                dot(q - q_before, n) * u_motion_pivot.w);
        v = relative + surface;
        touched = world;
    }
    if (x.y < 0.0) {
        respond(x, v, a, x.y, vec3(0.0, 1.0, 0.0), turn, x.y - x_before.y);
        touched = vec3(0.0, 1.0, 0.0);
    }
}

void integrate(inout vec3 x, inout vec3 v, vec4 r)
{
    // Randomness in flight: a random kick of u_jitter sqrt(dt) per step (a random walk of the
    // velocity, the same spread whatever dt).
    v += u_jitter * sqrt(u_dt) * (2.0 * r.yzw - 1.0);
    // Sub-steps: each moves at most u_substep (half a voxel) relative to the object's surface.
    float reach = (length(v) + length(u_gravity) * u_dt + u_surface_speed) * u_dt;
    float n = clamp(ceil(reach / u_substep), 1.0, float(MAX_SUBSTEPS));
    float h = u_dt / n;
    vec2 drag = exact_drag(u_drag, h);
    float t0 = u_step * u_dt;
    vec3 q_before = motion_unplace(x, motion_pose(t0));
    for (int i = 0; i < MAX_SUBSTEPS; ++i) {
        if (float(i) >= n) {
            break;
        }
        Pose pose = motion_pose(t0 + (float(i) + 1.0) * h);
        v = clamp(v * drag.x + u_gravity * drag.y, -u_max_speed, u_max_speed);
        vec3 x0 = x;
        x += v * h;
        collide(x, v, u_gravity, q_before, x0, pose, r.x);
        v = clamp(v, -u_max_speed, u_max_speed);
        q_before = motion_unplace(x, pose);
    }
}

Particle emit(vec2 uv)
{
    vec4 r = life_random(uv);
    vec4 s = step_hash(floor(uv * u_state_size), 71.0);
    float angle = 6.2831853 * r.x;
    float radius = u_emitter.w * sqrt(r.y);
    Particle p;
    p.x = u_emitter.xyz + radius * vec3(cos(angle), 0.0, sin(angle));
    float across = 6.2831853 * r.z;
    p.v = u_launch.xyz + u_launch.w * r.w * vec3(cos(across), 0.0, sin(across));
    p.life = vec2(0.0, mix(u_lifetime.x, u_lifetime.y, s.x));
    // A random facing, uniform on the sphere (trig.glsl's sin and cos: a browser's built-in
    // ones may be 2^-11 off, and the facing is stored to 16 bits).
    float z = 2.0 * s.y - 1.0;
    vec2 around = trig_sin_cos(6.2831853 * s.z);
    p.n = vec3(sqrt(max(1.0 - z * z, 0.0)) * around.yx, z);
    return p;
}

#ifdef ORIENTED
// The facing after a step in flight: turned by u_tumble dt about an axis across it, fixed for
// the particle (from its texel), so each tumbles end over end at its own angle.
vec3 tumble(vec3 n, vec2 uv)
{
    vec3 r = particle_sequence(uv);
    vec2 around = trig_sin_cos(6.2831853 * r.x);
    float z = 2.0 * r.y - 1.0;
    vec3 random = vec3(sqrt(max(1.0 - z * z, 0.0)) * around.yx, z);
    vec3 across = cross(n, random);
    vec3 axis = dot(across, across) > 1e-12 ? normalize(across)
        : normalize(cross(n, abs(n.y) < 0.99 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0)));
    vec2 turn = trig_sin_cos(u_tumble * u_dt);
    return normalize(n * turn.y + cross(axis, n) * turn.x);
}
#endif

Particle particle_step(vec3 x, vec3 v, vec2 life, vec3 n, vec2 uv)
{
    if (!(finite(x) && finite(v) && finite(life))) {
        return emit(uv);
    }
    Particle p;
    p.x = x;
    p.v = v;
    p.life = vec2(life.x + u_dt, life.y);
    p.n = n;
    if (life_emits(life, p.life, u_dt)) {
        return emit(uv);
    }
    if (life_alive(life)) {
        touched = vec3(0.0);
        integrate(p.x, p.v, flight_random(uv));
#ifdef ORIENTED
        p.n = dot(touched, touched) > 0.0 ? touched : tumble(n, uv);
#endif
        // Out of the position range (past the floor's edge, above the top) a write would clamp
        // it onto an invisible wall: it dies and is emitted again.
        vec3 hi = u_position_lo.xyz + u_position_span.xyz;
        if (any(lessThan(p.x, u_position_lo.xyz)) || any(greaterThan(p.x, hi))) {
            return emit(uv);
        }
    }
    return p;
}

void main()
{
#ifdef ORIENTED
    vec3 n = octahedral_decode(read_normal(v_uv));
#else
    vec3 n = vec3(0.0, 1.0, 0.0);
#endif
    Particle p = particle_step(read_position(v_uv), read_velocity(v_uv), read_life(v_uv), n,
                               v_uv);
#if defined(WRITE_LIFE)
    write_life(p.life);
#elif defined(WRITE_POSITION)
    write_position(p.x);
#elif defined(WRITE_NORMAL)
    write_normal(octahedral_encode(p.n));
#else
    write_velocity(p.v);
#endif
}
