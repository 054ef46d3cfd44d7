#version 100
// The 5-point Laplacian of f over the grid, edges clamped (a Neumann boundary).
void main()
{
    vec2 c = grid_cell();
    write_lap(f_at(c + vec2(1.0, 0.0)) + f_at(c - vec2(1.0, 0.0)) + f_at(c + vec2(0.0, 1.0))
              + f_at(c - vec2(0.0, 1.0)) - 4.0 * f_at(c));
}
