#version 100
void main()
{
    write_f(read_f(v_uv));
}
