#version 100
// The warm start of a repeat (PassGraph.repeat(..., warm_start=)): the solved quantity's last
// value scaled by u_warm before the iterations begin (0: a cold start from zero). WARM_READ is
// the quantity's generated reader, read_<q>.
void main()
{
    write(WARM_READ(v_uv) * u_warm);
}
