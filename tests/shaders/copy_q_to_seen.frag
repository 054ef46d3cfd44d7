#version 100
// Test pass: what a read of quantity q returns, kept in quantity "seen" (float storage).
void main()
{
    write_seen(read_q(v_uv));
}
