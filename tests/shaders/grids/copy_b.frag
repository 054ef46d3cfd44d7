#version 100
void main()
{
    write_b(read_b(v_uv));
}
