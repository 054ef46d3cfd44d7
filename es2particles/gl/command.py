"""One full-screen command type: a fragment shader drawn over a whole target.

Every full-screen draw of the package is one of these: the simulation's passes, the post chain's
stages and the context's format probe. A command owns its vertex array (through its component's
:class:`~es2particles.gl.context.Group`), gives each sampler the program really uses a texture unit
by name, and is strict about names, with one policy everywhere:

- a uniform given to it must be active in its program (a misspelled or unused name is an error
  that names the stage, the shader file and the name, where GL would drop it silently);
- every sampler the program uses must be fed on every draw;
- its GL state (target, blending) is scoped to the draw and switched off even when an exception
  passes through (``Context.scope``).
"""

import re

import moderngl

from .bindings import compile_checked, declared_names, generated_values, strip_comments
from .context import ProgramValues
from ..errors import ParameterError
from .shaders import GENERATED, expand

GL_SAMPLER_2D = 0x8B5E


class FullscreenCommand:
    """A fragment shader over ``lib/fullscreen.vert``, its samplers and its uniforms.

    Parameters
    ----------
    group : Group
        The owner of the command's vertex array.
    fragment : str
        The fragment shader: a library name or a path.
    stage : str
        How errors name the command ("pass 'drift'", "post stage bloom blur").
    defines : mapping, optional
    interface : bindings.Interface, optional
        The generated interface of a pass, placed before the shader's own lines and checked
        against them (``bindings.compile_checked``).

    A uniform is given by name: it must be declared (by the shader or the interface) and
    referenced by the shader's code, else the call is an error. Whether the driver keeps it
    active is its own business (a uniform whose result is never written is optimised away, and
    drivers differ there), so a referenced uniform the driver dropped is skipped, not an error.
    """

    def __init__(self, group, fragment, stage, defines=None, interface=None):
        self.ctx, self.stage, self.fragment = group.ctx, stage, fragment
        prelude = interface.lines if interface is not None else None
        epilogue = interface.epilogue if interface is not None else None
        source = expand(fragment, defines, prelude, epilogue)
        self.declared, self.referenced = _names(source)

        def compile():
            return self.ctx.program("lib/fullscreen.vert", fragment, defines,
                                    fragment_prelude=prelude, fragment_epilogue=epilogue)

        self.program = (compile_checked(compile, source, interface, self.where())
                        if interface is not None else compile())
        self.vao = group.fullscreen(self.program)
        members = {name: self.program[name] for name in self.program}
        self.samplers = sorted(name for name, m in members.items()
                               if isinstance(m, moderngl.Uniform) and m.gl_type == GL_SAMPLER_2D)
        self.units = {name: unit for unit, name in enumerate(self.samplers)}
        self.state = ProgramValues(self.ctx, self.program)  # the program may be shared
        for name, unit in self.units.items():
            self.state.set(name, unit)
        self.active = {name for name, m in members.items() if isinstance(m, moderngl.Uniform)}

    def where(self):
        return f"{self.stage} ({self.fragment})"

    def has(self, name):
        """True if ``name`` is an active uniform of the program."""
        return name in self.active

    def uses(self, name):
        """True if the shader's own code (not the generated lines) refers to ``name``."""
        return name in self.referenced

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
            return  # referenced, but its result is never written: the driver dropped it
        handle = self.program[name]
        try:
            if isinstance(value, list):
                value = value[: handle.array_length]  # the driver keeps only the used elements
                if handle.array_length == 1:
                    value = value[0]  # moderngl takes an array of one as its element
            self.state.set(name, value)
        except Exception as error:
            raise ParameterError(f"{self.where()}: uniform {name!r} cannot take {value!r} "
                                 f"({error})") from None

    def set_many(self, uniforms):
        for name, value in uniforms.items():
            self.set(name, value)

    def set_generated(self, interface, layout):
        """Set what the generated interface declares for a state ``layout``: the quantities'
        ranges, ``u_state_size`` and ``u_count`` (each where the driver kept it)."""
        for name, value in generated_values(interface, layout).items():
            if self.has(name):
                self.state.set(name, value)

    def check_fed(self, samplers):
        """Raise unless ``samplers`` (names) covers every sampler the program uses."""
        unfed = [name for name in self.samplers if name not in samplers]
        if unfed:
            raise ParameterError(f"{self.where()}: sampler {', '.join(map(repr, unfed))} is used "
                                 f"by the shader but nothing feeds it (fed: "
                                 f"{', '.join(sorted(samplers)) or 'nothing'})")

    def draw(self, framebuffer, textures, blend=None):
        """Draw over ``framebuffer`` with ``textures`` (sampler name -> texture)."""
        try:
            for name, unit in self.units.items():
                textures[name].use(unit)
        except KeyError:
            self.check_fed(textures)
            raise
        self.state.current()
        with self.ctx.scope(framebuffer, blend=blend):
            self.vao.render(moderngl.TRIANGLES)


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
    return declared, referenced
