"""Collision fields: the 2D distance/normal field over a scene rectangle, the 3D voxel field in a
slice atlas, and ASTC compression of read-only textures."""
