#version 100
// Test pass: one step of the de Jong map written out plainly (sin and cos of GLSL), so that the
// test's float64 map is the reference for what the state keeps of it.
void main()
{
    vec2 p = read_q(v_uv);
    write(vec2(sin(u_k.x * p.y) - cos(u_k.y * p.x), sin(u_k.z * p.x) - cos(u_k.w * p.y)));
}
