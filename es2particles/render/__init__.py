"""Render stages: density points, 3D sprites and meshes, the depth sort, the opacity shadow map and
the post chain (tone map, gradient map, bloom); cameras and colour ramps. Each stage is declared
as data for the frame plan."""
