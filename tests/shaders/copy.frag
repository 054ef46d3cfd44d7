#version 100
// Test pass: copy "position" (bound as last step's or this step's value by the graph).
void main()
{
    write(read_position(v_uv));
}
