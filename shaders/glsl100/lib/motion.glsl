// A moving object's rigid motion (es2particles/frame/motion.py: Motion), the one place it is
// written; numpy twin: es2particles/twins/motion.py. t seconds after the start, a point p of the
// rest pose is at
//
//     centre + R(axis, rate t) scale (p - pivot),   centre = pivot + offset + sway sin(2 pi t / period)
//
// and the centre moves at sway (2 pi / period) cos(2 pi t / period) (no sway where period is 0).
// Uniforms (Motion.uniforms; a pass's are declared by the graph, a stage declares its own):
// u_motion_pivot (pivot xyz, scale), u_motion_spin (unit axis, rate in rad/s), u_motion_sway
// (amplitude xyz, period in s), u_motion_offset (the rest offset, plus a hand's drag in a live
// view or the page). sin and cos are lib/trig.glsl's: the same on every driver (NVIDIA's
// built-ins are up to 9.7e-6 off float64 within +-100).
#include "lib/trig.glsl"

struct Pose {
    vec3 centre;    // where the pivot is
    vec2 turn;      // (sin, cos) of the angle turned about u_motion_spin.xyz
    vec3 velocity;  // of the pivot
};

Pose motion_pose(float t)
{
    Pose pose;
    pose.centre = u_motion_pivot.xyz + u_motion_offset;
    pose.velocity = vec3(0.0);
    if (u_motion_sway.w > 0.0) {
        float w = 6.2831853 / u_motion_sway.w;
        vec2 sc = trig_sin_cos(w * t);
        pose.centre += u_motion_sway.xyz * sc.x;
        pose.velocity = u_motion_sway.xyz * w * sc.y;
    }
    pose.turn = trig_sin_cos(u_motion_spin.w * t);
    return pose;
}

// v turned by the angle whose (sin, cos) is sc about the unit axis k (Rodrigues).
vec3 motion_rotate(vec3 v, vec3 k, vec2 sc)
{
    return v * sc.y + cross(k, v) * sc.x + k * dot(k, v) * (1.0 - sc.y);
}

// A direction of the rest pose turned as the object is.
vec3 motion_turn(vec3 v, Pose pose)
{
    return motion_rotate(v, u_motion_spin.xyz, pose.turn);
}

// A point of the rest pose where the motion puts it.
vec3 motion_place(vec3 p, Pose pose)
{
    return pose.centre + motion_turn((p - u_motion_pivot.xyz) * u_motion_pivot.w, pose);
}

// A world point in the object's own frame: about the pivot, unturned and unscaled.
vec3 motion_unplace(vec3 x, Pose pose)
{
    return motion_rotate(x - pose.centre, u_motion_spin.xyz, pose.turn * vec2(-1.0, 1.0))
        / u_motion_pivot.w;
}

// The velocity of the object's surface at world point x.
vec3 motion_surface_velocity(vec3 x, Pose pose)
{
    return pose.velocity + cross(u_motion_spin.xyz * u_motion_spin.w, x - pose.centre);
}
