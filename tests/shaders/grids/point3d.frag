#version 100
// Each cell of a 3D grid writes its own centre.
void main()
{
    write_centre(grid_point());
}
