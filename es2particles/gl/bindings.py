"""The GLSL interface of a stage, written from its declaration (as pygfx writes its bindings).

A pass declares what it reads, writes, samples and sets; this module writes the declarations its
shader sees, placed after ``#version`` and the defines, so the shader holds only its logic and the
two can never disagree:

- ``varying vec2 v_uv``: the texel of the particle being computed (full-screen passes);
- for each quantity ``q`` read or written: ``uniform vec4 u_q_lo, u_q_span`` (its range, one
  number per component);
- for each quantity read: its samplers ``u_q`` (and ``u_q_1``, the second RGBA8 part of a quantity
  of 3 or 4 components) and ``read_q(uv)``, returning float, vec2, vec3 or vec4; a vertex stage
  without vertex texture fetch reads attributes ``a_q`` (and ``a_q_1``) instead, the texels read
  back into a vertex buffer each frame, through the same ``read_q(uv)``;
- for the written quantity: ``write_q(value)`` (and ``write(value)``, the same, for a shader that
  several passes share), which sets the part this draw writes (ES 2.0 has one render target: a
  two-part quantity is written by two draws); the shader's ``main`` is renamed, and a generated
  ``main`` after it calls it and writes gl_FragColor once, outside any branch (the epilogue);
- ``uniform sampler2D u_t`` for each scene texture ``t`` the pass samples;
- each of the pass's own uniforms, typed from its value: a number is a float, 2 to 4 numbers a
  vec2..vec4, a (k, n) array a vecn[k];
- ``u_state_size`` (texels, vec2) and ``u_count`` (elements) of the domain the stage runs over;
  ``u_step`` comes with lib/state.glsl;
- for each grid ``G`` whose quantities a pass reads or writes: ``u_G_size`` (cells, vec2) and
  ``u_G_box`` (its world rectangle x0, y0, x1, y1); for each grid quantity ``q`` read, beside
  ``read_q(uv)``: ``q_at(cell)`` (the value of cell (i, j), clamped to the grid: stencils) and
  ``sample_q(point)`` (bilinear at a world point, from the four decoded cells around it: linear
  filtering of packed bytes would mix high and low bytes) and ``G_uv(cell)`` (the texture
  coordinate of a cell, where a scene texture laid out as the grid holds it too); a pass over a
  grid gets
  ``grid_cell()`` (the (i, j) it computes) and ``grid_point()`` (that cell's centre). On a 3D
  grid (an atlas of slices) the same take and give vec3: ``q_at(vec3 cell)``, a trilinear
  ``sample_q(vec3 point)`` across slices, ``grid_cell()`` (i, j, k), with ``u_G_size`` (W, H,
  D), ``u_G_lo``/``u_G_hi`` (the box's corners) and ``u_G_tiles`` (the atlas's columns, rows).

Pure Python, no GL: the executor compiles what is written here, and tests read it.
"""

import re
from dataclasses import dataclass, field

import numpy as np

from ..errors import GraphError, ParameterError, ShaderError
from .shaders import GENERATED

GLSL_TYPES = {1: "float", 2: "vec2", 3: "vec3", 4: "vec4"}
# The last input of lib/state.glsl's read jitter, by reader, so that a pass's read and a draw's
# read of the same state at the same step get independent offsets (a dithered write uses 17).
READ_SALTS = {"pass": 29.0, "draw": 41.0}


def glsl_type(name, value):
    """(type, array suffix) of uniform ``name`` for its value: ('vec2', ''), ('vec2', '[6]')."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        array = None
    if array is not None and np.all(np.isfinite(array)):
        if array.ndim == 0:
            return "float", ""
        if array.ndim == 1 and 2 <= len(array) <= 4:
            return GLSL_TYPES[len(array)], ""
        if array.ndim == 2 and array.shape[0] >= 1 and 1 <= array.shape[1] <= 4:
            return GLSL_TYPES[array.shape[1]], f"[{array.shape[0]}]"
    raise ParameterError(f"uniform {name}: value must be finite: a number, 2 to 4 numbers, or a "
                         f"(k, 1..4) array, got {value!r}")


def uniform_value(name, value, declared):
    """``value`` in the form moderngl takes for a uniform of type ``declared``; checks it fits."""
    got = glsl_type(name, value)
    if got != declared:
        raise ParameterError(f"uniform {name} is a {''.join(declared)}; got {value!r}, a "
                             f"{''.join(got)}")
    array = np.asarray(value, dtype=np.float64)
    if array.ndim == 0:
        return float(array)
    if array.ndim == 1:
        return tuple(map(float, array))
    return [tuple(map(float, row)) if len(row) > 1 else float(row[0]) for row in array]


@dataclass
class Interface:
    """What the generated lines declare, so the executor can feed and check them.

    ``samplers``: sampler name -> ('quantity', name, part, this_step) or ('texture', name).
    ``attributes``: attribute name -> (quantity, part), a quantity's texels read back.
    ``uniforms``: the stage's own uniform name -> (type, array suffix).
    ``fixed``: uniforms set once from the declaration (ranges), name -> value.
    ``writes``: (quantity, part) of a pass's draw, or None.
    ``epilogue``: lines after the shader's own (a pass's real main, see ``_writer``).
    """

    lines: list = field(default_factory=list)
    samplers: dict = field(default_factory=dict)
    attributes: dict = field(default_factory=dict)
    uniforms: dict = field(default_factory=dict)
    fixed: dict = field(default_factory=dict)
    writes: tuple = None
    epilogue: list = field(default_factory=list)

    owners: dict = field(default_factory=dict)  # generated name -> what declared it

    def declare(self, line, name, what):
        """Add a declaration line; a name declared twice (a texture and a quantity both ``pos``,
        a quantity ``pos_1`` beside the second part of ``pos``, a uniform named like a range)
        is an error naming both."""
        if name in self.owners:
            raise GraphError(f"{name} would be declared twice, for {self.owners[name]} and for "
                             f"{what}: rename one of them")
        self.owners[name] = what
        self.lines.append(line)

    @property
    def names(self):
        """Every name the generated lines declare (u_step is lib/state.glsl's: it counts for
        clashes, in ``owners``, but the library declares it)."""
        return set(self.owners) - {"u_step"}

    @property
    def text(self):
        return "\n".join(self.lines)


def _fixed(out, values, what):
    """Declare each uniform of ``values`` (name -> value, typed from it) once, set from the
    declaration (``Interface.fixed``)."""
    for name, value in values.items():
        if name not in out.owners:
            kind, suffix = glsl_type(name, value)
            out.declare(f"uniform {kind} {name}{suffix};", name, what)
    out.fixed.update(values)


def _ranges(out, quantity):
    _fixed(out, quantity.uniforms(), f"the range of quantity {quantity.name!r}")


def _reader(out, quantity, fmt, this_step, salt, hardware=False):
    q, c, fmt = quantity.name, quantity.components, quantity.format_in(fmt)
    _ranges(out, quantity)
    samplers = [f"u_{q}" if part == 0 else f"u_{q}_{part}" for part in range(quantity.parts(fmt))]
    for part, sampler in enumerate(samplers):
        out.declare(f"uniform sampler2D {sampler};", sampler, f"part {part + 1} of quantity {q!r}")
        out.samplers[sampler] = ("quantity", q, part, this_step)
    grid = quantity.domain
    # A grid's cells are read exactly (no jitter): a stencil's or a bilinear sample's four reads
    # must see the values stored, not four independent samples of their codes.
    _read_function(out, q, c, fmt, [f"texture2D({s}, uv)" for s in samplers],
                   None if quantity.storage or grid is not None else salt)
    if grid is not None:
        _grid_addressing(out, grid)
        out.lines += (_grid_reads_2d if grid.dimensions == 2 else _grid_reads_3d)(
            q, grid.name, GLSL_TYPES[c], hardware)
        out.owners.setdefault(f"{q}_at", f"quantity {q!r}")
        out.owners.setdefault(f"sample_{q}", f"quantity {q!r}")


def _grid_addressing(out, grid):
    """What a shader over or reading grid ``G`` addresses its cells by, declared once: its
    uniforms (``u_G_size``...), a 3D grid's ``G_tile(k)``, and ``G_uv(cell)``, the texture
    coordinate of cell (i, j) (3D: (i, j, k)): a texel centre of the grid's texture or atlas,
    where a scene texture laid out as the grid (``Grid.image``) holds that cell too."""
    _grid_uniforms(out, grid)
    g = grid.name
    if f"{g}_uv" in out.owners:
        return
    if grid.dimensions == 2:
        out.declare(f"vec2 {g}_uv(vec2 cell)  // the texel of cell (i, j)", f"{g}_uv",
                    f"the cells of grid {g!r}")
        out.lines += ["{", f"    return (cell + 0.5) / u_{g}_size;", "}"]
        return
    _grid_tile(out, g)
    out.declare(f"vec2 {g}_uv(vec3 cell)  // the atlas texel of cell (i, j, k)", f"{g}_uv",
                f"the cells of grid {g!r}")
    out.lines += ["{", f"    return ({g}_tile(cell.z) + cell.xy + 0.5) / "
                       f"(u_{g}_size.xy * u_{g}_tiles);", "}"]


def _grid_reads_2d(q, g, kind, hardware):
    """``q_at(cell)`` and ``sample_q(point)`` of a quantity on 2D grid ``g``; with ``hardware``
    (a float texture filtered LINEAR) the sample is one fetch, its point held within the
    outer cells' centres (the edge cells extend outwards, as by hand)."""
    at = [f"{kind} {q}_at(vec2 cell)  // cell (i, j) of grid {g}, clamped to the grid",
          "{", f"    return read_{q}({g}_uv(clamp(floor(cell), vec2(0.0), u_{g}_size - 1.0)));",
          "}"]
    where = f"(point - u_{g}_box.xy) / (u_{g}_box.zw - u_{g}_box.xy) * u_{g}_size - 0.5"
    if hardware:
        return at + [
            f"{kind} sample_{q}(vec2 point)  // bilinear at a world point, by the hardware",
            "{", f"    vec2 c = clamp({where}, vec2(0.0), u_{g}_size - 1.0);",
            f"    return read_{q}({g}_uv(c));", "}"]
    return at + [
        f"{kind} sample_{q}(vec2 point)  // bilinear at a world point, from decoded cells",
        "{", f"    vec2 c = {where};",
        "    vec2 i = floor(c);", "    vec2 t = c - i;",
        f"    return mix(mix({q}_at(i), {q}_at(i + vec2(1.0, 0.0)), t.x),",
        f"               mix({q}_at(i + vec2(0.0, 1.0)), {q}_at(i + vec2(1.0, 1.0)), t.x), "
        "t.y);", "}"]


def _grid_tile(out, g):
    """``G_tile(k)``, the atlas texel of 3D grid ``G``'s slice k's cell (0, 0), declared once."""
    if f"{g}_tile" not in out.owners:
        out.declare(f"vec2 {g}_tile(float k)  // the atlas texel of slice k's cell (0, 0)",
                    f"{g}_tile", f"the atlas of grid {g!r}")
        out.lines += ["{", f"    float row = floor((k + 0.5) / u_{g}_tiles.x);",
                      f"    return vec2(k - row * u_{g}_tiles.x, row) * u_{g}_size.xy;", "}"]


def _grid_reads_3d(q, g, kind, hardware):
    """``q_at(cell)`` and ``sample_q(point)`` of a quantity on 3D grid ``g``: cell (i, j, k)
    is texel (i, j) of slice k's tile in the atlas; the sample is trilinear across slices: by
    hand from eight decoded cells, or (``hardware``) from two bilinear fetches, one in each
    slice's tile, held within its outer cells' centres so no tap reaches the next tile."""
    def at(dx, dy, dz):
        return f"{q}_at(i + vec3({dx}.0, {dy}.0, {dz}.0))"

    def plane(dz):  # bilinear in slice k + dz
        return (f"mix(mix({at(0, 0, dz)}, {at(1, 0, dz)}, t.x), "
                f"mix({at(0, 1, dz)}, {at(1, 1, dz)}, t.x), t.y)")
    at_lines = [
        f"{kind} {q}_at(vec3 cell)  // cell (i, j, k) of grid {g}, clamped to the grid",
        "{", f"    return read_{q}({g}_uv(clamp(floor(cell), vec3(0.0), u_{g}_size - 1.0)));",
        "}"]
    where = f"(point - u_{g}_lo) / (u_{g}_hi - u_{g}_lo) * u_{g}_size - 0.5"
    if hardware:
        def tap(k):
            return f"read_{q}({g}_uv(vec3(xy, clamp({k}, 0.0, u_{g}_size.z - 1.0))))"
        sample = [
            f"{kind} sample_{q}(vec3 point)  // trilinear at a world point, by the hardware",
            "{", f"    vec3 c = {where};", "    float k = floor(c.z);",
            f"    vec2 xy = clamp(c.xy, vec2(0.0), u_{g}_size.xy - 1.0);",
            f"    return mix({tap('k')}, {tap('k + 1.0')}, c.z - k);", "}"]
    else:
        sample = [
            f"{kind} sample_{q}(vec3 point)  // trilinear at a world point, from decoded cells",
            "{", f"    vec3 c = {where};", "    vec3 i = floor(c);", "    vec3 t = c - i;",
            f"    {kind} below = {plane(0)};", f"    {kind} above = {plane(1)};",
            "    return mix(below, above, t.z);", "}"]
    return at_lines + sample


def _grid_uniforms(out, grid):
    """``u_G_size`` and ``u_G_box`` of grid ``G``, declared once."""
    _fixed(out, grid.uniforms(), f"the size and box of grid {grid.name!r}")


def _read_function(out, q, c, fmt, texels, salt):
    """``read_q(uv)`` from ``texels``, a GLSL vec4 expression per part: RGBA8 byte pairs
    decoded into the range (with the read's jitter, lib/state.glsl's state_jitter, under
    rounding "jitter"; ``salt`` is :data:`READ_SALTS`' of the reader, None for a quantity
    pinned to its storage, an exact clock, which reads its code), ``rgba8_32`` a value's four
    bytes (read exactly: its step is below float32's), floats as they are."""
    jitter = []  # the offsets of both parts from one hash
    if fmt == "rgba8":
        if salt is not None:
            jitter = [f"    vec4 jitter = state_jitter(uv * u_state_size, {salt:.1f});"]

        def decode(t, axes):
            ranges = f"u_{q}_lo.{axes}, u_{q}_span.{axes}"
            if salt is None:
                return f"state_decode({t}, {ranges})"
            return f"state_read({t}, {ranges}, jitter.{axes})"
        decoded = [decode(t, axes) for t, axes in zip(texels, ("xy", "zw"))]
        if c <= 2:
            body = decoded[0] + (".x" if c == 1 else "")
        else:
            body = f"{GLSL_TYPES[c]}({decoded[0]}, {decoded[1]}{'.x' if c == 3 else ''})"
    elif fmt == "rgba8_32":  # one value a texel, read exactly (lib/state.glsl)
        decoded = [f"state_decode32({t}, u_{q}_lo.{a}, u_{q}_span.{a})"
                   for t, a in zip(texels, "xyzw")]
        body = decoded[0] if c == 1 else f"{GLSL_TYPES[c]}({', '.join(decoded)})"
    else:
        body = texels[0] + ("" if c == 4 else "." + "xyzw"[:c])
    out.lines += [f"{GLSL_TYPES[c]} read_{q}(vec2 uv)", "{", *jitter, f"    return {body};", "}"]


def _attribute_reader(out, quantity, fmt):
    """``read_q(uv)`` from attributes: the quantity's texels, read back into a vertex buffer in
    the draw's order (the texel ``uv`` is needed only by a jittered read's hash: the plan gives
    such a stage the particles' texels), decoded as a texture fetch decodes them: RGBA8 bytes
    normalised to c / 255 as a sampler gives them, floats as they are."""
    q, c, fmt = quantity.name, quantity.components, quantity.format_in(fmt)
    _ranges(out, quantity)
    names = [f"a_{q}" if part == 0 else f"a_{q}_{part}" for part in range(quantity.parts(fmt))]
    for part, name in enumerate(names):
        out.declare(f"attribute vec4 {name};", name,
                    f"part {part + 1} of quantity {q!r}, read back")
        out.attributes[name] = (q, part)
    _read_function(out, q, c, fmt, names, None if quantity.storage else READ_SALTS["draw"])


def _writer(out, quantity, fmt, part):
    q, c, fmt = quantity.name, quantity.components, quantity.format_in(fmt)
    _ranges(out, quantity)
    padded = "value" if c == 4 else f"vec4(value{', 0.0' * (4 - c)})"
    if fmt == "rgba8":
        axes = ("xy", "zw")[part]
        encode = (f"state_encode(v.{axes}, u_{q}_lo.{axes}, u_{q}_span.{axes}, "
                  f"state_noise().{axes})")
    elif fmt == "rgba8_32":
        a = "xyzw"[part]
        encode = f"state_encode32(v.{a}, u_{q}_lo.{a}, u_{q}_span.{a})"
    else:
        encode = f"state_clamp(v, u_{q}_lo, u_{q}_span)"
    # GLSL ES 1.00 declares gl_FragColor mediump, and a driver may honour that where it is written
    # inside a branch (llvmpipe rounds such a write to half floats: float state then kept 11
    # bits). write_q keeps the texel in a highp variable, and the pass's real main, after the
    # shader's own (renamed), writes gl_FragColor once, outside any branch.
    out.declare("vec4 state_written;", "state_written", "the texel the pass writes")
    out.lines += [f"void write_{q}({GLSL_TYPES[c]} value)", "{", f"    vec4 v = {padded};",
                  f"    state_written = {encode};", "}",
                  f"void write({GLSL_TYPES[c]} value)  // the same, for a shader shared by passes",
                  "{", f"    write_{q}(value);", "}",
                  "#define main state_pass_main"]
    out.epilogue = ["#undef main", "void main()", "{", "    state_pass_main();",
                    "    gl_FragColor = state_written;", "}"]
    out.writes = (q, part)


def _own_uniforms(out, uniforms):
    for name, value in uniforms.items():
        if not re.fullmatch(r"[A-Za-z_]\w*", str(name)):
            raise ParameterError(f"uniform name {name!r} is not a GLSL identifier")
        kind = glsl_type(name, value)
        out.declare(f"uniform {kind[0]} {name}{kind[1]};", name, f"the uniform {name!r}")
        out.uniforms[name] = kind


PRELUDE = ["precision highp float;", "precision highp sampler2D;", '#include "lib/state.glsl"',
           "uniform vec2 u_state_size;", "uniform float u_count;"]
BUILT_IN = {"u_state_size": "the built-in u_state_size", "u_count": "the built-in u_count",
            "u_step": "the built-in u_step (lib/state.glsl)"}


def generated_values(interface, layout):
    """The values of what the generated lines declare for a state ``layout``: the quantities'
    ranges, ``u_state_size`` and ``u_count`` (set on EGL by the commands and renderers, written
    into a WebGL page by ``export/page.py``)."""
    return {**interface.fixed, "u_state_size": (float(layout.width), float(layout.height)),
            "u_count": float(layout.count)}


def _grid_cell(g):
    """The bodies of a 2D grid pass's ``grid_cell()`` and ``grid_point()``."""
    return (["{", f"    return floor(v_uv * u_{g}_size);  // the cell (i, j) computed", "}"],
            ["{", f"    return u_{g}_box.xy + (grid_cell() + 0.5) / u_{g}_size * "
                  f"(u_{g}_box.zw - u_{g}_box.xy);", "}"])


def _grid_cell_3d(g):
    """The bodies of a 3D grid pass's ``grid_cell()`` (the cell (i, j, k) of the atlas texel
    computed; k >= D on a spare tile) and ``grid_point()``."""
    return (["{", f"    vec2 texel = floor(v_uv * u_{g}_size.xy * u_{g}_tiles);",
             f"    vec2 tile = floor((texel + 0.5) / u_{g}_size.xy);",
             f"    return vec3(texel - tile * u_{g}_size.xy, tile.y * u_{g}_tiles.x + tile.x);",
             "}"],
            ["{", f"    return u_{g}_lo + (grid_cell() + 0.5) / u_{g}_size * "
                  f"(u_{g}_hi - u_{g}_lo);", "}"])


def pass_interface(spec, quantities, fmt, part=0, neighbours=None, hardware=frozenset()):
    """The interface of draw ``part`` of pass ``spec`` (a :class:`~es2particles.frame.graph.Pass`);
    ``neighbours``: (lines, samplers, fixed uniforms) of the neighbour grid it reads
    (``frame/neighbours.py``: interface_lines), declared before ``lib/neighbours.glsl``;
    ``hardware``: the grid quantities whose samples the hardware filters (their textures are
    LINEAR: ``frame/plan.py``'s _sampled_grids)."""
    out = Interface(lines=list(PRELUDE) + ["varying vec2 v_uv;"],
                    owners={**BUILT_IN, "v_uv": "the built-in v_uv"})
    grid = quantities[spec.writes].domain
    if grid is not None:
        _grid_addressing(out, grid)
        out.declare(f"{GLSL_TYPES[grid.dimensions]} grid_cell()", "grid_cell",
                    "the built-in grid_cell()")
        cell, point = (_grid_cell if grid.dimensions == 2 else _grid_cell_3d)(grid.name)
        out.lines += cell
        out.declare(f"{GLSL_TYPES[grid.dimensions]} grid_point()", "grid_point",
                    "the built-in grid_point()")
        out.lines += point
    for name in spec.reads:
        _reader(out, quantities[name], fmt, False, READ_SALTS["pass"], name in hardware)
    for name in spec.reads_new:
        if name != spec.neighbours:
            _reader(out, quantities[name], fmt, True, READ_SALTS["pass"], name in hardware)
    if spec.neighbours is not None:
        if neighbours is None:
            raise GraphError(f"pass {spec.name!r} reads neighbour grid {spec.neighbours!r}, "
                             "which the plan did not build")
        lines, samplers, fixed = neighbours
        out.lines += lines
        _fixed(out, fixed, f"neighbour grid {spec.neighbours!r}")
        for sampler, source in samplers.items():
            out.declare(f"uniform sampler2D {sampler};", sampler,
                        f"neighbour grid {spec.neighbours!r}")
            out.samplers[sampler] = source
        out.lines.append('#include "lib/neighbours.glsl"')
    for name in spec.textures:
        out.declare(f"uniform sampler2D u_{name};", f"u_{name}", f"texture {name!r}")
        out.samplers[f"u_{name}"] = ("texture", name)
    _own_uniforms(out, spec.uniforms)
    _writer(out, quantities[spec.writes], fmt, part)
    return out


def stage_interface(reads, quantities, fmt, uniforms=None, attributes=False, this_step=False):
    """The interface of a vertex stage that reads quantities at a texel (a renderer): by vertex
    texture fetch, or with ``attributes`` from the texels read back into vertex buffers.
    ``this_step``: the reads are of this step's values (a stage of the step that follows their
    writers: a neighbour grid's key pass)."""
    out = Interface(lines=list(PRELUDE), owners=dict(BUILT_IN))
    for name in reads:
        if attributes:
            _attribute_reader(out, quantities[name], fmt)
        else:
            _reader(out, quantities[name], fmt, this_step, READ_SALTS["draw"])
    _own_uniforms(out, uniforms or {})
    return out


_COMMENTS = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
DECLARATIONS = re.compile(r"\b(uniform|varying|attribute)\s+(?:(?:lowp|mediump|highp)\s+)?(\w+)"
                          r"\s+([^;]+);")


def strip_comments(text):
    """``text`` without comments, each replaced by as many line breaks as it held (line numbers
    stay)."""
    return _COMMENTS.sub(lambda m: "\n" * m.group(0).count("\n"), text)


def declared_names(text):
    """(kind, type, name, line) of every uniform/varying/attribute declared in ``text`` (comments
    stripped first; several per statement and statements across lines included; ``line`` is
    1-based, where the statement starts)."""
    clean = strip_comments(text)
    out = []
    for match in DECLARATIONS.finditer(clean):
        line = clean.count("\n", 0, match.start()) + 1
        for name in match.group(3).split(","):
            out.append((match.group(1), match.group(2), name.strip().split("[")[0].strip(), line))
    return out


def check_writes(source, interface, stage):
    """Raise :class:`ShaderError` if a pass's shader never names its ``write_<q>`` (or
    ``write``): a pass must write the quantity it declares. A call through a macro counts."""
    if interface.writes is None:
        return
    q = interface.writes[0]
    own = "\n".join(line for line, (file, _) in zip(strip_comments(source.text).split("\n"),
                                                      source.origins) if file != GENERATED)
    if not re.search(rf"\bwrite(_{q})?\b", own):
        raise ShaderError(f"{stage} never calls write_{q}(value): a pass must write the "
                          f"quantity it declares (writes={q!r})")


def explain_redeclaration(source, interface, stage):
    """After a failed compile: the clear message if the shader declares a name the interface
    declares for it (GLSL says only 'redeclaration'), else None. Run only then, so a declaration
    in an inactive #if branch is never taken for one."""
    generated = interface.names
    for _, _, name, line_number in declared_names(source.text):
        file, number = source.origin(line_number)
        if file != GENERATED and name in generated:
            text = source.text.splitlines()[line_number - 1].strip()
            return (f"{file}:{number}: {stage} declares {name!r}, which the graph declares "
                    f"for it from the pass's declaration; remove this line\n    "
                    f"{number:4d} | {text}")
    return None


def compile_checked(compile, source, interface, stage):
    """``compile()`` after the write check; a failed compile caused by redeclaring a generated
    name is reported as such."""
    check_writes(source, interface, stage)
    try:
        return compile()
    except ShaderError:
        message = explain_redeclaration(source, interface, stage)
        if message is None:
            raise
        raise ShaderError(message) from None
