"""One draw command for every draw: a program, its primitive and vertex data, its samplers and
uniforms by name, and the GL state of its draw.

Every draw of the package is one of these: simulation passes, the density points, sprites, meshes,
the shadow map, the sort's key and merge passes, the post stages and the context's format probe
(regl: "a command is a complete representation of the WebGL state required to perform some draw
call"). A command owns its vertex array (through its component's
:class:`~es2particles.gl.context.Group`), gives each sampler its program really uses a texture
unit by name (nobody numbers units by hand), and is strict about names, with one policy
everywhere:

- a uniform given to it must be declared by its sources (the shader files or the generated
  interface) and used by the shader's own code; a misspelled or unused name is an error naming
  the stage, the shader files and the name, where GL would drop it silently;
- every sampler the program uses must be fed on every draw, and a texture given for a sampler
  the sources never declare is an error;
- its :class:`~es2particles.gl.device.DrawState` is set for its draw and switched off again after
  it, even when an exception passes through (the device's draw).

Whether the driver keeps a used uniform active is its own business (one whose result is never
written is optimised away, and drivers differ there), so a used uniform the driver dropped is
skipped, not an error.
"""

import functools
import re
from types import MappingProxyType

from ..errors import ParameterError
from .bindings import compile_checked, declared_names, strip_comments
from .context import ProgramValues
from .device import PRIMITIVES, DrawState
from .shaders import GENERATED

FULLSCREEN = "lib/fullscreen.vert"


class DrawCommand:
    """A program and everything its draws need.

    Parameters
    ----------
    group : Group
        The owner of the command's vertex array (and, with ``vertices``, of nothing else: the
        buffers in ``vertices`` belong to whoever made them).
    stage : str
        How errors and plans name the command ("pass 'drift'", "post stage bloom blur").
    fragment : str
        The fragment shader: a library name or a path.
    vertex : str
        The vertex shader; the full-screen triangle's by default.
    defines : mapping, optional
    interface, vertex_interface : bindings.Interface, optional
        The generated interface of the fragment shader (a pass) or of the vertex shader (a stage
        that reads particles at a texel), placed before the shader's own lines and checked against
        them (``bindings.compile_checked``).
    vertices : list, optional
        moderngl-style vertex array content ``[(buffer, "2f", "a_texel"), ...]``; None draws the
        full-screen triangle.
    primitive : str
        ``triangles`` or ``points``.
    indices : buffer, optional
        uint32 vertex indices the draws walk (a static index buffer; its owner's).
    state : DrawState
        Blending, depth, point size and sprites of every draw of the command.
    """

    def __init__(self, group, stage, fragment, vertex=FULLSCREEN, defines=None, interface=None,
                 vertex_interface=None, vertices=None, primitive="triangles", state=DrawState(),
                 indices=None):
        if primitive not in PRIMITIVES:
            raise ParameterError(f"{stage}: primitive must be one of {PRIMITIVES}, got "
                                 f"{primitive!r}")
        self.ctx, self.stage, self.primitive, self.state = group.ctx, stage, primitive, state
        self.files = (str(vertex), str(fragment)) if vertex != FULLSCREEN else (str(fragment),)
        self.fragment = fragment
        fs_prelude = interface.lines if interface is not None else None
        epilogue = interface.epilogue if interface is not None else None
        vs_prelude = vertex_interface.lines if vertex_interface is not None else None
        sources = self.ctx.sources(vertex, fragment, defines, vs_prelude, fs_prelude, epilogue)
        self.declared, self.referenced = {}, set()
        for source in sources:
            declared, referenced = _names(source)
            self.declared.update(declared)
            self.referenced |= referenced

        def compile():
            return self.ctx.program(vertex, fragment, defines, vertex_prelude=vs_prelude,
                                    fragment_prelude=fs_prelude, fragment_epilogue=epilogue)

        for checked, source in ((vertex_interface, sources[0]), (interface, sources[1])):
            if checked is not None:
                compile = _checked(compile, source, checked, self.where())
        self.program = compile()
        if vertices is None:
            self.vertex_array = group.fullscreen(self.program)
        else:
            self.vertex_array = group.vertex_array(self.program, vertices, indices)
        active = self.ctx.device.uniforms(self.program)
        self.active = set(active)
        self.samplers = sorted(name for name, u in active.items() if u.sampler)
        self.lengths = {name: u.length for name, u in active.items()}
        self.units = {name: unit for unit, name in enumerate(self.samplers)}
        self.values = ProgramValues(self.ctx, self.program)  # the program may be shared
        for name, unit in self.units.items():
            self.values.set(name, unit)

    def where(self):
        return f"{self.stage} ({', '.join(self.files)})"

    def has(self, name):
        """True if ``name`` is an active uniform of the program."""
        return name in self.active

    def set(self, name, value):
        """Set uniform ``name``: declared and used by the shader, else an error."""
        if self.declared.get(name) == "sampler2D":
            raise ParameterError(f"{self.where()}: {name!r} is a sampler; it is fed a texture, "
                                 "not given a value")
        if name not in self.declared or name not in self.referenced:
            uniforms = sorted(n for n, kind in self.declared.items()
                              if kind != "sampler2D" and n in self.referenced)
            how = "does not declare it" if name not in self.declared else "never uses it"
            raise ParameterError(f"{self.where()}: uniform {name!r} is given, but the shader "
                                 f"{how} (uniforms it uses: {', '.join(uniforms) or 'none'})")
        if name not in self.active:
            return  # used, but its result is never written: the driver dropped it
        length = self.lengths[name]
        try:
            if isinstance(value, list):
                value = value[:length]  # the driver keeps only the used elements
                if length == 1:
                    value = value[0]  # moderngl takes an array of one as its element
            self.values.set(name, value)
        except Exception as error:
            raise ParameterError(f"{self.where()}: uniform {name!r} cannot take {value!r} "
                                 f"({error})") from None

    def set_many(self, uniforms):
        for name, value in uniforms.items():
            self.set(name, value)

    def check_fed(self, samplers):
        """Raise unless ``samplers`` (names) covers every sampler the program uses and names no
        sampler its sources never declare."""
        unfed = [name for name in self.samplers if name not in samplers]
        if unfed:
            raise ParameterError(f"{self.where()}: sampler {', '.join(map(repr, unfed))} is used "
                                 f"by the shader but nothing feeds it (fed: "
                                 f"{', '.join(sorted(samplers)) or 'nothing'})")
        unknown = [name for name in samplers if self.declared.get(name) != "sampler2D"]
        if unknown:
            raise ParameterError(f"{self.where()}: a texture is given for "
                                 f"{', '.join(map(repr, unknown))}, which the shader does not "
                                 f"declare as a sampler (its samplers: "
                                 f"{', '.join(self.samplers) or 'none'})")

    def draw(self, framebuffer, textures, uniforms=None, first=0, count=None):
        """Draw into ``framebuffer`` with ``textures`` (sampler name -> texture), after setting
        ``uniforms`` (name -> value, by :meth:`set`): the full-screen triangle, or ``count``
        vertices from ``first`` (None: all of the vertex data)."""
        for name, value in (uniforms or {}).items():
            self.set(name, value)
        if len(textures) != len(self.samplers) or any(s not in textures for s in self.samplers):
            self.check_fed(textures)
        bound = {self.units[name]: textures[name] for name in self.samplers}
        self.ctx.make_current()
        self.values.current()
        self.ctx.device.draw(self.vertex_array, framebuffer, bound, self.state, self.primitive,
                             first, count, self.stage)


def _checked(compile, source, interface, stage):
    return lambda: compile_checked(compile, source, interface, stage)


@functools.lru_cache(maxsize=256)  # commands sharing a program share its sources (Context)
def _names(source):
    """(uniform name -> type declared anywhere, identifiers the non-generated code uses outside
    declarations). Comments are stripped across lines; several declarations per statement and
    statements across lines count."""
    declared = {name: glsl_type for kind, glsl_type, name, _ in declared_names(source.text)
                if kind == "uniform"}
    code = strip_comments(source.text)
    code = re.sub(r"\b(?:uniform|varying|attribute)\b[^;]*;",
                  lambda m: "\n" * m.group(0).count("\n"), code)
    referenced = set()
    for line, (file, _) in zip(code.split("\n"), source.origins):
        if file != GENERATED:
            referenced.update(re.findall(r"[A-Za-z_]\w*", line))
    return MappingProxyType(declared), frozenset(referenced)  # cached: read-only
