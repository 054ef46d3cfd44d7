"""Mesh and mask files checked before use (issue 28, item 2): a mesh file's faults (not finite,
out of range, no faces, flat, huge, not a mesh at all), a folder or a FIFO given as a mesh or a
mask, and a voxelising whose work or memory is estimated beyond bounds are each one line naming
the file, exit 2, nothing written, and no GL context needed (the fast tier runs them). The
voxeliser's runs of triangles give the mask that subdividing the whole mesh at once gives."""

import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import needs

from es2particles.cli import main

SMALL = ["--particles", "1024", "--size", "64x64"]

TETRAHEDRON = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TETRAHEDRON_FACES = [(1, 3, 2), (1, 2, 4), (2, 3, 4), (3, 1, 4)]  # OBJ: from 1, outwards


def obj_text(vertices, faces=()):
    """An OBJ file's text: ``v`` lines (numbers as given, so 'nan' stays 'nan') and ``f`` lines
    (indices from 1)."""
    return "".join([f"v {' '.join(str(x) for x in v)}\n" for v in vertices]
                   + [f"f {' '.join(str(i) for i in f)}\n" for f in faces])


def ply_text(vertices, faces):
    """An ASCII PLY file's text (face indices from 0)."""
    head = ["ply", "format ascii 1.0", f"element vertex {len(vertices)}", "property float x",
            "property float y", "property float z", f"element face {len(faces)}",
            "property list uchar int vertex_indices", "end_header"]
    return "\n".join(head + [" ".join(map(str, v)) for v in vertices]
                     + [f"3 {' '.join(map(str, f))}" for f in faces]) + "\n"


def binary_stl(triangles):
    """A binary STL of ``triangles`` (n, 3, 3): an 80-byte header, the count, 50 bytes each."""
    triangles = np.asarray(triangles, np.float32)
    records = np.zeros(len(triangles), [("normal", "<f4", 3), ("corners", "<f4", (3, 3)),
                                        ("attributes", "<u2")])
    records["corners"] = triangles
    return bytes(80) + np.uint32(len(triangles)).tobytes() + records.tobytes()


def noise(size=5000, seed=28):
    """Random bytes: not UTF-8 text, and 5000 is no binary STL's size (84 + 50 n)."""
    return np.random.default_rng(seed).integers(0, 256, size, np.uint8).tobytes()


def refused(tmp_path, capsys, monkeypatch, scene, shape, *more):
    """stderr of a run that must be refused before any work: exit 2, one line, no traceback, no
    file. There is no GL context to make (ES2PARTICLES_BACKEND=nope): a refusal that did not
    happen fails on the context instead, and the caller's check of the message catches it."""
    monkeypatch.setenv("ES2PARTICLES_BACKEND", "nope")
    out = tmp_path / "out" / "x.png"
    assert main(["run", scene, "--shape", str(shape), "--out", str(out), *SMALL, *more]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert not out.parent.exists() and not out.exists()
    return err


MESH_FAULTS = [
    ("nan.obj", obj_text(TETRAHEDRON[:3] + [("nan", 0, 1)], TETRAHEDRON_FACES),
     "has a vertex that is not finite: (nan, 0, 1)"),
    ("inf.ply", ply_text(TETRAHEDRON[:3] + [(0, "inf", 1)], [(0, 2, 1), (0, 1, 3)]),
     "has a vertex that is not finite: (0, inf, 1)"),
    ("index.obj", obj_text(TETRAHEDRON, TETRAHEDRON_FACES[:3] + [(3, 1, 9)]),
     "has a face index 9 out of range: it has 4 vertices (1 to 4)"),
    ("index.ply", ply_text(TETRAHEDRON, [(0, 2, 1), (0, 1, 9)]),
     "has a face index 9 out of range: it has 4 vertices (0 to 3)"),
    ("points.obj", obj_text(TETRAHEDRON), "has 4 vertices but no triangles"),
    ("line.obj", obj_text([(0, 0, 0), (1, 1, 1), (2, 2, 2), (3, 3, 3)], [(1, 2, 3), (2, 3, 4)]),
     "is flat: none of its 2 triangles has an area (its vertices lie on one line)"),
    ("point.obj", obj_text([(1, 2, 3)] * 3, [(1, 2, 3)]), "is flat to a point"),
    ("huge.obj", obj_text(TETRAHEDRON[:3] + [(0, 0, 1e300)], TETRAHEDRON_FACES),
     "has a coordinate of 1e+300; coordinates must lie within +-1e+10"),
    ("zero.obj", obj_text(TETRAHEDRON, [(0, 1, 2)] + TETRAHEDRON_FACES[1:]),
     "line 5: a face names vertex 0; OBJ counts vertices from 1"),
    ("claims.ply", ply_text(TETRAHEDRON, [(0, 2, 1), (0, 1, 3)]).replace("3 0 1 3", "5 0 1 3"),
     "has face 2 claiming 5 indices but holding 3"),
    ("noise.stl", noise(), "could not be read as a mesh"),
    ("noise.obj", noise(seed=29), "could not be read as a mesh"),
]


@pytest.mark.parametrize("name, content, fault", MESH_FAULTS, ids=[c[0] for c in MESH_FAULTS])
def test_a_faulty_mesh_file_is_one_line_naming_it(tmp_path, capsys, monkeypatch, name, content,
                                                   fault):
    """Before, the nan tetrahedron ran as the one triangle trimesh kept, the collinear mesh ran,
    1e300 ran after a numpy warning line, and the OBJ index said numpy's 'index 8 is out of
    bounds for axis 0 with size 4'."""
    needs("trimesh", "mesh")
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    err = refused(tmp_path, capsys, monkeypatch, "collision3d", path)
    assert f"mesh file {str(path)!r} {fault}" in err, err
    assert "warning" not in err.lower()


@pytest.mark.parametrize("name, kind", [("noise.stl", "neither a binary STL nor UTF-8 text"),
                                        ("noise.obj", "not UTF-8 text")])
def test_bytes_that_are_no_mesh_are_not_sent_to_the_install(tmp_path, capsys, monkeypatch, name,
                                                            kind):
    """Without charset_normalizer (trimesh wants it only to guess a text's encoding), random
    bytes said "No module named 'charset_normalizer'": the file is at fault, not the install."""
    needs("trimesh", "mesh")
    monkeypatch.setitem(sys.modules, "charset_normalizer", None)  # its import fails
    path = tmp_path / name
    path.write_bytes(noise())
    err = refused(tmp_path, capsys, monkeypatch, "collision3d", path)
    assert f"mesh file {str(path)!r} could not be read as a mesh: it is {kind}" in err, err
    assert "charset" not in err and "install" not in err


@pytest.mark.parametrize("module", ["trimesh", "scipy"])
def test_a_missing_mesh_extra_still_says_how_to_install_it(tmp_path, capsys, monkeypatch, module):
    path = tmp_path / "tetrahedron.obj"
    path.write_text(obj_text(TETRAHEDRON, TETRAHEDRON_FACES))
    monkeypatch.setitem(sys.modules, module, None)  # as if not installed
    err = refused(tmp_path, capsys, monkeypatch, "collision3d", path)
    assert "mesh shapes need trimesh and scipy: pip install 'es2particles[mesh]'" in err, err


@pytest.mark.parametrize("scene, name, label", [("collision3d", "shape.obj", "mesh file {}"),
                                                ("collision3d", "shape.stl", "mesh file {}"),
                                                ("collision", "mask.png", "--shape (a mask): {}")])
def test_a_folder_is_named_as_a_folder(tmp_path, capsys, monkeypatch, scene, name, label):
    """It said "does not exist"."""
    folder = tmp_path / name
    folder.mkdir()
    err = refused(tmp_path, capsys, monkeypatch, scene, folder)
    assert f"{label.format(repr(str(folder)))} is a folder, not a file" in err, err


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
@pytest.mark.parametrize("scene, name, label", [("collision3d", "shape.stl", "mesh file {}"),
                                                ("collision", "mask.png", "--shape (a mask): {}")])
def test_a_fifo_is_refused_not_opened(tmp_path, scene, name, label):
    """A FIFO opened for reading waits for a writer forever: in a process of its own, with a
    time limit, so that a regression fails instead of hanging the tests."""
    fifo = tmp_path / name
    os.mkfifo(fifo)
    out = tmp_path / "x.png"
    done = subprocess.run([sys.executable, "-m", "es2particles", "run", scene, "--shape",
                           str(fifo), "--out", str(out), *SMALL], capture_output=True, text=True,
                          timeout=120, env={**os.environ, "ES2PARTICLES_BACKEND": "nope"})
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert f"{label.format(repr(str(fifo)))} is not a plain file" in done.stderr
    assert "Traceback" not in done.stderr and not out.exists()


def large_triangles(count=300, seed=0):
    """``count`` triangles with corners anywhere in a cube: each spans much of the field."""
    return np.random.default_rng(seed).uniform(-1, 1, (count, 3, 3))


@pytest.mark.slow
def test_300_large_triangles_at_resolution_256_are_refused_fast(tmp_path):
    """A 15 KB STL whose triangles, cut to a quarter voxel, are ~160 million points: it died of a
    MemoryError after minutes. Now estimated from the triangles before any voxel and refused in
    one line saying what to lower, before any voxel: seconds, not the minutes a voxelisation
    takes (3.2 s with 12 workers on a loaded 16-core machine, so the bound is 30 s). In a process of its own with 4 GiB of
    address space, so that a regression is a MemoryError, not the machine's OOM killer. The
    refusal comes before the warning of the field's size: one line."""
    needs("trimesh", "mesh")
    import resource

    path = tmp_path / "large.stl"
    path.write_bytes(binary_stl(large_triangles()))
    assert path.stat().st_size == 84 + 50 * 300
    out = tmp_path / "x.png"
    timed = ("import sys, time; from es2particles.cli import main; start = time.perf_counter(); "
             "code = main(sys.argv[1:]); print(time.perf_counter() - start); sys.exit(code)")
    limit = 4 << 30
    done = subprocess.run(
        [sys.executable, "-c", timed, "run", "collision3d", "--shape", str(path),
         "--field-resolution", "256", "--out", str(out), *SMALL],
        capture_output=True, text=True, timeout=300,
        env={**os.environ, "ES2PARTICLES_BACKEND": "nope"},
        preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_AS, (limit, limit)))
    err = done.stderr
    errors = err.splitlines()
    assert done.returncode == 2 and len(errors) == 1 and "Traceback" not in err, err
    seconds = float(done.stdout)
    assert seconds < 30, f"refused after {seconds:.1f} s"
    assert f"mesh file {str(path)!r} needs about " in errors[0]
    assert "million points to voxelise at --field-resolution 256" in errors[0]
    assert "lower --field-resolution to " in errors[0] and not out.exists()


def test_a_run_beyond_the_memory_available_is_refused(tmp_path, capsys, monkeypatch):
    """The largest run of triangles is held at once: a tetrahedron across the field at 128 is
    ~0.3 million points a face, ~1.3 GB with its margin; with 0.2 GB available it is refused, and
    the line says the resolution that fits."""
    needs("trimesh", "mesh")
    from es2particles.fields import field3d

    monkeypatch.setattr(field3d, "free_memory", lambda: 0.2e9)
    path = tmp_path / "tetrahedron.obj"
    path.write_text(obj_text(TETRAHEDRON, TETRAHEDRON_FACES))
    err = refused(tmp_path, capsys, monkeypatch, "collision3d", path, "--field-resolution", "128")
    assert f"mesh file {str(path)!r} needs about " in err and "GB at once to voxelise" in err
    assert "more than the 0.2 GB of memory available: lower --field-resolution to " in err, err


@pytest.mark.slow
def test_the_estimate_bounds_the_points_made():
    """TriangleMesh.surface_points against trimesh's subdivision, one triangle at a time (random
    ones, slivers and needles among them): within the measured 0.19 to 2.75 times, so that
    ESTIMATE_MARGIN (3) covers the memory of a run."""
    trimesh = needs("trimesh", "mesh")
    from es2particles.fields.field3d import ESTIMATE_MARGIN, TriangleMesh

    rng = np.random.default_rng(31)
    ratios = []
    for k in range(60):
        corners = rng.uniform(-1, 1, (3, 3)) * rng.uniform(0.02, 0.3)
        if k % 3 == 1:  # a sliver: the third corner near the first edge
            corners[2] = corners[0] + (corners[1] - corners[0]) * rng.uniform() \
                + rng.normal(0, 1e-3, 3)
        if k % 3 == 2:  # a needle: one short edge
            corners[2] = corners[0] + rng.normal(0, 2e-3, 3)
        mesh = TriangleMesh(corners, np.array([[0, 1, 2]]))
        made = len(trimesh.remesh.subdivide_to_size(corners, [[0, 1, 2]], max_edge=0.01 / 4,
                                                     max_iter=40)[0])
        ratios.append(made / mesh.surface_points(0.01)[0])
    assert 0.19 <= min(ratios) and max(ratios) <= 2.75 <= ESTIMATE_MARGIN, (min(ratios),
                                                                            max(ratios))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["icosphere.obj", "dome.obj", "tetrahedron.obj"])
def test_runs_of_triangles_make_the_mask_the_whole_mesh_makes(tmp_path, monkeypatch, name):
    """The voxeliser subdivides a run of triangles at a time (here runs of a few triangles, so
    that there are many): the mask is the one trimesh's subdivision of the whole mesh gives."""
    trimesh = needs("trimesh", "mesh")
    from scipy import ndimage

    from es2particles.fields import field3d

    path = tmp_path / name
    if name == "tetrahedron.obj":
        path.write_text(obj_text(TETRAHEDRON, TETRAHEDRON_FACES))
    else:
        path = field3d.Path(__file__).parent / "data" / name
    mesh = field3d.load_mesh(path)
    for resolution in (24, 41):
        field = field3d.VoxelField([mesh], resolution)
        lo, cells = field.lo + field.pivot, np.asarray(field.cells)
        points, _ = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces,
                                                     max_edge=field.voxel / 4, max_iter=40)
        index = np.floor((points - lo) / field.voxel).astype(int)
        index = index[np.all((index >= 0) & (index < cells), axis=1)]
        whole = np.zeros(cells[::-1], bool)
        whole[index[:, 2], index[:, 1], index[:, 0]] = True
        if not mesh.closed:
            whole = ndimage.binary_dilation(whole, ndimage.generate_binary_structure(3, 1))
        whole = ndimage.binary_fill_holes(whole)
        monkeypatch.setattr(field3d, "SURFACE_POINTS_PER_CHUNK", 200)
        assert len(mesh.chunks(field.voxel)) > 3
        assert np.array_equal(mesh.solid(lo, field.voxel, cells), whole), (name, resolution)
        monkeypatch.undo()


def test_a_good_mesh_is_read_as_it_was(tmp_path):
    """A closed tetrahedron: four triangles, closed, scaled to 2 across about (0, 1, 0)."""
    needs("trimesh", "mesh")
    from es2particles.fields.field3d import load_mesh

    path = tmp_path / "tetrahedron.obj"
    path.write_text(obj_text(TETRAHEDRON, TETRAHEDRON_FACES))
    mesh = load_mesh(path)
    lo, hi = mesh.bounds()
    assert len(mesh.faces) == 4 and mesh.closed and mesh.name == str(path)
    assert np.allclose(hi - lo, 2) and np.allclose((lo + hi) / 2, (0, 1, 0))


@pytest.mark.gl
def test_a_good_mesh_still_runs(tmp_path, capsys):
    needs("trimesh", "mesh")
    path = tmp_path / "tetrahedron.obj"
    path.write_text(obj_text(TETRAHEDRON, TETRAHEDRON_FACES))
    out = tmp_path / "x.png"
    assert main(["run", "collision3d", "--shape", str(path), "--out", str(out), *SMALL,
                 "--steps", "2"]) == 0, capsys.readouterr().err
    assert out.stat().st_size > 0


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_files_a_mesh_names_are_never_opened(tmp_path):
    """Issue 44, item 2: an OBJ whose mtllib named a FIFO blocked forever in open(). The mesh is
    read from its own bytes with no resolver: an mtllib naming a FIFO, a device or a file
    outside the mesh's folder is not opened, and the geometry loads (in a process of its own,
    with a time limit, so that a regression fails instead of hanging the tests)."""
    needs("trimesh", "mesh")
    fifo = tmp_path / "materials.mtl"
    os.mkfifo(fifo)
    mesh = tmp_path / "tetrahedron.obj"
    for named in (fifo, "/dev/zero", "../../../../etc/passwd"):
        mesh.write_text(f"mtllib {named}\nusemtl stone\n"
                        + obj_text(TETRAHEDRON, TETRAHEDRON_FACES))
        code = ("from es2particles.fields.field3d import load_mesh; "
                f"print(len(load_mesh({str(mesh)!r}).faces))")
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              timeout=60)
        assert done.returncode == 0 and done.stdout.strip() == "4", (named, done.stderr)


@pytest.mark.parametrize("name", ["shape.gltf", "shape.glb", "shape.off", "shape.dae"])
def test_mesh_formats_not_documented_are_not_opened(tmp_path, capsys, monkeypatch, name):
    """Only OBJ, STL and PLY are read (a glTF names buffer files of its own): the others are
    refused in one line, whatever they hold."""
    path = tmp_path / name
    path.write_text('{"asset": {"version": "2.0"}, "buffers": [{"uri": "/dev/zero"}]}')
    err = refused(tmp_path, capsys, monkeypatch, "collision3d", path)
    assert "(.obj .stl .ply)" in err, err
