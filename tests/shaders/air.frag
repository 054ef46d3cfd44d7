#version 100
// Test pass: quantity air is the air velocity (lib/flow.glsl) at each particle's position, with
// the field's parameters as pass uniforms; tests/test_flow.py checks it against the float64 twin.
#include "lib/flow.glsl"

void main()
{
    write_air(air_velocity(read_position(v_uv), u_centre, u_radius, u_wind, u_sphere_velocity,
                           u_noise, u_offset));
}
