"""The context: the one owner of the GL objects made through it, and what it can do.

A :class:`Context` holds a device (``device.py``: GL through moderngl, or a recording one), makes
every texture, framebuffer, buffer and program of the package through it, counts them, and
releases them all on ``release()`` or at the end of a ``with``. Its :class:`Capabilities` are
probed once (``egl.py``, where a context is opened) or stated (``Capabilities.assumed``).
"""

import threading
from dataclasses import dataclass, field

import numpy as np

from ..errors import CapabilityError, ContextError, ParameterError
from .shaders import compile_program, expand

# Formats the state may use: name -> moderngl dtype (four components).
FORMAT_DTYPES = {"rgba8": "f1", "rgba16f": "f2", "rgba32f": "f4"}
# Every texture format made here: name -> (components, moderngl dtype). r32f is for the density
# target only (one channel is all it needs; not ES 2.0, so it is probed like the float formats).
TEXTURE_FORMATS = {**{name: (4, dtype) for name, dtype in FORMAT_DTYPES.items()}, "r32f": (1, "f4")}
_NUMPY = {"f1": np.uint8, "f2": np.float16, "f4": np.float32}
# Storage formats kept in another's textures: 32-bit packed state is RGBA8 bytes, as 16-bit is.
STORED_IN = {"rgba8_32": "rgba8"}


def texture_format(fmt):
    """The texture format that holds storage format ``fmt`` (itself, or rgba8 for rgba8_32)."""
    return STORED_IN.get(fmt, fmt)


def numpy_dtype(fmt):
    """The numpy dtype of one channel of a texture of ``fmt``, as read back or written."""
    return _NUMPY[TEXTURE_FORMATS[texture_format(fmt)][1]]


def bytes_per_texel(fmt):
    components, dtype = TEXTURE_FORMATS[texture_format(fmt)]
    return components * np.dtype(_NUMPY[dtype]).itemsize


@dataclass
class Capabilities:
    """What the context offers, checked once at start-up."""

    backend: str
    profile: str
    vendor: str
    renderer: str
    version: str
    max_texture_size: int
    max_vertex_texture_units: int
    point_size_range: tuple
    # format -> can be a render target / additive blending works into it; probed per format the
    # first time one is asked for (see FormatFlags), so a run probes only the formats it uses.
    renderable: dict = field(default_factory=dict)
    blendable: dict = field(default_factory=dict)
    extensions: frozenset = frozenset()
    probe_store_rule: object = field(default=None, repr=False, compare=False)
    probe_multiply_add: object = field(default=None, repr=False, compare=False)
    probe_precision: object = field(default=None, repr=False, compare=False)
    probe_point_size: object = field(default=None, repr=False, compare=False)

    @classmethod
    def assumed(cls, **changes):
        """Capabilities stated rather than probed: llvmpipe's figures on this project's machines
        (every format renderable and blendable, ASTC listed), for plans made with no context
        (the WebGL export's checks, a recording device's tests); ``changes``
        override any field."""
        formats = {name: True for name in TEXTURE_FORMATS}
        values = dict(backend="assumed", profile="core", vendor="assumed", renderer="assumed",
                      version="assumed", max_texture_size=16384, max_vertex_texture_units=16,
                      point_size_range=(1.0, 255.0), renderable=dict(formats),
                      blendable=dict(formats),
                      extensions=frozenset({"GL_KHR_texture_compression_astc_ldr"}))
        values.update(changes)
        return cls(**values)

    @property
    def depth_texture(self):
        """True where a depth buffer can be a texture that shaders sample: core in desktop GL
        (1.4), an extension in ES 2.0 (OES_depth_texture) and WebGL 1 (WEBGL_depth_texture)."""
        es = "ES" in self.version or "WebGL" in self.version
        return not es or bool({"GL_OES_depth_texture", "WEBGL_depth_texture"} & self.extensions)

    def filters(self, fmt):
        """True where textures of storage ``fmt`` may be sampled LINEAR: every format in desktop
        GL (3.0 and on); in ES 2.0 and WebGL 1 float and half float textures only with
        OES_texture_float_linear / OES_texture_half_float_linear."""
        es = "ES" in self.version or "WebGL" in self.version
        needs = {"rgba32f": "OES_texture_float_linear",
                 "rgba16f": "OES_texture_half_float_linear"}.get(fmt)
        return not es or needs is None or bool({needs, "GL_" + needs} & self.extensions)

    @property
    def astc(self):
        """True where the driver lists ASTC LDR textures."""
        return "GL_KHR_texture_compression_astc_ldr" in self.extensions

    @property
    def store_rule(self):
        """How the driver turns a float into a byte in an RGBA8 store (round-to-nearest,
        truncate, floor256): probed the first time it is asked for, then kept."""
        if not hasattr(self, "_store_rule"):
            self._store_rule = self.probe_store_rule() if self.probe_store_rule else "unknown"
        return self._store_rule

    @property
    def drawn_point_size_range(self):
        """The point sizes the driver draws, which sprites and points are clamped to: its
        reported range (``point_size_range``), the top raised to the widest point a probe saw it
        draw where that is wider (NVIDIA's ES context reports 1..10 and draws 2048): probed the
        first time it is asked for, then kept."""
        if not hasattr(self, "_drawn_point_size_range"):
            lo, hi = self.point_size_range
            seen = self.probe_point_size() if self.probe_point_size else 0
            self._drawn_point_size_range = (float(lo), max(float(hi), float(seen)))
        return self._drawn_point_size_range

    @property
    def multiply_add(self):
        """How a shader's a * b + c rounds ("fused (one rounding)" or "two roundings"): probed
        the first time it is asked for, then kept."""
        if not hasattr(self, "_multiply_add"):
            self._multiply_add = (self.probe_multiply_add() if self.probe_multiply_add
                                  else "unknown")
        return self._multiply_add

    @property
    def precision(self):
        """The shaders' float and int precisions (``GLDevice.shader_precision``: shader ->
        precision -> (log2 range low, high, bits)), or None where the context does not say:
        asked the first time, then kept."""
        if not hasattr(self, "_precision"):
            self._precision = self.probe_precision() if self.probe_precision else None
        return self._precision

    @property
    def fragment_highp(self):
        """Whether fragment shaders have highp float (GLSL ES 1.00 leaves it optional: the
        article's Tegra 2, 3 and 4 lack it); True where the context does not say."""
        table = self.precision
        return table is None or table["fragment"]["high float"][2] > 0

    @property
    def is_es(self):
        """Whether this is an OpenGL ES context (its version string says so)."""
        return self.version.startswith("OpenGL ES")

    def article_extension(self, name):
        """Whether the context has what ES extension ``name`` (one of :data:`ARTICLE_EXTENSIONS`)
        gives: listed, on ES; core since desktop GL 3.0 (float and half float textures, their
        filtering and render targets, RGBA8 renderbuffers) on a desktop context."""
        if self.is_es:
            return f"GL_{name}" in self.extensions or name in self.extensions
        return self.version[:1].isdigit() and int(self.version[0]) >= 3

    @property
    def fused_multiply_add(self):
        """True where the driver fuses a * b + c (NVIDIA's does; llvmpipe's does not)."""
        return self.multiply_add.startswith("fused")

    @property
    def software_rasteriser(self):
        """True for a CPU rasteriser that bins a whole draw before rasterising it (llvmpipe,
        softpipe): large point draws are cut into slices there (a stage's ``slice``,
        frame/executor.py)."""
        return any(name in self.renderer.lower() for name in ("llvmpipe", "softpipe", "swrast"))

    def lines(self):
        """The report as (label, value) rows."""
        rows = [("backend", self.backend), ("profile", self.profile), ("vendor", self.vendor),
                ("renderer", self.renderer), ("GL version", self.version),
                ("max texture size", self.max_texture_size),
                ("max particles (max texture size squared)", self.max_texture_size ** 2),
                ("vertex texture image units", self.max_vertex_texture_units),
                ("particles drawn by", "vertex texture fetch" if self.max_vertex_texture_units
                 else "reading the state back each frame (no vertex texture units)"),
                ("point size range (reported)", "%g..%g" % tuple(self.point_size_range)),
                ("point sizes drawn (probed)", "%g..%g" % self.drawn_point_size_range)]
        for name in TEXTURE_FORMATS:
            rows.append((f"{name} render target / additive blend",
                         f"{_yes(self.renderable.get(name))} / {_yes(self.blendable.get(name))}"))
        rows.append(("8-bit store of a float channel", self.store_rule))
        rows.append(("a * b + c in a shader", self.multiply_add))
        core = "" if self.is_es else " (core in desktop GL 3.0+)"
        for name in ARTICLE_EXTENSIONS:
            rows.append((name, _yes(self.article_extension(name)) + core))
        table = self.precision
        for shader in ("vertex", "fragment"):
            for kind in ("float", "int"):
                label = f"{shader} {kind} precision (high / medium / low)"
                if table is None:
                    rows.append((label, "not reported by this context"))
                    continue
                rows.append((label, " / ".join(_precision(*table[shader][f"{p} {kind}"], kind)
                                               for p in ("high", "medium", "low"))))
        return rows

    def as_dict(self):
        """The report for scripts (``info --json``): the rows' values, the precisions as
        numbers, each format's flags."""
        out = {label: value for label, value in self.lines()
               if "precision" not in label and "render target" not in label
               and label not in ARTICLE_EXTENSIONS}
        del out["point size range (reported)"]  # under the key scripts have read all along
        out["point size range"] = [float(v) for v in self.point_size_range]
        out["point sizes drawn (probed)"] = list(self.drawn_point_size_range)
        out["formats"] = {name: {"render target": bool(self.renderable.get(name)),
                                 "additive blend": bool(self.blendable.get(name))}
                          for name in TEXTURE_FORMATS}
        out["precision"] = self.precision and {
            shader: {name: {"range log2": [lo, hi], "bits": bits}
                     for name, (lo, hi, bits) in kinds.items()}
            for shader, kinds in self.precision.items()}
        out["article extensions"] = {name: self.article_extension(name)
                                     for name in ARTICLE_EXTENSIONS}
        return out

    def __str__(self):
        width = max(len(label) for label, _ in self.lines())
        return "\n".join(f"{label:<{width}}  {value}" for label, value in self.lines())


def _yes(flag):
    return "yes" if flag else "no"


# The extensions the article's table names (OpenGL ES 2.0 names; core in desktop GL 3.0+).
ARTICLE_EXTENSIONS = ("OES_rgb8_rgba8", "OES_texture_half_float", "OES_texture_half_float_linear",
                      "EXT_color_buffer_half_float", "OES_texture_float",
                      "OES_texture_float_linear")


def _precision(lo, hi, bits, kind):
    """One precision as the article's table gives it: the bits and the range, or absent."""
    if lo == hi == bits == 0:
        return "none"
    if kind == "int":
        return f"+-2^{hi}"
    return f"{bits} bits, +-2^{hi}"


class FormatFlags(dict):
    """format -> flag, filled on the first question about a format: ``probe(fmt)`` renders into
    a 4x4 target of it (~5 ms a format on llvmpipe) and fills this and its sibling mapping. A name
    that is not a texture format stays absent (``get`` gives None)."""

    def __init__(self, probe):
        super().__init__()
        self._probe = probe

    def __missing__(self, fmt):
        if texture_format(fmt) != fmt:
            return self[texture_format(fmt)]
        if fmt not in TEXTURE_FORMATS:
            raise KeyError(fmt)
        self._probe(fmt)
        return dict.__getitem__(self, fmt)

    def get(self, fmt, default=None):
        return self[fmt] if texture_format(fmt) in TEXTURE_FORMATS else default


def _program_key(vertex, fragment, defines, vertex_prelude, fragment_prelude, fragment_epilogue):
    return (str(vertex), str(fragment), tuple(sorted((defines or {}).items())),
            tuple(vertex_prelude or ()), tuple(fragment_prelude or ()),
            tuple(fragment_epilogue or ()))


class Context:
    """A headless GL context and the one owner of the GL objects made through it.

    Every object is made, and every draw, read and write is done, through its ``device``: a
    :class:`~es2particles.gl.device.GLDevice` (moderngl) or a
    :class:`~es2particles.gl.gles.GLESDevice` (OpenGL ES) from :func:`open_context`, or a
    :class:`~es2particles.gl.device.RecordingDevice`, which draws nothing and records the calls
    (``Context(RecordingDevice())``: the executor's call stream with no GL library loaded).
    """

    def __init__(self, device, probe=None):
        self.device, self._probe = device, probe
        self.backend, self.profile = device.backend, device.profile
        # A GL context is current in one thread; the one that made it is the one it serves
        # (a recording device's calls go nowhere, so any thread may make them).
        self._thread = threading.get_ident() if device.draws else None
        self._program_users = {}  # id(program) -> the ProgramValues that set its uniforms last
        Context._current = self  # a new context is current
        self._owned = []
        self._programs = {}
        self._sources = {}  # the same keys: a program's two expanded sources
        self._caps = None
        self._fullscreen = None
        self._open = True

    _current = None  # the Context made current last (GL calls go to it, whoever makes them)

    @property
    def mgl(self):
        """The moderngl context of a GL device (None once released, or on a recording device):
        for tests and tools that need moderngl itself."""
        return getattr(self.device, "mgl", None) if self._open else None

    def make_current(self):
        """Make this context the thread's current one: GL calls go to whichever context was made
        current last, so every object makes its own current before GL work (a no-op when it
        already is). A released context raises :class:`ContextError`."""
        if not self._open:
            raise ContextError("this context was released; open a new one with open_context()")
        if self._thread is not None and self._thread != threading.get_ident():
            raise ContextError("this context was opened on another thread, and a GL context "
                               "serves the thread that made it: open one in this thread "
                               "(open_context()), as each cluster worker does")
        if Context._current is not self:
            self.device.make_current()
            Context._current = self

    def screen(self):
        """The framebuffer of the window this context was made on (a window's context only)."""
        self.make_current()
        return self.device.screen()

    def flush(self):
        """Hand the queued GL work to the driver without waiting for it (glFlush)."""
        self.device.flush()

    def finish(self):
        """Wait until the GL work queued so far is done (timings)."""
        if self._open:
            self.device.finish()

    def error(self):
        """The device's GL error flag (``"GL_NO_ERROR"`` when none)."""
        return self.device.error()

    # -- ownership ---------------------------------------------------------------------------

    def own(self, obj):
        """Take ownership of an object the device made; it is released with the context."""
        self._owned.append(obj)
        return obj

    def free(self, *objects):
        """Release objects made through this context before the context itself goes."""
        self.make_current()  # GL names are per context: deleting them elsewhere deletes others
        for obj in objects:
            if obj is None:
                continue
            for i, owned in enumerate(self._owned):
                if owned is obj:
                    del self._owned[i]
                    self.device.release(obj)
                    break

    def live_objects(self):
        """Count of GL objects alive, by type name (a test can check a run leaks nothing)."""
        counts = {}
        for obj in self._owned:
            name = getattr(obj, "kind", None) or type(obj).__name__
            name = _TYPE_NAMES.get(name, name)
            counts[name] = counts.get(name, 0) + 1
        return counts

    def release(self):
        """Release every owned object and the context; safe to call twice."""
        if self._open:
            self.make_current()  # its objects' names must be deleted in it, not in another
        while self._owned:
            self.device.release(self._owned.pop())
        self._programs.clear()
        self._sources.clear()
        self._fullscreen = None
        if self._open:
            self.device.close()
            self._open = False
        # Releasing a context may leave another (or none) current, whatever was before: the next
        # make_current() must switch for real.
        Context._current = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()

    # -- factories ---------------------------------------------------------------------------

    def texture(self, size, fmt="rgba8", data=None, filter_nearest=True):
        """A 2D texture of ``fmt`` (rgba8, rgba16f, rgba32f, r32f), NEAREST-sampled and clamped
        (``filter_nearest=False``: linear).

        Packed state must be sampled NEAREST: linear filtering would mix high and low bytes.
        """
        components, dtype = TEXTURE_FORMATS[texture_format(fmt)]
        self.make_current()
        return self.own(self.device.texture(tuple(size), components, dtype, data,
                                            linear=not filter_nearest))

    def compressed_texture(self, compressed):
        """A 2D texture holding :class:`~es2particles.gl.astc.Compressed` ASTC blocks as they
        are, NEAREST-sampled and clamped; :class:`CapabilityError` where the driver cannot take
        them."""
        from . import astc  # only compressed fields need it: not imported at start-up

        if not isinstance(compressed, astc.Compressed):
            raise ParameterError(f"compressed must be an astc.Compressed (see astc.compress), got "
                                 f"{type(compressed).__name__}")
        reason = astc.unavailable(self, encode=False)
        if reason:
            raise CapabilityError(f"ASTC textures cannot be used: {reason}")
        self.make_current()  # the upload is a raw GL call: it goes to the current context
        tex, error = self.device.compressed_texture(compressed)
        self.own(tex)
        if error != "GL_NO_ERROR":
            self.free(tex)
            c = compressed
            raise CapabilityError(f"glCompressedTexImage2D of {c.width}x{c.height} ASTC "
                                  f"{c.block[0]}x{c.block[1]} failed with {error}")
        return tex

    def framebuffer(self, texture, depth=None):
        self.make_current()
        return self.own(self.device.framebuffer(texture, depth))

    def depth(self, size, texture=False):
        """A depth buffer of ``size`` (for a framebuffer that depth-tests); with ``texture``, a
        depth texture that shaders can also sample."""
        self.make_current()
        return self.own(self.device.depth_buffer(tuple(size), texture))

    def buffer(self, data):
        self.make_current()
        return self.own(self.device.buffer(data))

    def sources(self, vertex, fragment, defines=None, vertex_prelude=None, fragment_prelude=None,
                fragment_epilogue=None):
        """The two :class:`~es2particles.gl.shaders.ExpandedSource` of the program
        :meth:`program` makes from the same arguments: expanded once per context, as the program
        is compiled once (draw commands that share a program share them)."""
        key = _program_key(vertex, fragment, defines, vertex_prelude, fragment_prelude,
                           fragment_epilogue)
        if key not in self._sources:
            self._sources[key] = (expand(vertex, defines, vertex_prelude),
                                  expand(fragment, defines, fragment_prelude, fragment_epilogue))
        return self._sources[key]

    def program(self, vertex, fragment, defines=None, vertex_prelude=None, fragment_prelude=None,
                fragment_epilogue=None):
        """Compiled program for the shader files, defines and generated preludes and epilogue
        (see ``bindings.py``); compiled once, then cached."""
        key = _program_key(vertex, fragment, defines, vertex_prelude, fragment_prelude,
                           fragment_epilogue)
        if key not in self._programs:
            sources = self.sources(vertex, fragment, defines, vertex_prelude, fragment_prelude,
                                   fragment_epilogue)
            self.make_current()
            self._programs[key] = self.own(compile_program(self.device, vertex, fragment,
                                                           sources))
        return self._programs[key]

    def vertex_array(self, program, content, indices=None):
        self.make_current()
        return self.own(self.device.vertex_array(program, content, indices))

    def fullscreen(self, program):
        """A vertex array drawing the full-screen triangle of ``lib/fullscreen.vert``."""
        if self._fullscreen is None:
            self._fullscreen = self.buffer(np.array([-1, -1, 3, -1, -1, 3], dtype="f4").tobytes())
        return self.vertex_array(program, [(self._fullscreen, "2f", "a_position")])

    def group(self):
        """A new :class:`Group`: the GL objects of one component, released together."""
        return Group(self)

    # -- work --------------------------------------------------------------------------------

    def clear(self, framebuffer, colour, depth=None):
        """Clear ``framebuffer`` to ``colour`` (and its depth buffer to ``depth``)."""
        self.make_current()
        self.device.clear(framebuffer, tuple(float(c) for c in colour), depth)

    def read(self, texture, components=None):
        """A texture's bytes, row 0 (GL's bottom row) first; ``components``: only the first
        ones of each texel (RGB of an RGBA texture), packed."""
        self.make_current()
        return self.device.read(texture, components)

    def write(self, obj, data):
        """Replace a texture's or buffer's contents with ``data`` (bytes)."""
        self.make_current()
        self.device.write(obj, data)

    # -- capabilities ------------------------------------------------------------------------

    @property
    def caps(self):
        """The :class:`Capabilities` report, probed once."""
        if self._caps is None:
            given = getattr(self.device, "caps", None)
            if given is None and self._probe is None:
                raise ContextError("this context's capabilities are neither stated by its device "
                                   "nor probed: open it with open_context()")
            if given is None:
                self.make_current()  # the probes draw
            self._caps = given if given is not None else self._probe(self)
        return self._caps

    def require_format(self, fmt, blend=False):
        """Raise :class:`CapabilityError` unless ``fmt`` is renderable (and blendable)."""
        fmt = texture_format(fmt)
        if fmt not in FORMAT_DTYPES:
            raise CapabilityError(f"format must be one of {sorted(FORMAT_DTYPES)}, got {fmt!r}")
        if not self.caps.renderable.get(fmt) or (blend and not self.caps.blendable.get(fmt)):
            need = "rendered to with additive blending" if blend else "rendered to"
            raise CapabilityError(f"format {fmt!r} cannot be {need} on {self.caps.renderer}")


# Names of what live_objects() counts: moderngl's class names, and the recording device's kinds.
_TYPE_NAMES = {"texture": "Texture", "framebuffer": "Framebuffer", "buffer": "Buffer",
               "program": "Program", "vertex array": "VertexArray",
               "depth buffer": "Renderbuffer"}


class ProgramValues:
    """The uniform values one user keeps on a program. The context compiles each program once and
    hands it to every user with the same sources and defines, but uniform values live in the
    program: each user keeps its own here, and they are set again whenever another user set the
    program's last (two simulations of one graph with other ranges, two meshes of one shader in
    other colours)."""

    def __init__(self, ctx, program):
        self.ctx, self.program, self.values = ctx, program, {}

    def set(self, name, value):
        """Keep ``value`` for uniform ``name`` (active in the program) and set it now."""
        self.ctx.make_current()
        self.current()
        self.ctx.device.set_uniform(self.program, name, value)
        self.values[name] = value

    def current(self):
        """Make the program hold this user's values (a no-op when it already does)."""
        users = self.ctx._program_users
        if users.get(id(self.program)) is not self:
            for name, value in self.values.items():
                self.ctx.device.set_uniform(self.program, name, value)
            users[id(self.program)] = self


class Group:
    """The GL objects one component (a simulation, a renderer, a post chain) makes: made through
    the context, which counts them, and released together by one ``release()`` (safe twice; a
    component whose constructor fails releases its group before it re-raises)."""

    def __init__(self, ctx):
        self.ctx, self.objects = ctx, []

    def _keep(self, obj):
        self.objects.append(obj)
        return obj

    def texture(self, *args, **kwargs):
        return self._keep(self.ctx.texture(*args, **kwargs))

    def compressed_texture(self, compressed):
        return self._keep(self.ctx.compressed_texture(compressed))

    def framebuffer(self, texture, depth=None):
        return self._keep(self.ctx.framebuffer(texture, depth))

    def depth(self, size, texture=False):
        """A depth buffer of ``size`` (for a framebuffer that depth-tests), or a depth texture."""
        return self._keep(self.ctx.depth(size, texture))

    def buffer(self, data):
        return self._keep(self.ctx.buffer(data))

    def vertex_array(self, program, content, indices=None):
        return self._keep(self.ctx.vertex_array(program, content, indices))

    def fullscreen(self, program):
        return self._keep(self.ctx.fullscreen(program))

    def release(self):
        if self.ctx._open:
            self.ctx.free(*reversed(self.objects))
        self.objects = []
