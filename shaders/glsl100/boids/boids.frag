#version 100
// Boids (es2particles/scenes/boids.py): WRITE_VELOCITY, the three rules over the neighbours within
// their radii u_radii (separation, alignment, cohesion) weighted by u_weights, the speed held in
// u_speed, walls turning a boid back; else the position pass, x + dt v, kept in the box.
// BOIDS_3D: in 3D (the neighbour grid's 3 x 3 x 3 cells; u_box a vec3), else 2D.
#ifdef BOIDS_3D
#define VEC vec3
#else
#define VEC vec2
#endif

void main()
{
    VEC x = read_position(v_uv);
#ifdef WRITE_VELOCITY
    VEC v = read_velocity(v_uv);
    VEC away = VEC(0.0);
    VEC heading = VEC(0.0);  // sum of velocities
    VEC centre = VEC(0.0);   // sum of positions
    vec2 counts = vec2(0.0); // of the headings and of the positions
    vec2 other;
    FOR_EACH_NEIGHBOUR(x, other) {
        VEC d = read_position(other) - x;
        float r = length(d);
        if (!neighbour_other(other) || (r >= u_radii.z && r >= u_radii.y)) {
            continue;
        }
        if (r < u_radii.x && r > 0.0) {
            away -= d / (r * r);
        }
        if (r < u_radii.y) {
            heading += read_velocity(other);
            counts.x += 1.0;
        }
        if (r < u_radii.z) {
            centre += d;
            counts.y += 1.0;
        }
    }
    VEC steer = u_weights.x * away * u_radii.x;
    if (counts.x > 0.0) {
        steer += u_weights.y * (heading / counts.x - v);
    }
    if (counts.y > 0.0) {
        steer += u_weights.z * centre / counts.y / u_radii.z * u_speed.y;
    }
    // Walls: nearer than the cohesion radius, turn back at the top speed's rate.
    VEC wall = step(x, VEC(u_radii.z)) - step(u_box - VEC(u_radii.z), x);
    v += u_dt * (steer + wall * u_speed.y / max(u_radii.z, u_dt * u_speed.y));
    float s = length(v);
    VEC forward = VEC(0.0);
    forward.x = u_speed.x;
    v = s > 0.0 ? v / s * clamp(s, u_speed.x, u_speed.y) : forward;
    write_velocity(v);
#else
    write_position(clamp(x + u_dt * read_velocity(v_uv), VEC(0.0), u_box));
#endif
}
