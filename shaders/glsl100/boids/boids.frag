#version 100
// Boids (es2particles/scenes/boids.py): WRITE_VELOCITY, the three rules over the neighbours within
// their radii u_radii (separation, alignment, cohesion) weighted by u_weights, the speed held in
// u_speed, walls turning a boid back; else the position pass, x + dt v, kept in the box.

void main()
{
    vec2 x = read_position(v_uv);
#ifdef WRITE_VELOCITY
    vec2 v = read_velocity(v_uv);
    vec2 away = vec2(0.0);
    vec3 heading = vec3(0.0);  // sum of velocities, count
    vec3 centre = vec3(0.0);   // sum of positions, count
    vec2 other;
    FOR_EACH_NEIGHBOUR(x, other) {
        vec2 d = read_position(other) - x;
        float r = length(d);
        if (!neighbour_other(other) || (r >= u_radii.z && r >= u_radii.y)) {
            continue;
        }
        if (r < u_radii.x && r > 0.0) {
            away -= d / (r * r);
        }
        if (r < u_radii.y) {
            heading += vec3(read_velocity(other), 1.0);
        }
        if (r < u_radii.z) {
            centre += vec3(d, 1.0);
        }
    }
    vec2 steer = u_weights.x * away * u_radii.x;
    if (heading.z > 0.0) {
        steer += u_weights.y * (heading.xy / heading.z - v);
    }
    if (centre.z > 0.0) {
        steer += u_weights.z * centre.xy / centre.z / u_radii.z * u_speed.y;
    }
    // Walls: nearer than the cohesion radius, turn back at the top speed's rate.
    vec2 wall = step(x, vec2(u_radii.z)) - step(u_box - vec2(u_radii.z), x);
    v += u_dt * (steer + wall * u_speed.y / max(u_radii.z, u_dt * u_speed.y));
    float s = length(v);
    v = s > 0.0 ? v / s * clamp(s, u_speed.x, u_speed.y) : vec2(u_speed.x, 0.0);
    write_velocity(v);
#else
    write_position(clamp(x + u_dt * read_velocity(v_uv), vec2(0.0), u_box));
#endif
}
