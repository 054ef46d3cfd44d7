#version 100
// One Jacobi iteration of the discrete Poisson problem lap(p) = b (unit cells), p = 0 outside.
void main()
{
    vec2 c = grid_cell();
    vec2 n = u_cells_size - 1.0;
    float left = c.x > 0.0 ? p_at(c - vec2(1.0, 0.0)) : 0.0;
    float right = c.x < n.x ? p_at(c + vec2(1.0, 0.0)) : 0.0;
    float down = c.y > 0.0 ? p_at(c - vec2(0.0, 1.0)) : 0.0;
    float up = c.y < n.y ? p_at(c + vec2(0.0, 1.0)) : 0.0;
    write_p(0.25 * (left + right + down + up - read_b(v_uv)));
}
