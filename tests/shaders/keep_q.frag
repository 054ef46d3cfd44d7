#version 100
// Test pass: quantity q (of any width) keeps its value.
void main()
{
    write(read_q(v_uv));
}
