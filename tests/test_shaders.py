"""Shader loading: every shader is valid GLSL ES 1.00 for the Khronos reference compiler, includes
and defines expand as documented, and errors name the file and the line."""

import re
import subprocess
from pathlib import Path

import pytest

from conftest import TEST_SHADERS, glslang, shader, wide_graph
from es2particles import ParameterError, ShaderError
from es2particles.gl.shaders import expand, shader_root


def variants(path):
    """The default build and one build per flag the shader tests (#ifdef / defined()), so every
    branch is compiled. Flags with values (#define NAME value) keep their defaults; the dither
    flag is for fragment shaders only (it reads gl_FragCoord)."""
    text = expand(path).text
    flags = set(re.findall(r"#\s*ifn?def\s+(\w+)", text)) | set(re.findall(r"defined\((\w+)\)", text))
    valued = set(re.findall(r"#[ \t]*define[ \t]+(\w+)[ \t]+\S", text))
    flags -= valued
    # the implementation's own macros (GL_FRAGMENT_PRECISION_HIGH): the driver builds each way
    flags = {flag for flag in flags if not flag.startswith("GL_")}
    if path.endswith(".vert"):
        flags.discard("STATE_DITHER")
    return [{}] + [{flag: None} for flag in sorted(flags)]


def uses_bindings(path):
    """True for a shader that calls the accessors the graph generates (read_q, write_q)."""
    return re.search(r"\b(read_\w+|write(_\w+)?)\s*\(", expand(path).text) is not None


def all_shaders():
    root = shader_root()
    library = sorted(p for p in root.rglob("*") if p.suffix in (".vert", ".frag"))
    tests = sorted(p for p in TEST_SHADERS.glob("*") if p.suffix in (".vert", ".frag")
                   and p.name != "broken.frag")
    return [str(p) for p in library + tests if not uses_bindings(str(p))]


# Builds whose branch reads state through the generated interface, so they compile only with
# it: the page's programs (tests/test_export.py) validate them with their interface.
NEEDS_BINDINGS = {("march.frag", "SOURCE_STATE")}  # the wind flame's march of its fire
BUILDS = [(path, defines) for path in all_shaders() for defines in variants(path)
          if (Path(path).name, next(iter(defines), None)) not in NEEDS_BINDINGS]


def validate(tool, source, suffix, tmp_path, what):
    assert source.startswith("#version 100\n")
    target = tmp_path / ("expanded" + suffix)
    target.write_text(source)
    result = subprocess.run([tool, str(target)], capture_output=True, text=True)
    assert result.returncode == 0, f"{what} rejected:\n{result.stdout}{result.stderr}"


@pytest.mark.parametrize("path, defines", BUILDS,
                         ids=[f"{Path(p).name}-{next(iter(d), 'default')}" for p, d in BUILDS])
def test_every_shader_is_valid_glsl_es_100(path, defines, tmp_path):
    validate(glslang(), expand(path, defines).text, Path(path).suffix, tmp_path,
             f"{path} ({defines})")


def stage_sources(stage):
    """(vertex, fragment) expanded sources of a plan's stage, as the executors compile them."""
    vs = expand(stage.vertex, stage.defines,
                stage.vertex_interface.lines if stage.vertex_interface else None)
    fs = expand(stage.fragment, stage.defines,
                stage.interface.lines if stage.interface else None,
                stage.interface.epilogue if stage.interface else None)
    return vs, fs


def programs():
    """(name, source, suffix) of every distinct program source the frame plans of the built-in
    scenes (in variants: reseeded and stateful, tracers, sorted and not, shadowed and not, a
    float order, fields of every encoding, the wind's air alone) and the wide test graph and a
    3D grid's samples (by hand and by the hardware) hold, in every state format
    and rounding: simulation passes, points, sprites, meshes, sort key and merge, shadow map and
    post stages alike."""
    from es2particles.fields.field2d import CollisionField
    from es2particles.frame.plan import plan_frame, plan_graph
    from es2particles.frame.settings import ROUNDINGS, FrameSettings
    from es2particles.frame.state import FORMATS
    from es2particles.scenes import Clifford, Collision, Collision3D, DeJong, Fountain, Smoke
    from es2particles.scenes.collision import RECT
    from es2particles.scenes.wind import Wind

    from test_grids3d import BOX, SHAPE, sampled_graph
    from test_jitter import DeJong16

    scenes = {"dejong": DeJong(), "dejong-reseed": DeJong(reseed=True), "clifford": Clifford(),
              "dejong-16-bit": DeJong16(),
              "collision": Collision(field=CollisionField(RECT, [], resolution=(8, 8))),
              "fountain": Fountain(),
              "fountain-bounce": Fountain(floor="bounce", emitters="0,0,0;1,0,1"),
              "collision3d": Collision3D(field_resolution=16),
              "collision3d-float": Collision3D(field_resolution=16, field_format="rgba32f"),
              "collision3d-smooth": Collision3D(field_resolution=16,
                                                field_format="rgba8-smooth"),
              "collision3d-moving": Collision3D(field_resolution=16,
                                                spin=(90.0, 0.0, 1.0, 0.0)),
              "smoke": Smoke(), "smoke-tracers": Smoke(tau=0.0),
              "smoke-plain": Smoke(shadows="off", sort="off"), "smoke-spread": Smoke(sort="7"),
              "wind": Wind(grid="16x16")}
    out = {}
    for fmt in FORMATS:
        for rounding in ROUNDINGS:
            plans = [(name, plan) for name, scene in scenes.items()
                     for plan in [_plan_unless_inert(scene, FrameSettings(
                         format=fmt, rounding=rounding, particles=4096, size=(64, 64)))]
                     if plan is not None]
            plans.append(("wide", plan_graph(wide_graph(), 64, fmt=fmt, rounding=rounding)))
            plans.append(("wind-alone", plan_frame(Wind(grid="16x16"), FrameSettings(
                format=fmt, rounding=rounding, particles=0, size=(64, 64)))))
            for sampling in ("hand", "hardware"):  # a 3D grid's reads, by hand and LINEAR
                graph = sampled_graph(SHAPE, BOX, sampling, ((-1, 0, 0.5), (2, 1.5, 3)))
                plans.append((f"grid3d-{sampling}", plan_graph(graph, 64, fmt=fmt,
                                                                rounding=rounding)))
            for name, plan in plans:
                for stage in plan.stages:
                    for source, suffix in zip(stage_sources(stage), (".vert", ".frag")):
                        out.setdefault(source.text, (f"{name}-{stage.name}-{fmt}-{rounding}"
                                                     f"{suffix}", suffix))
    return [(name, text, suffix) for text, (name, suffix) in out.items()]


def _plan_unless_inert(scene, settings):
    """The scene's plan, or None where a setting would change nothing and is refused (a 32-bit
    attractor's rounding, or rgba16f: its programs are those of another combination)."""
    from es2particles.frame.plan import plan_frame

    try:
        return plan_frame(scene, settings)
    except ParameterError as error:
        if "would change nothing" in str(error) or "always rounded to the nearest" in str(error):
            return None
        raise


@pytest.mark.slow
def test_every_program_of_every_plan_is_valid_glsl_es_100(tmp_path):
    """Every program, each named in the failure (made here, not at collection: planning every
    variant took 6 s of the fast tier's start)."""
    tool, failed = glslang(), []
    for name, text, suffix in programs():
        try:
            validate(tool, text, suffix, tmp_path, name)
        except AssertionError as error:
            failed.append(f"{name}: {error}")
    assert not failed, "\n".join(failed)


def test_includes_paste_each_file_once_and_keep_origins():
    # The prelude includes state.glsl, which includes pack.glsl; the second include is a no-op.
    src = expand("lib/constant.frag", prelude=['#include "lib/state.glsl"', '#include "lib/pack.glsl"'])
    assert src.text.count("vec2 pack16(float x)") == 1  # state.glsl includes pack.glsl too
    line = next(i for i, t in enumerate(src.text.splitlines(), 1) if "vec2 pack16(float x)" in t)
    path, number = src.origin(line)
    assert path.endswith("lib/pack.glsl")
    assert Path(path).read_text().splitlines()[number - 1].strip() == "vec2 pack16(float x)"


def test_defines_go_right_after_the_version_line():
    lines = expand("lib/constant.frag", {"FOO": 3, "BAR": None, "SCALE": 0.5}).text.splitlines()
    assert lines[:4] == ["#version 100", "#define FOO 3", "#define BAR", "#define SCALE 0.5"]


def test_compile_error_names_file_line_and_source(gl):
    with pytest.raises(ShaderError) as info:
        gl.program("lib/fullscreen.vert", shader("broken.frag"))
    message = str(info.value)
    assert "broken.frag:9:" in message, message
    assert "undeclared_name" in message
    assert "gl_FragColor = pack2x16(v_uv) + undeclared_name;" in message


def test_error_inside_an_include_names_the_included_file(gl, tmp_path):
    (tmp_path / "bad_lib.glsl").write_text("float helper()\n{\n    return missing_thing;\n}\n")
    main = tmp_path / "main.frag"
    main.write_text('#version 100\nprecision highp float;\n#include "bad_lib.glsl"\n'
                    "void main() { gl_FragColor = vec4(helper()); }\n")
    with pytest.raises(ShaderError, match=r"bad_lib\.glsl:3:"):
        gl.program("lib/fullscreen.vert", str(main))


def test_loader_errors():
    with pytest.raises(ShaderError, match="not found"):
        expand("no/such/file.frag")
    with pytest.raises(ShaderError, match="must start with '#version 100'"):
        expand("lib/pack.glsl")
    with pytest.raises(ShaderError, match="not a GLSL identifier"):
        expand("lib/constant.frag", {"bad name": 1})


def test_shaders_are_found_from_any_working_directory(tmp_path):
    import sys

    code = ("from es2particles.gl.shaders import shader_root, expand;"
            "print(shader_root()); expand('lib/fullscreen.vert')")
    result = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                            text=True)
    assert result.returncode == 0, result.stderr
    assert Path(result.stdout.strip(), "lib", "pack.glsl").is_file()


@pytest.mark.parametrize("target", ["/etc/passwd", "../../../etc/passwd", "lib/../../x.glsl"])
def test_includes_stay_inside_the_shader_folders(tmp_path, target):
    main = tmp_path / "main.frag"
    main.write_text(f'#version 100\n#include "{target}"\nvoid main() {{}}\n')
    with pytest.raises(ShaderError, match="includes are relative paths") as info:
        expand(str(main))
    assert "root:" not in str(info.value)  # nothing of the file is echoed


def test_an_include_next_to_the_user_file_still_works(tmp_path):
    (tmp_path / "helpers.glsl").write_text("float twice(float x) { return 2.0 * x; }\n")
    main = tmp_path / "main.frag"
    main.write_text('#version 100\n#include "helpers.glsl"\n#include "lib/pack.glsl"\nvoid main() {}\n')
    text = expand(str(main)).text
    assert "float twice(float x)" in text and "vec2 pack16(float x)" in text
