#version 100
// The liquid (es2particles/scenes/liquid.py): Clavet, Beaudoin and Poulin 2005's step in gather form,
// one define a pass. Lengths are in world units, h = u_h; time in steps of u_dt.
// - VISCOSITY: v + dt g, less half of each pairwise viscosity impulse
//   I = dt (1 - q)(sigma u + beta u^2) r_ij over the neighbours moving toward it (u > 0);
// - PREDICT: x + dt v;
// - DENSITY: rho = sum (1 - q)^2, rho_near = sum (1 - q)^3 over the others within h of the
//   predicted position;
// - RELAX: the double density relaxation: each pair moves i by
//   -dt^2 / 2 [(P_i + P_j)(1 - q) + (Pn_i + Pn_j)(1 - q)^2] r_ij, with P = k (rho - rho0),
//   Pn = k_near rho_near (the sequential loop's two half displacements, summed by i), times
//   u_share: every particle moves at once here, and the whole sum overshoots (see liquid.py);
//   then the walls and the obstacle circle push it back inside;
// - VELOCITY: the velocity from the position change, v + (x - x_predicted) / dt.

void main()
{
#ifdef VISCOSITY
    vec2 x = read_position(v_uv);
    vec2 v = read_velocity(v_uv);
    vec2 impulse = vec2(0.0);
    vec2 other;
    FOR_EACH_NEIGHBOUR(x, other) {
        vec2 d = read_position(other) - x;
        float r = length(d);
        if (r < u_h && r > 0.0 && neighbour_other(other)) {
            vec2 n = d / r;
            float u = dot(v - read_velocity(other), n);
            if (u > 0.0) {
                impulse += u_dt * (1.0 - r / u_h) * (u_viscosity.x * u + u_viscosity.y * u * u) * n;
            }
        }
    }
    write_velocity(v + u_dt * u_gravity - 0.5 * impulse);
#endif
#ifdef PREDICT
    write_predicted(read_position(v_uv) + u_dt * read_velocity(v_uv));
#endif
#ifdef DENSITY
    vec2 x = read_predicted(v_uv);
    vec2 rho = vec2(0.0);
    vec2 other;
    FOR_EACH_NEIGHBOUR(x, other) {
        float q = length(read_predicted(other) - x) / u_h;
        if (q < 1.0 && neighbour_other(other)) {
            float a = 1.0 - q;
            rho += vec2(a * a, a * a * a);
        }
    }
    write_rho(rho);
#endif
#ifdef RELAX
    vec2 x = read_predicted(v_uv);
    vec2 own = read_rho(v_uv);
    vec2 move = vec2(0.0);
    vec2 other;
    FOR_EACH_NEIGHBOUR(x, other) {
        vec2 d = read_predicted(other) - x;
        float r = length(d);
        if (r < u_h && r > 0.0 && neighbour_other(other)) {
            vec2 rho = own + read_rho(other);  // the pair's summed densities
            float a = 1.0 - r / u_h;
            float p = u_stiffness.x * (rho.x - 2.0 * u_rest) * a + u_stiffness.y * rho.y * a * a;
            move -= u_share * 0.5 * u_dt * u_dt * p * d / r;
        }
    }
    x += move;
    // The obstacle circle (x, y, radius); while a hand drags (u_push.w = 1) it is under the
    // pointer, radius u_push.z, and what it holds is carried along by the pointer's velocity
    // before it is put on the circle.
    vec3 obstacle = u_push.w > 0.5 ? u_push.xyz : u_obstacle;
    vec2 c = x - obstacle.xy;
    if (length(c) < obstacle.z) {
        c += u_push.w * u_dt * u_push_velocity;
        float r = length(c);
        x = obstacle.xy + (r > 0.0 ? c / r : vec2(0.0, 1.0)) * obstacle.z;
    }
    write_position(clamp(x, vec2(0.0), u_box));
#endif
#ifdef VELOCITY
    write_velocity(read_velocity(v_uv) + (read_position(v_uv) - read_predicted(v_uv)) / u_dt);
#endif
}
