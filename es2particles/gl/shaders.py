"""Loading GLSL ES 1.00 sources: includes, injected defines, and errors that point at the file.

A shader file starts with ``#version 100``. ``#include "lib/pack.glsl"`` pastes another file (looked
up next to the including file, then in the library root); each file is pasted once per shader and
nesting is capped. ``#define`` lines for variants are injected right after ``#version``. Every line
of the expanded text remembers its file and line, so a driver's compile error is reported against
the file a person edits, not the expanded text the driver saw.
"""

import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from ..errors import ShaderError

GENERATED = "<generated>"  # the origin of the lines bindings.py writes

MAX_INCLUDE_DEPTH = 16
_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')
_VERSION = re.compile(r"^\s*#\s*version\b")
_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


@lru_cache(maxsize=None)
def shader_root():
    """The folder that holds the library's GLSL ES 1.00 files (looked up once: every include
    asks for it, and the package does not move while it runs).

    An installed package carries them as ``es2particles/_shaders/glsl100``; a source checkout (or an
    editable install) has them once, at the top-level ``shaders/glsl100``.
    """
    here = Path(__file__).resolve().parent.parent  # the package's folder
    for candidate in (here / "_shaders" / "glsl100", here.parent / "shaders" / "glsl100"):
        if candidate.is_dir():
            return candidate
    raise ShaderError(f"the shader library is missing: looked for {here / '_shaders' / 'glsl100'} "
                      f"and {here.parent / 'shaders' / 'glsl100'}; reinstall es2particles")


def find_shader(name, near=None):
    """Path of shader ``name``: next to ``near`` (for includes), in the library, or as given."""
    candidates = []
    if near is not None:
        candidates.append(Path(near).parent / name)
    candidates.append(shader_root() / name)
    candidates.append(Path(name))
    for path in candidates:
        if path.is_file():
            return path.resolve()
    looked = ", ".join(str(p) for p in candidates)
    raise ShaderError(f"shader file {name!r} not found (looked at: {looked})")


def find_include(name, near=None):
    """Path of included file ``name``: a relative path inside the including file's folder or the
    library (never absolute, never through '..', and a link may not lead out), so an include reads
    only shader folders."""
    relative = Path(name)
    if relative.is_absolute() or ".." in relative.parts or not relative.parts:
        raise ShaderError(f"#include {name!r}: includes are relative paths inside the library or "
                          "the including file's folder (no absolute path, no '..')")
    # ``near`` is a resolved path (find_shader's, or this function's): its folder needs no
    # resolving again.
    folders = ([Path(near).parent] if near is not None else []) + [shader_root()]
    for folder in folders:
        candidate = folder / relative
        if not candidate.is_file():  # one stat; resolving walks every part of the path
            continue
        candidate = candidate.resolve()
        if folder in candidate.parents:
            return candidate
    looked = ", ".join(str(folder / relative) for folder in folders)
    raise ShaderError(f"shader file {name!r} not found (looked at: {looked})")


@dataclass(frozen=True)
class ExpandedSource:
    """Expanded GLSL text and, for each of its lines, the (file, line) it came from."""

    text: str
    origins: tuple

    def origin(self, line_number):
        """(path, line) of 1-based line ``line_number`` of the expanded text, or None."""
        if 1 <= line_number <= len(self.origins):
            return self.origins[line_number - 1]
        return None


def expand(name, defines=None, prelude=None, epilogue=None):
    """Expand shader ``name`` with its includes and ``defines`` (a dict; a None value defines a bare
    flag), the ``prelude`` lines (the interface ``bindings.py`` writes; they may include
    library files) between the defines and the file, and the ``epilogue`` lines after the file.
    Returns an :class:`ExpandedSource`."""
    path = find_shader(name)
    lines = _read(path).splitlines()
    first = next((i for i, line in enumerate(lines) if line.strip()), None)
    if first is None or not re.match(r"^\s*#\s*version\s+100\s*$", lines[first]):
        raise ShaderError(f"{path}:{(first or 0) + 1}: a shader must start with '#version 100' "
                          "(GLSL ES 1.00)")
    out = [(lines[first], (str(path), first + 1))]
    for key, value in (defines or {}).items():
        if not _IDENT.match(str(key)):
            raise ShaderError(f"define name {key!r} is not a GLSL identifier")
        text = f"#define {key}" if value is None else f"#define {key} {_glsl_literal(value)}"
        out.append((text, ("<defines>", 0)))
    seen = {path}
    if prelude:
        _paste(GENERATED, list(prelude), 0, out, seen, depth=0)
    _paste(path, lines, first + 1, out, seen, depth=0)
    if epilogue:
        _paste(GENERATED, list(epilogue), 0, out, seen, depth=0)
    return ExpandedSource("\n".join(t for t, _ in out) + "\n", tuple(o for _, o in out))


def _paste(path, lines, start, out, seen, depth):
    where = str(path)  # once a file, not once a line
    for number, line in enumerate(lines[start:], start + 1):
        include = _INCLUDE.match(line)
        if include is None:
            if _VERSION.match(line):
                raise ShaderError(f"{path}:{number}: '#version' may only stand at the top of a "
                                  "shader, not in an included file")
            out.append((line, (where, number)))
            continue
        if depth >= MAX_INCLUDE_DEPTH:
            raise ShaderError(f"{path}:{number}: includes nest deeper than {MAX_INCLUDE_DEPTH}")
        try:
            # Generated lines include library files only: nothing next to the user's file.
            child = find_include(include.group(1), near=None if path == GENERATED else path)
        except ShaderError as error:
            raise ShaderError(f"{path}:{number}: {error}") from None
        if child in seen:  # included once: a second include of a file is a no-op
            continue
        seen.add(child)
        _paste(child, _read(child).splitlines(), 0, out, seen, depth + 1)


def _read(path):
    """A shader file's text; GLSL ES 1.00 sources are ASCII, so anything undecodable is an error
    naming the file."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise ShaderError(f"{path}: not a text file (byte {error.start} is not UTF-8); GLSL "
                          "sources are text") from None


def _glsl_literal(value):
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        text = repr(value)
        return text if ("." in text or "e" in text) else text + ".0"
    return str(value)


# Driver log formats: Mesa "0:12(5): error", NVIDIA "0(12) : error", ANGLE/others "ERROR: 0:12:".
_LOG_LINE = re.compile(r"^\s*(?:ERROR:\s*|WARNING:\s*)?\d+\s*(?::(\d+)|\((\d+)\))(?:\(\d+\))?\s*:?\s*(.*)$")


def describe_log(log, source):
    """Rewrite a driver's compile log so each message names the original file, line and text."""
    described = []
    for raw in log.splitlines():
        if not raw.strip():
            continue
        match = _LOG_LINE.match(raw)
        origin = source.origin(int(match.group(1) or match.group(2))) if match else None
        if origin is None:
            described.append(raw.strip())
            continue
        file, line = origin
        text = (source.text.splitlines()[int(match.group(1) or match.group(2)) - 1].strip()
                if file == GENERATED else _source_line(file, line))
        described.append(f"{file}:{line}: {match.group(3).strip()}" + (f"\n    {line:4d} | {text}" if text else ""))
    return "\n".join(described)


def _source_line(file, line):
    try:
        return Path(file).read_text().splitlines()[line - 1].strip()
    except (OSError, IndexError):
        return ""


def compile_program(device, vertex, fragment, sources):
    """Compile and link a program on ``device`` (see ``device.py``) from ``sources``, the two
    :class:`ExpandedSource` (see :func:`expand`) of shader files ``vertex`` and ``fragment``.

    Raises :class:`ShaderError` naming the file and line of each driver message.
    """
    from .device import ProgramError

    vs, fs = sources
    try:
        return device.program(vs.text, fs.text)
    except ProgramError as error:
        raise ShaderError(_explain(str(error), vs, fs, vertex, fragment)) from None


def _explain(message, vs, fs, vertex, fragment):
    if "vertex_shader" in message:
        stage, source = f"vertex shader {vertex}", vs
    elif "fragment_shader" in message:
        stage, source = f"fragment shader {fragment}", fs
    else:
        return f"linking {vertex} with {fragment} failed:\n{message.strip()}"
    log = message.split("=\n", 1)[-1]
    return f"{stage} failed to compile:\n{describe_log(log, source)}"
