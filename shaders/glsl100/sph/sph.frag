#version 100
// Weakly compressible SPH (es2particles/scenes/sph.py), 2D or 3D (SPH_3D), SI units, one define a
// pass:
// - DENSITY: rho_i = sum_j m W(r_ij), itself included (the Wendland C2 kernel, support 2h);
// - ACCELERATION: the velocity after dt of
//     a_i = g - sum_j m (p_i / rho_i^2 + p_j / rho_j^2 + Pi_ij) grad W(r_ij),
//   p = max(B ((rho / rho0)^7 - 1), 0) (Tait, without tension), Pi_ij Monaghan's artificial viscosity for approaching
//   pairs; a wall within the box's edge turns the velocity's normal part back by u_restitution;
//   u_gravity and u_box have a component a dimension;
// - POSITION: x + dt v, held in the box.

const float PI = 3.141592653589793;
#ifdef SPH_3D
#define VEC vec3
// Wendland C2 in 3D: 21 / (16 pi h^3), and its slope's -105 / (16 pi h^4)
#define KERNEL_NORM (21.0 / (16.0 * PI * u_h * u_h * u_h))
#define SLOPE_NORM (-105.0 / (16.0 * PI * u_h * u_h * u_h * u_h))
#else
#define VEC vec2
#define KERNEL_NORM (7.0 / (4.0 * PI * u_h * u_h))
#define SLOPE_NORM (-35.0 / (4.0 * PI * u_h * u_h * u_h))
#endif

#ifdef NEIGHBOUR_BOUND
// Wendland C2, support 2h: W(q) = KERNEL_NORM (1 - q/2)^4 (2q + 1), q = r / h (2D: 7 / (4 pi h^2)).
float kernel(float r)
{
    float q = r / u_h;
    if (q >= 2.0) {
        return 0.0;
    }
    float t = 1.0 - 0.5 * q;
    return KERNEL_NORM * t * t * t * t * (2.0 * q + 1.0);
}

// dW/dr: SLOPE_NORM q (1 - q/2)^3 (2D: -35 / (4 pi h^3)).
float kernel_slope(float r)
{
    float q = r / u_h;
    if (q >= 2.0) {
        return 0.0;
    }
    float t = 1.0 - 0.5 * q;
    return SLOPE_NORM * q * t * t * t;
}

#endif

#ifdef ACCELERATION
float pressure(float rho)
{
    float s = rho / u_fluid.x;
    float s2 = s * s;
    return max(u_fluid.y * (s2 * s2 * s2 * s - 1.0), 0.0);  // no tension: see sph.py
}
#endif

void main()
{
    VEC x = read_position(v_uv);
#ifdef DENSITY
    float rho = 0.0;
    vec2 other;
    FOR_EACH_NEIGHBOUR(x, other) {
        rho += u_mass * kernel(length(read_position(other) - x));
    }
    write_rho(rho);
#endif
#ifdef ACCELERATION
    VEC v = read_velocity(v_uv);
    float rho = read_rho(v_uv);
    float own = pressure(rho) / (rho * rho);
    VEC a = u_gravity;
    vec2 other;
    FOR_EACH_NEIGHBOUR(x, other) {
        VEC d = x - read_position(other);  // from j to i
        float r = length(d);
        if (r > 0.0 && r < 2.0 * u_h && neighbour_other(other)) {
            float rho_j = read_rho(other);
            float term = own + pressure(rho_j) / (rho_j * rho_j);
            float approach = dot(v - read_velocity(other), d);
            if (approach < 0.0) {  // Monaghan: -alpha c0 h mu / mean rho
                float mu = u_h * approach / (r * r + 0.01 * u_h * u_h);
                term -= u_viscosity * u_fluid.z * mu / (0.5 * (rho + rho_j));
            }
            a -= u_mass * term * kernel_slope(r) * d / r;
        }
    }
    v += u_dt * a;
    // walls: a particle at or beyond an edge, moving out, turns back
    if ((x.x <= 0.0 && v.x < 0.0) || (x.x >= u_box.x && v.x > 0.0)) {
        v.x *= -u_restitution;
    }
    if ((x.y <= 0.0 && v.y < 0.0) || (x.y >= u_box.y && v.y > 0.0)) {
        v.y *= -u_restitution;
    }
#ifdef SPH_3D
    if ((x.z <= 0.0 && v.z < 0.0) || (x.z >= u_box.z && v.z > 0.0)) {
        v.z *= -u_restitution;
    }
#endif
    write_velocity(v);
#endif
#ifdef POSITION
    write_position(clamp(x + u_dt * read_velocity(v_uv), VEC(0.0), u_box));
#endif
}
