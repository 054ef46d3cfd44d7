"""Collision fields: the 2D distance/normal field over a scene rectangle and the 3D voxel field in a
slice atlas, made once in numpy and sampled by the scenes' passes as textures."""
