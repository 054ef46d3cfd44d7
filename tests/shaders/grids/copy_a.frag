#version 100
void main()
{
    write_b(read_a(v_uv));
}
