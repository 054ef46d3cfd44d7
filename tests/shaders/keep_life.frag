#version 100
// Test pass: life keeps its value.
void main()
{
    write_life(read_life(v_uv));
}
