#version 100
// The 7-point Laplacian of f over a 3D grid, edges clamped (a Neumann boundary).
void main()
{
    vec3 c = grid_cell();
    write_lap(f_at(c + vec3(1.0, 0.0, 0.0)) + f_at(c - vec3(1.0, 0.0, 0.0))
              + f_at(c + vec3(0.0, 1.0, 0.0)) + f_at(c - vec3(0.0, 1.0, 0.0))
              + f_at(c + vec3(0.0, 0.0, 1.0)) + f_at(c - vec3(0.0, 0.0, 1.0)) - 6.0 * f_at(c));
}
