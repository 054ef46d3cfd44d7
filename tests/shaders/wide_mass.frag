#version 100
// Test pass: a 1-component quantity keeps its value.
void main()
{
    write_mass(read_mass(v_uv));
}
