#version 100
// Test pass: a value that needs float32's mantissa (1 + k / 16384), written inside a branch.
void main()
{
    float v = 1.0 + floor(v_uv.x * u_state_size.x) / 16384.0;
    if (v_uv.y > 0.5) {
        write_q(v);
    } else {
        write_q(v + 0.5);
    }
}
