#version 100
// Test pass: velocity keeps its value.
void main()
{
    write_velocity(read_velocity(v_uv));
}
