"""The device beneath the context: the one place GL calls are made, and a recording twin of it.

A :class:`~es2particles.gl.context.Context` makes, owns and releases objects and runs draws only
through its device. :class:`GLDevice` does that with moderngl (the only module of the package that
calls it); :class:`RecordingDevice` makes handles that carry what was asked for and writes every
call into ``calls``, with no GL library loaded, so the plan's executor can be tested on its call
stream: which texture is bound to which sampler, which framebuffer each draw writes, in which
order, with which uniforms and state, and what is released (as Filament tests its frame graph on a
no-op driver). Numbers are tested on the GL device; the recording one draws nothing.

A draw is one call, :meth:`draw`, with everything it needs: the vertex array, the target, the
textures by unit, the :class:`DrawState` (blending, depth test and writes, program point size,
point sprites), set for that draw and switched off again after it, also when an exception passes
through.
"""

import ctypes
import itertools
import re
from contextlib import contextmanager
from dataclasses import dataclass, field

from ..errors import ContextError
from ..io.signals import signals_held

# (ONE, ONE), (ONE, ONE_MINUS_SRC_ALPHA), (ZERO, SRC_COLOR): a product, what light passes.
BLEND_FUNCTIONS = {"add": (1, 1), "over": (1, 0x0303), "multiply": (0, 0x0300)}
PRIMITIVES = ("triangles", "points")
GL_POINT_SPRITE = 0x8861
GL_TEXTURE_2D = 0x0DE1
GL_SAMPLER_2D = 0x8B5E


@dataclass(frozen=True)
class DrawState:
    """The GL state of one draw: blending (None, ``"add"``: ONE, ONE, ``"over"``: premultiplied
    alpha, or ``"multiply"``: the target times the colour), depth test, depth writes (with the
    test), colour writes (off: a depth-only draw), the vertex shader's point size
    (``point_size``) and point sprites (``sprites``: gl_PointCoord varies over a point)."""

    blend: str = None
    depth_test: bool = False
    depth_write: bool = True
    point_size: bool = False
    sprites: bool = False
    colour_write: bool = True

    def __post_init__(self):
        if self.blend not in (None, *BLEND_FUNCTIONS):
            raise ValueError(f"blend must be None or one of {sorted(BLEND_FUNCTIONS)}, "
                             f"got {self.blend!r}")

    def describe(self):
        """A few words for a printed plan."""
        words = [f"{self.blend} blend" if self.blend else "no blend"]
        if not self.colour_write:
            words = ["depth only"]
        if self.depth_test:
            words.append("depth test" + (" and writes" if self.depth_write else ", no writes"))
        if self.sprites:
            words.append("point sprites")
        return ", ".join(words)


@dataclass(frozen=True)
class ActiveUniform:
    """A uniform the linked program keeps: whether it is a sampler, and its array length."""

    sampler: bool
    length: int = 1


# glGetShaderPrecisionFormat's precision types, in the order of their enums (0x8DF0 on)
PRECISIONS = ("low float", "medium float", "high float", "low int", "medium int", "high int")


class GLDevice:
    """moderngl under a context: objects, draws, reads and writes, through one moderngl context."""

    draws = True  # its pictures can be read and measured

    def __init__(self, mgl, backend="egl", profile="core"):
        self.mgl, self.backend, self.profile = mgl, backend, profile
        self._gl_calls = {}

    # -- the context ---------------------------------------------------------------------------

    def info(self):
        return dict(self.mgl.info)

    def extensions(self):
        return set(self.mgl.extensions)

    def error(self):
        return self.mgl.error

    def shader_precision(self):
        """glGetShaderPrecisionFormat for each shader and precision (the article's table):
        {"vertex"|"fragment": {"high float"|...|"low int": (log2 of the range's low end, of its
        high end, bits of precision)}}; None where the call cannot be loaded. A precision the
        shader lacks reads (0, 0, 0)."""
        ints = ctypes.POINTER(ctypes.c_int)
        call = self._gl_function("glGetShaderPrecisionFormat", ctypes.c_uint, ctypes.c_uint,
                                 ints, ints)
        if self._gl_calls.get("glGetShaderPrecisionFormat") is None:
            return None
        table = {}
        for shader, shader_enum in (("vertex", 0x8B31), ("fragment", 0x8B30)):
            table[shader] = {}
            for i, name in enumerate(PRECISIONS):
                span, bits = (ctypes.c_int * 2)(), ctypes.c_int()
                call(shader_enum, 0x8DF0 + i, span, ctypes.byref(bits))
                table[shader][name] = (span[0], span[1], bits.value)
        # A context that errs on the call, or answers nothing at all (a stub), does not say.
        if self.error() != "GL_NO_ERROR" or not any(any(v) for v in table["fragment"].values()):
            return None
        return table

    def make_current(self):
        self.mgl.__enter__()

    def flush(self):
        """glFlush: hand the queued GL work to the driver without waiting for it. moderngl has no
        call for it; where moderngl's own loader is not there it does nothing (a flush changes
        speed, never results)."""
        self._gl_function("glFlush")()

    def finish(self):
        self.mgl.finish()

    def screen(self):
        """The window's own framebuffer, where the context was made on a window."""
        if self.mgl.screen is None:
            raise ContextError("this context has no window to draw on (it is headless)")
        return self.mgl.screen

    def close(self):
        self.mgl.release()
        self.mgl = None

    # -- objects -------------------------------------------------------------------------------

    def texture(self, size, components, dtype, data=None, linear=False):
        import moderngl

        tex = self.mgl.texture(tuple(size), components, data=data, dtype=dtype)
        mode = moderngl.LINEAR if linear else moderngl.NEAREST
        tex.filter = (mode, mode)
        tex.repeat_x = tex.repeat_y = False
        return tex

    def compressed_texture(self, compressed):
        """A texture holding ASTC blocks as they are (NEAREST, clamped): moderngl checks data
        against the uncompressed size, so an RGBA8 texture of that size is made and its level 0
        replaced by glCompressedTexImage2D. Returns (texture, GL error after the upload)."""
        import moderngl

        upload = self._gl_function("glCompressedTexImage2D", ctypes.c_uint, ctypes.c_int,
                                   ctypes.c_uint, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                                   ctypes.c_int, ctypes.c_char_p, required=True)
        c = compressed
        tex = self.mgl.texture((c.width, c.height), 4)
        tex.use(0)
        upload(GL_TEXTURE_2D, 0, c.internal_format, c.width, c.height, 0, c.nbytes, c.data)
        error = self.mgl.error
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        tex.repeat_x = tex.repeat_y = False
        return tex, error

    def depth_buffer(self, size, texture=False):
        if not texture:
            return self.mgl.depth_renderbuffer(tuple(size))
        import moderngl

        depth = self.mgl.depth_texture(tuple(size))
        depth.filter = (moderngl.NEAREST, moderngl.NEAREST)
        depth.compare_func = ""  # sampled as a value, not compared
        return depth

    def framebuffer(self, colour, depth=None):
        return self.mgl.framebuffer(color_attachments=[colour], depth_attachment=depth)

    def buffer(self, data):
        return self.mgl.buffer(data)

    def program(self, vertex, fragment):
        """Compile and link; a failure raises :class:`ProgramError` with the driver's words.
        SIGINT, SIGTERM and SIGALRM are held back while the driver compiles (see
        :func:`signals_held`)."""
        import moderngl

        try:
            with signals_held():
                return self.mgl.program(vertex_shader=vertex, fragment_shader=fragment)
        except moderngl.Error as error:
            raise ProgramError(str(error)) from None

    def uniforms(self, program):
        import moderngl

        out = {}
        for name in program:
            member = program[name]
            if isinstance(member, moderngl.Uniform):
                out[name] = ActiveUniform(member.gl_type == GL_SAMPLER_2D, member.array_length)
        return out

    def set_uniform(self, program, name, value):
        program[name].value = value

    def vertex_array(self, program, content, indices=None):
        """A vertex array of ``content``; ``indices``: a buffer of uint32 vertex indices that
        the draws walk instead (one static index buffer: quads as two triangles). An attribute
        the program does not use (a depth-only draw of a mesh needs no normal; the linker drops
        it) is skipped over as padding."""
        content = [_used(program, entry) for entry in content]
        content = [entry for entry in content if len(entry) > 2]
        if indices is None:
            return self.mgl.vertex_array(program, content)
        return self.mgl.vertex_array(program, content, index_buffer=indices,
                                     index_element_size=4)

    def release(self, obj):
        import moderngl

        if isinstance(obj, moderngl.Framebuffer):
            # moderngl re-binds the last used framebuffer when it makes the next one; if that one
            # was deleted, GL answers INVALID_OPERATION. Park on the default framebuffer first.
            self.mgl.detect_framebuffer(0).use()
        obj.release()

    # -- work ------------------------------------------------------------------------------------

    def clear(self, framebuffer, colour, depth=None):
        framebuffer.depth_mask = True  # a depth clear writes through the mask
        if depth is None:
            framebuffer.clear(*colour)
        else:
            framebuffer.clear(*colour, depth=depth)

    def read(self, texture, components=None):
        """A texture's bytes; ``components`` (fewer than the texture has) reads only the first
        ones, packed (alignment 1), as the driver converts them: 1 ms for 1024x1024 RGB of RGBA8
        here, where dropping alpha in numpy took 5."""
        if components is None or components == texture.components:
            return texture.read()
        framebuffer = self.mgl.framebuffer([texture])
        try:
            return framebuffer.read(components=components, alignment=1)
        finally:
            framebuffer.release()

    def write(self, obj, data):
        obj.write(data)

    def draw(self, vertex_array, framebuffer, textures, state, primitive, first=0, count=None,
             label=None):
        """Bind ``textures`` (unit -> texture) and draw ``count`` vertices from ``first`` of
        ``vertex_array`` as ``primitive`` into ``framebuffer`` under ``state`` (``label``: the
        stage's name, for a device that records)."""
        import moderngl

        for unit, texture in textures.items():
            texture.use(unit)
        mode = moderngl.POINTS if primitive == "points" else moderngl.TRIANGLES
        with self.scope(framebuffer, state):
            if count is None:
                vertex_array.render(mode)
            else:
                vertex_array.render(mode, vertices=count, first=first)

    @contextmanager
    def scope(self, framebuffer, state):
        """``state`` for one draw, all switched off again on the way out.

        Point sprites: core profiles and ES always vary gl_PointCoord over a point; by the spec,
        the compatibility profile that :func:`open_context` prefers does it only with
        GL_POINT_SPRITE enabled, which moderngl has no flag for, so it is switched through the GL
        function loader. (Mesa varies it for ES shaders even without the switch.)"""
        import moderngl

        flags = moderngl.NOTHING
        if state.blend is not None:
            flags |= moderngl.BLEND
        if state.point_size:
            flags |= moderngl.PROGRAM_POINT_SIZE
        if state.depth_test:
            flags |= moderngl.DEPTH_TEST
        # The masks are the framebuffer's, taken by GL when it is bound: set them first.
        framebuffer.depth_mask = bool(state.depth_write)
        if not state.colour_write:
            framebuffer.color_mask = (False, False, False, False)
        framebuffer.use()
        self.mgl.enable_only(flags)
        if state.blend is not None:
            self.mgl.blend_func = BLEND_FUNCTIONS[state.blend]
        point_sprite = state.sprites and self.profile == "compatibility"
        if point_sprite:
            self._gl_function("glEnable", ctypes.c_uint)(GL_POINT_SPRITE)
        try:
            yield
        finally:
            # An interrupt that lands between the yield and the with statement taking the
            # scope leaves this generator to be closed by the collector, after the context may
            # have been released on the way out: then there is nothing left to switch off.
            if self.mgl is not None:
                if point_sprite:
                    self._gl_function("glDisable", ctypes.c_uint)(GL_POINT_SPRITE)
                framebuffer.depth_mask = True
                if not state.colour_write:
                    framebuffer.color_mask = (True, True, True, True)
                self.mgl.enable_only(moderngl.NOTHING)

    def _gl_function(self, name, *argtypes, required=False):
        """A GL entry point moderngl has no call for, through moderngl's own function loader
        (loaded once). Where that loader is not there: a no-op for calls that change speed or
        state moderngl's drivers already have, never results; for a ``required`` one, whose
        effect is the result (an upload), :class:`~es2particles.errors.CapabilityError`."""
        if name not in self._gl_calls:
            loader = getattr(self.mgl.mglo, "_context", None)
            address = loader.load_opengl_function(name) if loader is not None else 0
            self._gl_calls[name] = (ctypes.CFUNCTYPE(None, *argtypes)(address) if address
                                    else None)
        if self._gl_calls[name] is None:
            if required:
                from ..errors import CapabilityError

                raise CapabilityError(f"the GL function {name} cannot be loaded through "
                                      f"moderngl on the {self.backend} back-end")
            return lambda *args: None
        return self._gl_calls[name]


def _used(program, entry):
    """A vertex array entry (buffer, "3f 3f", names...) with the attributes ``program`` does not
    use turned into padding ("3f 3x4")."""
    import moderngl

    buffer, layout, *names = entry
    parts, kept = [], []
    for part, name in zip(layout.split(), names):
        member = program.get(name, None) if hasattr(program, "get") else None
        if isinstance(member, moderngl.Attribute):
            parts.append(part)
            kept.append(name)
        else:
            count = int(part[:-1] if part.endswith("f") else part.split("f")[0] or 1)
            size = 4 if part.endswith("f") else int(part.split("f")[1])
            parts.append(f"{count}x{size}")
    return (buffer, " ".join(parts), *kept)


class ProgramError(Exception):
    """A device could not compile or link a program; the message is the driver's."""


# --- the recording device ---------------------------------------------------------------------

class ModernglLike:
    """The few moderngl-like members the package reads from a device's objects (``size`` and
    ``device`` their own): the recording device's handles and the ES device's have them."""

    @property
    def width(self):
        return self.size[0]

    @property
    def height(self):
        return self.size[1]

    def read(self):
        return self.device.read(self)

    def write(self, data):
        self.device.write(self, data)

    def release(self):
        self.device.release(self)


@dataclass(eq=False)
class Handle(ModernglLike):
    """An object the recording device made: its kind, number and what it was made with. Textures
    keep what was written into them, so an upload reads back; a texture never written reads as
    zeros."""

    device: object = field(repr=False)
    kind: str
    number: int
    size: tuple = None
    components: int = 4
    itemsize: int = 1
    data: bytes = None
    details: dict = field(default_factory=dict)

    def __repr__(self):
        size = f" {self.size[0]}x{self.size[1]}" if self.size else ""
        return f"<{self.kind} {self.number}{size}>"



@dataclass(frozen=True)
class Call:
    """One call the recording device received: ``op`` and its arguments."""

    op: str
    args: dict

    def __getitem__(self, key):
        return self.args[key]


class RecordingDevice:
    """A device that draws nothing and records everything (see the module's docstring).

    ``caps`` is the :class:`~es2particles.gl.context.Capabilities` it answers with (by default
    llvmpipe's figures on this project's machines, with every format renderable and blendable);
    ``calls`` is the list of :class:`Call` it received, in order.
    """

    backend, profile = "recording", "core"
    draws = False  # nothing to measure in what it reads back

    def __init__(self, caps=None):
        self.caps = caps
        self.calls = []
        self.live = set()
        self._numbers = itertools.count(1)
        self._programs = {}

    def _record(self, op, **args):
        self.calls.append(Call(op, args))

    def _handle(self, kind, **kwargs):
        handle = Handle(self, kind, next(self._numbers), **kwargs)
        self.live.add(handle.number)
        return handle

    def of(self, op):
        """The recorded calls of one kind, in order."""
        return [c for c in self.calls if c.op == op]

    # -- the context ---------------------------------------------------------------------------

    def info(self):
        return {}

    def extensions(self):
        return set(self.caps.extensions) if self.caps is not None else set()

    def error(self):
        return "GL_NO_ERROR"

    def shader_precision(self):
        return None

    def make_current(self):
        pass

    def flush(self):
        self._record("flush")

    def finish(self):
        pass

    def close(self):
        self._record("close")

    # -- objects -------------------------------------------------------------------------------

    def texture(self, size, components, dtype, data=None, linear=False):
        itemsize = {"f1": 1, "f2": 2, "f4": 4}[dtype]
        tex = self._handle("texture", size=tuple(size), components=components, itemsize=itemsize,
                           details={"dtype": dtype, "linear": linear})
        self._record("texture", texture=tex, size=tuple(size), dtype=dtype, linear=linear,
                     data=data is not None)
        if data is not None:
            tex.data = bytes(data)
        return tex

    def compressed_texture(self, compressed):
        tex = self._handle("texture", size=(compressed.width, compressed.height),
                           details={"compressed": compressed.block})
        self._record("compressed texture", texture=tex, block=compressed.block)
        return tex, "GL_NO_ERROR"

    def depth_buffer(self, size, texture=False):
        depth = self._handle("depth buffer", size=tuple(size), details={"texture": texture})
        self._record("depth buffer", depth=depth)
        return depth

    def framebuffer(self, colour, depth=None):
        fbo = self._handle("framebuffer", size=colour.size, details={"colour": colour,
                                                                      "depth": depth})
        self._record("framebuffer", framebuffer=fbo, colour=colour, depth=depth)
        return fbo

    def buffer(self, data):
        buf = self._handle("buffer", data=bytes(data))
        self._record("buffer", buffer=buf, nbytes=len(data))
        return buf

    def program(self, vertex, fragment):
        program = self._handle("program", details={"vertex": vertex, "fragment": fragment})
        self._programs[program.number] = _active_uniforms(vertex, fragment)
        program.details["values"] = {}
        self._record("program", program=program)
        return program

    def uniforms(self, program):
        return dict(self._programs[program.number])

    def set_uniform(self, program, name, value):
        program.details["values"][name] = value

    def vertex_array(self, program, content, indices=None):
        vao = self._handle("vertex array", details={"program": program, "content": content,
                                                    "indices": indices})
        self._record("vertex array", vertex_array=vao, program=program)
        return vao

    def release(self, obj):
        self.live.discard(obj.number)
        self._record("release", handle=obj)

    # -- work ------------------------------------------------------------------------------------

    def clear(self, framebuffer, colour, depth=None):
        self._record("clear", framebuffer=framebuffer, colour=tuple(colour), depth=depth)

    def read(self, texture, components=None):
        self._record("read", texture=texture, components=components)
        nbytes = texture.size[0] * texture.size[1] * texture.components * texture.itemsize
        data = texture.data if texture.data is not None else bytes(nbytes)
        if components is None or components == texture.components:
            return data
        texels = memoryview(data).cast("B")
        step, size = texture.components * texture.itemsize, components * texture.itemsize
        return b"".join(texels[i:i + size] for i in range(0, nbytes, step))

    def write(self, obj, data):
        obj.data = bytes(data)
        self._record("write", handle=obj, nbytes=len(data))

    def draw(self, vertex_array, framebuffer, textures, state, primitive, first=0, count=None,
             label=None):
        program = vertex_array.details["program"]
        self._record("draw", stage=label, program=program, vertex_array=vertex_array,
                     framebuffer=framebuffer, textures=dict(textures),
                     uniforms=dict(program.details["values"]),
                     state=state, primitive=primitive, first=first, count=count)


_DECLARATION = re.compile(r"\buniform\s+(?:(?:lowp|mediump|highp)\s+)?(\w+)\s+([^;]+);")
_COMMENTS = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
_DIRECTIVE = re.compile(r"^\s*#\s*(\w+)\s*(.*?)\s*$")
_FUNCTION = re.compile(r"\b\w+\s+(\w+)\s*\([^;{)]*\)\s*\{")
_IDENTIFIER = re.compile(r"[A-Za-z_]\w*")


def _active_uniforms(*sources):
    """What a linker keeps, as the recording device models it: each source run through the
    preprocessor (``#define``, ``#undef``, ``#ifdef``, ``#ifndef``, ``#if``/``#elif`` of
    ``defined``, numbers and logic, ``#else``, ``#endif``; object-like macros substituted), then
    every uniform declared there that a function reachable from ``main`` refers to. (A driver may
    drop more: one whose result is never written.)"""
    declared, used = {}, set()
    for text in sources:
        code = _preprocess(_COMMENTS.sub("", text))
        for glsl_type, names in _DECLARATION.findall(code):
            for name in names.split(","):
                name = name.strip()
                length = int(re.search(r"\[(\d+)\]", name).group(1)) if "[" in name else 1
                declared[name.split("[")[0].strip()] = ActiveUniform(glsl_type == "sampler2D",
                                                                      length)
        used |= _reachable_identifiers(code)
    return {name: u for name, u in declared.items() if name in used}


def _preprocess(text):
    """The lines of ``text`` the GLSL preprocessor keeps, object-like macros substituted."""
    macros, out, stack = {}, [], []  # stack of (this branch taken, any branch taken yet)
    for line in text.split("\n"):
        match = _DIRECTIVE.match(line)
        active = all(taken for taken, _ in stack)
        if match:
            word, rest = match.groups()
            if word in ("ifdef", "ifndef"):
                taken = (rest.split()[0] in macros) == (word == "ifdef")
                stack.append((taken, taken))
            elif word == "if":
                taken = _condition(rest, macros)
                stack.append((taken, taken))
            elif word == "elif":
                _, done = stack.pop()
                taken = not done and _condition(rest, macros)
                stack.append((taken, done or taken))
            elif word == "else":
                _, done = stack.pop()
                stack.append((not done, True))
            elif word == "endif":
                stack.pop()
            elif active and word == "define":
                name, _, value = rest.partition(" ")
                macros[name] = value.strip()
            elif active and word == "undef":
                macros.pop(rest.strip(), None)
            continue
        if active:
            out.append(_IDENTIFIER.sub(lambda m: _renamed(m.group(0), macros), line))
    return "\n".join(out)


def _renamed(word, macros):
    """``word`` after an object-like macro that names another identifier (``#define main
    state_pass_main``); any other word as it is."""
    value = macros.get(word, "")
    return value if _IDENTIFIER.fullmatch(value) else word


def _condition(expression, macros):
    """An ``#if`` expression of ``defined``, numbers, macros and ``! && ||``, as a bool."""
    text = re.sub(r"defined\s*\(\s*(\w+)\s*\)|defined\s+(\w+)",
                  lambda m: " 1 " if (m.group(1) or m.group(2)) in macros else " 0 ", expression)
    text = text.replace("&&", " and ").replace("||", " or ")
    text = re.sub(r"!(?!=)", " not ", text)
    text = _IDENTIFIER.sub(lambda m: m.group(0) if m.group(0) in ("and", "or", "not") else
                           (macros.get(m.group(0)) or "0"), text)
    return bool(eval(text, {"__builtins__": {}}, {}))  # digits, operators and 'and or not'


def _reachable_identifiers(code):
    """Identifiers in the bodies of the functions ``main`` reaches (by name: an overload
    counts as called where any of its name is)."""
    bodies = {}
    for match in _FUNCTION.finditer(code):
        depth, i = 1, match.end()
        while depth and i < len(code):
            depth += {"{": 1, "}": -1}.get(code[i], 0)
            i += 1
        bodies.setdefault(match.group(1), []).append(code[match.end():i])
    reached, todo, words = set(), ["main"], set()
    while todo:
        name = todo.pop()
        if name in reached or name not in bodies:
            continue
        reached.add(name)
        for body in bodies[name]:
            found = set(_IDENTIFIER.findall(body))
            words |= found
            todo += [w for w in found if w in bodies]
    return words
