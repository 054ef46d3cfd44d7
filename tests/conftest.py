"""Shared fixtures: one real headless GL context per session, a GL-error check per test, a
recording context for the executor's call stream, and the test tiers.

Tiers (markers, registered in pyproject.toml): ``gl`` needs a GL context (every test that takes
the ``ctx`` or ``gl`` fixture is marked here; a module that opens contexts itself marks itself),
``browser`` needs Chromium, ``slow`` takes half a second or more. ``pytest -m "not gl and not
browser and not slow"`` is the fast tier: plans, bindings, the executor on a recording device,
numpy twins and the command line's refusals, with no GL library loaded. The README's test
command runs them all.

A tool a test needs and lacks (glslang, astcenc, Chromium...) is a skip, or under CI a failure
(``missing``). Tests write under their tmp_path only: a session that made, changed or removed a
file of the repository fails, naming them (``pytest_sessionfinish``).
"""

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from es2particles import open_context

TEST_SHADERS = Path(__file__).parent / "shaders"


def pytest_collection_modifyitems(config, items):
    """Every test that takes a GL context is in the ``gl`` tier."""
    for item in items:
        if {"ctx", "gl"} & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.gl)


# Tests write under their tmp_path only. The repository's files are listed when the session starts
# and again when it ends; a file made, changed or removed in between fails the session, named.
# Left out: environments, git, caches and build leftovers (the tools' own, not the tests').
REPOSITORY = Path(__file__).resolve().parent.parent
NOT_WATCHED = {".git", ".venv", "venv", "__pycache__", ".pytest_cache", ".hypothesis", "build",
               "dist"}
REPOSITORY_BEFORE = pytest.StashKey[dict]()
REPOSITORY_CHANGED = pytest.StashKey[list]()


def repository_files():
    """{path relative to the repository: (size, modification time in ns)} of every file the
    guard watches."""
    files = {}
    for folder, folders, names in os.walk(REPOSITORY):
        folders[:] = [f for f in folders if f not in NOT_WATCHED and not f.endswith(".egg-info")]
        for name in names:
            path = os.path.join(folder, name)
            try:
                stat = os.lstat(path)
            except OSError:  # gone between the listing and the look
                continue
            files[os.path.relpath(path, REPOSITORY)] = (stat.st_size, stat.st_mtime_ns)
    return files


def pytest_sessionstart(session):
    session.config.stash[REPOSITORY_BEFORE] = repository_files()


def pytest_sessionfinish(session, exitstatus):
    before = session.config.stash.get(REPOSITORY_BEFORE, None)
    if before is None:
        return
    after = repository_files()
    changed = sorted([f"made: {p}" for p in after.keys() - before.keys()]
                     + [f"changed: {p}" for p in after.keys() & before.keys()
                        if after[p] != before[p]]
                     + [f"removed: {p}" for p in before.keys() - after.keys()])
    session.config.stash[REPOSITORY_CHANGED] = changed
    if changed and session.exitstatus == 0:
        session.exitstatus = 1


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    changed = config.stash.get(REPOSITORY_CHANGED, [])
    if changed:
        terminalreporter.section("files written into the repository", red=True)
        terminalreporter.write_line(
            f"The session made, changed or removed {len(changed)} file(s) under {REPOSITORY} "
            "(tests write under their tmp_path only; a file edited by hand while the tests ran "
            "shows here too):", red=True)
        for line in changed:
            terminalreporter.write_line(f"  {line}", red=True)


@pytest.fixture
def recording():
    """A context over a recording device (``gl/device.py``): no GL library is loaded, nothing is
    drawn, every call is recorded in ``recording.device.calls``; the capabilities are stated
    (``Capabilities.assumed()``: every format renderable and blendable)."""
    from es2particles.gl.context import Capabilities, Context
    from es2particles.gl.device import RecordingDevice

    context = Context(RecordingDevice(Capabilities.assumed()))
    yield context
    context.release()


# The GL tier's core, which runs on both back-ends (docs/backends.md): packing, each scene's
# step against its float64 reference, every renderer, the pages against EGL's pictures. Its tests that take ``ctx`` or ``gl`` run
# once on desktop GL and once on OpenGL ES (ids [gl] and [gles]), unless ES2PARTICLES_BACKEND
# names one (then every test runs on that one).
BOTH_BACKENDS = {"test_packing", "test_bits32", "test_numerics", "test_wide", "test_simulation",
                 "test_clamps", "test_dejong", "test_clifford", "test_collision",
                 "test_fountain", "test_collision3d", "test_confetti", "test_smoke", "test_wind",
                 "test_grids", "test_grids3d", "test_neighbours", "test_boids", "test_sph",
                 "test_liquid", "test_flame", "test_render", "test_meshes", "test_sort",
                 "test_sprite_roles", "test_metaballs", "test_shafts", "test_bloom",
                 "test_soft", "test_lamp", "test_trails", "test_vertex_fetch", "test_export",
                 "test_air3d"}


def pytest_generate_tests(metafunc):
    module = metafunc.module.__name__.rsplit(".", 1)[-1]
    if (module in BOTH_BACKENDS and {"ctx", "gl"} & set(metafunc.fixturenames)
            and not os.environ.get("ES2PARTICLES_BACKEND")):
        metafunc.parametrize("backend", ["gl", "gles"], indirect=True, scope="session")


@pytest.fixture(scope="session")
def backend(request):
    """The back-end of the session's context: gl or gles for the core's tests, else None
    (ES2PARTICLES_BACKEND's, or auto)."""
    return getattr(request, "param", None)


@pytest.fixture(scope="session")
def ctx(backend):
    context = open_context(backend=backend)
    yield context
    context.release()


@pytest.fixture
def gl(ctx):
    """The context, current, with no GL error allowed before or after the test."""
    # A test may have opened (and released) a context of its own, perhaps a raw moderngl one
    # that Context does not track: force the switch.
    type(ctx)._current = None
    ctx.make_current()
    assert ctx.error() == "GL_NO_ERROR"
    yield ctx
    assert ctx.error() == "GL_NO_ERROR"


def shader(name):
    """Path of a test-only shader."""
    return str(TEST_SHADERS / name)


def run_fullscreen(ctx, frag, source, out_fmt="rgba8", uniforms=None):
    """Draw test shader ``frag`` over a target the size of texture ``source`` (bound to
    u_source, where the shader samples it) and return the target's texels as an array (h*w, 4):
    through a draw command, so on either back-end."""
    from es2particles.gl.command import DrawCommand

    group = ctx.group()
    try:
        target = group.texture(source.size, out_fmt)
        fbo = group.framebuffer(target)
        command = DrawCommand(group, "test", shader(frag))
        command.draw(fbo, {"u_source": source} if "u_source" in command.samplers else {},
                     uniforms)
        dtype = {"rgba8": np.uint8, "rgba16f": np.float16, "rgba32f": np.float32}[out_fmt]
        return np.frombuffer(ctx.read(target), dtype=dtype).reshape(-1, 4).copy()
    finally:
        group.release()


def missing(what):
    """A tool the test needs is missing: ``what`` says which, and how to get it. Under CI (the
    environment variable CI set, as ``.ci/run`` sets it) a failure, so that no test of CI is
    skipped unseen; elsewhere a skip."""
    if os.environ.get("CI"):
        pytest.fail(f"{what}; CI must provide it (CI is set: a missing tool fails the test)",
                    pytrace=False)
    pytest.skip(what, allow_module_level=True)


def needs(module, extra):
    """Import ``module``, which the package's ``extra`` installs; missing, as ``missing`` says."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        missing(f"{module} is not installed (pip install '.[{extra}]')")


def glslang():
    """Path of glslangValidator; in CI its absence is a failure, elsewhere a skip."""
    tool = shutil.which("glslangValidator")
    if tool is None:
        missing("glslangValidator is not installed (Debian package glslang-tools)")
    return tool


def wide_graph(shift=(0.1, 0.2, 0.3, 0.4)):
    """Quantities of 1, 3 and 4 components: position (3) moves by u_shift.xyz * mass each step,
    reading last step's position, colour and mass; colour (4) is this step's position and last
    step's mass; mass (1) keeps its value."""
    from es2particles import PassGraph

    g = PassGraph()
    g.quantity("mass", 0, 1, components=1)
    g.quantity("position", -1, 1, components=3)
    g.quantity("colour", 0, 1, components=4)
    g.add("position", shader("wide.frag"), writes="position",
          reads=["position", "colour", "mass"], uniforms={"u_shift": shift})
    g.add("colour", shader("wide_colour.frag"), writes="colour", reads=["mass"],
          reads_new=["position"])
    g.add("mass", shader("wide_mass.frag"), writes="mass", reads=["mass"])
    return g


def run_scene(gl, scene, count, steps, seed, rounding=None):
    """Decoded positions (start, after ``steps``) of ``scene`` simulated from its own start:
    the GPU side of the float64 comparisons. Rounding: the given one, else the scene's default."""
    from es2particles import Simulation

    rounding = scene.defaults.rounding if rounding is None else rounding
    with Simulation(gl, scene.graph(), count, rounding=rounding) as sim:
        scene.initialise(sim, np.random.default_rng(seed))
        start = sim.download("position")
        sim.run(steps)
        return start, sim.download("position")


def command(*words):
    """The command line run in this process: (exit status, the lines it wrote to stderr)."""
    import contextlib
    import io

    from es2particles.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(list(words))
    return code, err.getvalue().strip().splitlines()
