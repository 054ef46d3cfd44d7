#version 100
// a = a * u_scale + u_shift: one writer of a chain of several.
void main()
{
    write_a(read_a(v_uv) * u_scale + u_shift);
}
