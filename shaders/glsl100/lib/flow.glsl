// The smoke scene's air: u_air(x) = sphere_flow + amplitude * curl_noise, both exactly
// divergence-free, so the air neither gathers nor thins the smoke; and neither carries air
// through the sphere (the normal velocity at its surface is the sphere's own).
// - sphere_flow: ideal (potential) flow of air moving at `wind` far away around a sphere moving
//   at V, u = wind + grad[R^3 / (2 r^3) (wind - V).(x - c)]: the dipole is harmonic, and at r = R
//   the normal velocity is V.n. (The Mali sample's source potential phi = -a ln(r + e) is not
//   harmonic in 3D: its Laplacian is a / (r + e)^2 - 2a / (r (r + e)), so its flow has
//   divergence; the dipole is the exact potential flow around a moving sphere.)
// - curl_noise: Bridson's curl noise (2007), the curl of a vector potential psi of three simplex
//   noises whose tangential part is ramped down near the sphere, so at its surface the noise has
//   no normal component.
// Functions of their parameters, no uniforms of their own (smoke.frag passes its own).
// numpy twin: es2particles/twins/flow.py, float64, line for line.
#include "lib/noise.glsl"

// Where psi's 2nd and 3rd noises are read, relative to the 1st: tens of cells away, so the three
// components are independent.
const vec3 PSI_OFFSET_Y = vec3(31.4, 47.2, 11.9);
const vec3 PSI_OFFSET_Z = vec3(-23.7, 13.3, 59.1);

// Ideal flow at x around the sphere (centre, radius) moving at sphere_velocity, in air moving at
// wind far away: wind + (R^3 / (2 r^3)) (a - 3 (a.n) n), a = wind - V, the closed-form gradient of
// the dipole potential. Inside the sphere: the sphere's velocity.
vec3 sphere_flow(vec3 x, vec3 centre, float radius, vec3 wind, vec3 sphere_velocity)
{
    vec3 y = x - centre;
    float r = length(y);
    if (r < radius) {
        return sphere_velocity;
    }
    vec3 n = y / r;
    vec3 a = wind - sphere_velocity;
    float q = radius / r;
    float k = 0.5 * q * q * q;  // not pow(): pow(x, 3) is exp2(3 log2 x), less exact
    return wind + k * (a - 3.0 * dot(a, n) * n);
}

// Bridson's ramp of q clamped to [0, 1]: (15/8 q - 10/8 q^3 + 3/8 q^5, its derivative
// 15/8 (1 - q^2)^2). 0 at q = 0, and 1 with zero first and second derivatives at q = 1, so the
// ramped field joins the free noise smoothly.
vec2 flow_ramp(float q)
{
    q = clamp(q, 0.0, 1.0);
    float q2 = q * q;
    float w = 1.0 - q2;
    return vec2(q * (15.0 / 8.0 - q2 * (10.0 / 8.0 - 3.0 / 8.0 * q2)), 15.0 / 8.0 * w * w);
}

// curl(psi') at x, psi = (N(s x + offset), N(s x + offset + PSI_OFFSET_Y), N(... + PSI_OFFSET_Z))
// with N the simplex noise and s = scale (spatial frequency), and psi' = alpha psi
// + (1 - alpha)(n.psi) n its tangential part ramped down over `ramp` (> 0) from the sphere:
// alpha = flow_ramp((r - R) / ramp), n = (x - c) / r. In closed form, J the Jacobian of psi
// (J_ij = d psi_i / d x_j, row i = s * gradient of noise i):
//   curl psi' = alpha curl psi + alpha' n x psi + (1 - alpha)(psi / r + J^T n) x n
// with alpha' = d alpha / dr, because curl(beta n) = grad beta x n (n is a gradient: curl n = 0)
// and grad(n.psi) = (psi - n (n.psi)) / r + J^T n. At r = R (alpha = 0) both terms are normal
// to n: no flow through the sphere. Inside it: 0.
vec3 curl_noise(vec3 x, vec3 offset, float scale, vec3 centre, float radius, float ramp)
{
    vec3 y = x - centre;
    float r = length(y);
    if (r < radius) {
        return vec3(0.0);
    }
    vec3 n = y / r;
    float width = max(ramp, 1e-6);  // a zero ramp is a step: keep 0 / 0 out
    vec2 alpha = flow_ramp((r - radius) / width);
    float alpha_slope = alpha.y / width;
    vec3 p = scale * x + offset;
    vec4 a = simplex3(p);
    vec4 b = simplex3(p + PSI_OFFSET_Y);
    vec4 c = simplex3(p + PSI_OFFSET_Z);
    vec3 psi = vec3(a.w, b.w, c.w);
    vec3 curl = scale * vec3(c.y - b.z, a.z - c.x, b.x - a.y);
    vec3 jtn = scale * (n.x * a.xyz + n.y * b.xyz + n.z * c.xyz);
    return alpha.x * curl + alpha_slope * cross(n, psi)
         + (1.0 - alpha.x) * cross(psi / r + jtn, n);
}

// The air's velocity at x: sphere_flow + amplitude * curl_noise, with
// noise = (amplitude, spatial frequency, ramp distance, unused here) and offset the noise's shift
// (a drift with the wind, say).
vec3 air_velocity(vec3 x, vec3 centre, float radius, vec3 wind, vec3 sphere_velocity, vec4 noise,
                  vec3 offset)
{
    return sphere_flow(x, centre, radius, wind, sphere_velocity)
         + noise.x * curl_noise(x, offset, noise.y, centre, radius, noise.z);
}
