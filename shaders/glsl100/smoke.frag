#version 100
// The smoke's passes, as the Mali sample's: particles leave an emitter that flies in a circle,
// are carried by the air (lib/flow.glsl: ideal flow around a moving sphere plus curl noise,
// divergence-free), live a random lifetime and are emitted again. Inertial particles relax
// towards the air with time constant tau (Stokes drag) under buoyancy g:
//   ACCELERATION  a = (u_air(x, t) - v) / tau + g
//   VELOCITY      v' = v + a phi,                 phi = tau (1 - exp(-dt / tau))
//   POSITION      x' = x + v dt + a tau (dt - phi)
// the exact solution over the step for the air seen at the step's start, so any tau > 0 is
// stable (for tau << dt the particle follows the air, v' -> u_air + g tau). phi and tau (dt - phi)
// come as the uniform u_relax, computed in float64 (twins/smoke.py, relaxation): in float32,
// tau (dt - phi) cancels to noise once tau / dt passes ~100. TRACER (tau = 0):
// the position pass alone reads the air itself, x' = x + u_air(x + u_air(x, t) dt / 2, t + dt / 2) dt
// (the midpoint rule), and velocity and acceleration are not computed at all. LIFE: the exact step
// clock of lib/life.glsl. A particle that ends inside the sphere (a step's chord across a curved
// streamline) is put back on its surface; one that leaves the position range is put back at the
// emitter (keeping its velocity and the rest of its life: the life clock does not see it).
// Uniforms, declared by the graph from the scene (scenes/smoke.py): u_dt, u_tau, u_relax,
// u_gravity, u_wind, u_noise (amplitude, spatial frequency, ramp distance, drift with the wind),
// u_sphere_radius, u_sphere_drift, lib/motion.glsl's u_motion_* (the sphere's rest centre is
// the motion's offset, its sway the motion's), u_emitter (centre, orbit radius),
// u_emission (orbit period, spawn radius), u_lifetime. numpy twin: es2particles/twins/smoke.py.
// sin and cos of the orbit (and the sway's, in lib/motion.glsl) are lib/trig.glsl's: NVIDIA's built-ins are up to 9.7e-6
// off float64 for |x| <= 100 (an H200, driver 580), ~80 times the error the air's bound carries.
#include "lib/life.glsl"
#include "lib/flow.glsl"
#include "lib/trig.glsl"
#include "lib/motion.glsl"

const float TAU = 6.2831853;

// The sphere's centre at time t (xyz) and its velocity (out): the scene's motion (its sway about
// the rest centre, u_motion_offset), plus u_sphere_drift, the rest centre's own velocity while a
// hand drags it (live views and the page; zero otherwise).
vec3 sphere_centre(float t, out vec3 velocity)
{
    Pose pose = motion_pose(t);
    velocity = pose.velocity + u_sphere_drift;
    return pose.centre;
}

vec3 air(vec3 x, float t)
{
    vec3 v_sphere;
    vec3 c = sphere_centre(t, v_sphere);
    // Frozen turbulence: the noise pattern drifts with the wind. The noise repeats every 289
    // lattice cells (skewed space), so the offset is wrapped into +-144.5 cells there and stays
    // small in float32.
    vec3 offset = -u_noise.y * u_noise.w * u_wind * t;
    vec3 skewed = offset + dot(offset, vec3(1.0 / 3.0));
    skewed -= 289.0 * floor(skewed / 289.0 + 0.5);
    offset = skewed - dot(skewed, vec3(1.0 / 6.0));
    return air_velocity(x, c, u_sphere_radius, u_wind, v_sphere, u_noise, offset);
}

vec3 emitter_at(float t)
{
    vec2 sc = trig_sin_cos(TAU / u_emission.x * t);
    return u_emitter.xyz + u_emitter.w * vec3(sc.y, 0.0, sc.x);
}

// A new particle's place: uniform in a ball of the spawn radius around the emitter.
vec3 spawn(vec2 uv, float t)
{
    vec4 r = life_random(uv);
    float z = 2.0 * r.x - 1.0;
    float azimuth = TAU * r.y;
    vec3 direction = vec3(sqrt(max(1.0 - z * z, 0.0)) * vec2(cos(azimuth), sin(azimuth)), z);
    return emitter_at(t) + u_emission.y * pow(r.z, 1.0 / 3.0) * direction;
}

// Outside the sphere of time t, and inside the position range (else emitted again).
vec3 outside_sphere(vec3 x, float t)
{
    vec3 v_sphere;
    vec3 d = x - sphere_centre(t, v_sphere);
    float r = length(d);
    return r < u_sphere_radius && r > 0.0 ? x + d * (u_sphere_radius / r - 1.0) : x;
}

#ifdef WRITE_POSITION
bool in_range(vec3 x)  // (only the position pass knows the range)
{
    vec3 hi = u_position_lo.xyz + u_position_span.xyz;
    return all(greaterThanEqual(x, u_position_lo.xyz)) && all(lessThanEqual(x, hi));
}
#endif

void main()
{
    float t = u_step * u_dt;  // the step's start
#if defined(WRITE_ACCELERATION)
    write_acceleration((air(read_position(v_uv), t) - read_velocity(v_uv)) / u_tau + u_gravity);
#elif defined(WRITE_LIFE)
    vec2 life = read_life(v_uv);
    vec2 aged = life + vec2(u_dt, 0.0);
    if (life_emits(life, aged, u_dt)) {
        aged = vec2(0.0, mix(u_lifetime.x, u_lifetime.y, life_random(v_uv).w));
    }
    write_life(aged);
#else
    vec2 life = read_life(v_uv);
    bool emits = life_emits(life, life + vec2(u_dt, 0.0), u_dt);
#  if defined(WRITE_VELOCITY)
    vec3 v = read_velocity(v_uv);
    write_velocity(emits ? u_wind : v + read_acceleration(v_uv) * u_relax.x);
#  else
    vec3 x = read_position(v_uv);
    if (!emits && life_alive(life)) {
#    ifdef TRACER
        vec3 middle = x + air(x, t) * (0.5 * u_dt);
        x += air(middle, t + 0.5 * u_dt) * u_dt;
#    else
        x += read_velocity(v_uv) * u_dt + read_acceleration(v_uv) * u_relax.y;
#    endif
        x = outside_sphere(x, t + u_dt);
    }
    write_position(emits || !in_range(x) ? spawn(v_uv, t) : x);
#  endif
#endif
}
