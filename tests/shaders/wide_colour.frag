#version 100
// Test pass: colour = (this step's position, last step's mass).
void main()
{
    write_colour(vec4(read_position(v_uv), read_mass(v_uv)));
}
