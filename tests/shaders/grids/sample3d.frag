#version 100
// Each particle takes the 3D grid's field f, trilinear at its position.
void main()
{
    write_value(sample_f(read_position(v_uv)));
}
