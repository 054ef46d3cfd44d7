#version 100
// Each particle takes the grid's field f, bilinear at its position.
void main()
{
    write_value(sample_f(read_position(v_uv)));
}
