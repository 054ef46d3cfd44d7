#version 100
void main()
{
    write_c(read_a(v_uv));
}
