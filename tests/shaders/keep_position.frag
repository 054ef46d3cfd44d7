#version 100
// Test pass: position keeps its value.
void main()
{
    write_position(read_position(v_uv));
}
