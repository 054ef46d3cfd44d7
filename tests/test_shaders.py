"""Shader loading: every shader is valid GLSL ES 1.00 for the Khronos reference compiler, includes
and defines expand as documented, and errors name the file and the line."""

import re
import subprocess
from pathlib import Path

import pytest

from conftest import TEST_SHADERS, glslang, shader
from es2particles import ShaderError
from es2particles.shaders import expand, shader_root

def variants(path):
    """The default build and one build per flag the shader tests (#ifdef / defined()), so every
    branch is compiled. Flags with values (#define NAME value) keep their defaults; the dither
    flag is for fragment shaders only (it reads gl_FragCoord)."""
    text = expand(path).text
    flags = set(re.findall(r"#\s*ifn?def\s+(\w+)", text)) | set(re.findall(r"defined\((\w+)\)", text))
    valued = set(re.findall(r"#[ \t]*define[ \t]+(\w+)[ \t]+\S", text))
    flags -= valued
    if path.endswith(".vert"):
        flags.discard("STATE_DITHER")
    return [{}] + [{flag: None} for flag in sorted(flags)]


def all_shaders():
    root = shader_root()
    library = sorted(p for p in root.rglob("*") if p.suffix in (".vert", ".frag"))
    tests = sorted(p for p in TEST_SHADERS.glob("*") if p.suffix in (".vert", ".frag")
                   and p.name != "broken.frag")
    return [str(p) for p in library + tests]


BUILDS = [(path, defines) for path in all_shaders() for defines in variants(path)]


@pytest.mark.parametrize("path, defines", BUILDS,
                         ids=[f"{Path(p).name}-{next(iter(d), 'default')}" for p, d in BUILDS])
def test_every_shader_is_valid_glsl_es_100(path, defines, tmp_path):
    tool = glslang()
    source = expand(path, defines).text
    assert source.startswith("#version 100\n")
    target = tmp_path / ("expanded" + Path(path).suffix)
    target.write_text(source)
    result = subprocess.run([tool, str(target)], capture_output=True, text=True)
    assert result.returncode == 0, f"{path} ({defines}) rejected:\n{result.stdout}{result.stderr}"


def test_includes_paste_each_file_once_and_keep_origins():
    src = expand(shader("copy.frag"))
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

    code = ("from es2particles.shaders import shader_root, expand;"
            "print(shader_root()); expand('lib/fullscreen.vert')")
    result = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                            text=True)
    assert result.returncode == 0, result.stderr
    assert Path(result.stdout.strip(), "lib", "pack.glsl").is_file()
