"""Writes the small mesh files of tests/data with trimesh: a closed icosphere and an open dome (its
upper half, a thin shell with a rim). Run from the repository root: python tests/data/make_meshes.py
"""

from pathlib import Path

import numpy as np
import trimesh

HERE = Path(__file__).parent

sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
upper = np.flatnonzero(sphere.triangles_center[:, 1] > 0)
dome = sphere.submesh([upper], append=True)
for name, mesh in (("icosphere.obj", sphere), ("dome.obj", dome)):
    path = HERE / name
    mesh.export(path)
    print(f"{path}: {path.stat().st_size} bytes, {len(mesh.vertices)} vertices, "
          f"{len(mesh.faces)} faces, watertight {mesh.is_watertight}")
