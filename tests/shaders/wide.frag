#version 100
// Test pass over a 3-component position: every component moves, by a value that also depends
// on a 4-component colour and a 1-component mass read as last step's values.
void main()
{
    vec4 c = read_colour(v_uv);
    write_position(read_position(v_uv) + u_shift.xyz * read_mass(v_uv) * step(-1.0, c.w));
}
