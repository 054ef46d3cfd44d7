"""The headless GL context: making one, reporting what it can do, and owning its GL objects.

:func:`open_context` tries moderngl's EGL back-end first (no display needed: Mesa llvmpipe on a
machine without a GPU, the vendor's driver where there is one), then the other standalone back-ends.
The returned :class:`Context` is the one owner of every texture, framebuffer, buffer and program the
package makes, counts them, and releases them all on ``release()`` or at the end of a ``with``.
"""

import ctypes
import os
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from ..errors import CapabilityError, ContextError, ParameterError
from .shaders import compile_program

INSTALL_HINT = (
    "install a GL driver with EGL: on Debian/Ubuntu 'apt-get install libegl1 libgl1 "
    "libgl1-mesa-dri libegl-mesa0' (Mesa llvmpipe renders on the CPU; a GPU's own driver also "
    "works)"
)
# Formats the state may use: name -> moderngl dtype (four components).
FORMAT_DTYPES = {"rgba8": "f1", "rgba16f": "f2", "rgba32f": "f4"}
# Every texture format made here: name -> (components, moderngl dtype). r32f is for the density
# target only (one channel is all it needs; not ES 2.0, so it is probed like the float formats).
TEXTURE_FORMATS = {**{name: (4, dtype) for name, dtype in FORMAT_DTYPES.items()}, "r32f": (1, "f4")}
_NUMPY = {"f1": np.uint8, "f2": np.float16, "f4": np.float32}


def numpy_dtype(fmt):
    """The numpy dtype of one channel of a texture of ``fmt``, as read back or written."""
    return _NUMPY[TEXTURE_FORMATS[fmt][1]]


def bytes_per_texel(fmt):
    components, dtype = TEXTURE_FORMATS[fmt]
    return components * np.dtype(_NUMPY[dtype]).itemsize


def _backends():
    """Back-ends to try, in order; ES2PARTICLES_BACKEND picks one (egl, or '' for the default)."""
    forced = os.environ.get("ES2PARTICLES_BACKEND")
    if forced is not None:
        return [forced or None]
    return ["egl", None]


# Profiles to ask for, in order, with the GL version requested. A request for 3.0 names no
# profile, and drivers answer it with their newest compatibility-profile context. There, points
# that are not sprites follow the legacy point rules, which llvmpipe rasterises as rectangles:
# 2^20 one-pixel points draw ~25% faster than through the quad path that core profiles force (every
# point is a sprite in core GL and in ES). The core profile is the fallback.
PROFILES = (("compatibility", 300), ("core", 330))
MIN_GL_VERSION = 330  # what moderngl itself needs


def _profiles():
    """Profiles to try; ES2PARTICLES_PROFILE (compatibility or core) asks for one alone."""
    forced = os.environ.get("ES2PARTICLES_PROFILE")
    if forced is None:
        return PROFILES
    chosen = [p for p in PROFILES if p[0] == forced]
    if not chosen:
        raise ContextError(f"ES2PARTICLES_PROFILE must be one of "
                           f"{[p for p, _ in PROFILES]}, got {forced!r}")
    return chosen


def open_context(device=None):
    """Make a headless :class:`Context`, or raise :class:`ContextError` saying what to install.
    ``device``: the index of the EGL device to render on, where a machine has several GPUs
    (None: the driver's first)."""
    import moderngl

    failures = []
    for backend in _backends():
        kwargs = {"standalone": True}
        if backend:
            kwargs["backend"] = backend
        if device is not None and backend == "egl":
            kwargs["device_index"] = int(device)
        errors = []
        for profile, version in _profiles():
            try:
                mgl = moderngl.create_context(require=version, **kwargs)
            except Exception as error:  # the binding raises bare Exceptions with the loader's words
                errors.append(str(error).strip() or type(error).__name__)
                continue
            if mgl.version_code >= MIN_GL_VERSION:
                return Context(mgl, backend or "default", profile)
            errors.append(f"{profile} profile is GL {mgl.version_code}, below {MIN_GL_VERSION}")
            mgl.release()
        unique = list(dict.fromkeys(errors))  # a missing library fails both profiles alike
        failures.append(f"{backend or 'default'}: " + "; ".join(unique))
    raise ContextError("no headless OpenGL context could be made; " + INSTALL_HINT
                       + "\n  tried: " + "\n  tried: ".join(failures))


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
    probe_store_rule: object = field(default=None, repr=False, compare=False)

    @property
    def store_rule(self):
        """How the driver turns a float into a byte in an RGBA8 store (round-to-nearest,
        truncate, floor256): probed the first time it is asked for, then kept."""
        if not hasattr(self, "_store_rule"):
            self._store_rule = self.probe_store_rule() if self.probe_store_rule else "unknown"
        return self._store_rule

    @property
    def software_rasteriser(self):
        """True for a CPU rasteriser that bins a whole draw before rasterising it (llvmpipe,
        softpipe): large point draws are cut into slices there (see render.py)."""
        return any(name in self.renderer.lower() for name in ("llvmpipe", "softpipe", "swrast"))

    def lines(self):
        """The report as (label, value) rows."""
        rows = [("backend", self.backend), ("profile", self.profile), ("vendor", self.vendor),
                ("renderer", self.renderer), ("GL version", self.version),
                ("max texture size", self.max_texture_size),
                ("max particles (max texture size squared)", self.max_texture_size ** 2),
                ("vertex texture image units", self.max_vertex_texture_units),
                ("point size range", "%g..%g" % tuple(self.point_size_range))]
        for name in TEXTURE_FORMATS:
            rows.append((f"{name} render target / additive blend",
                         f"{_yes(self.renderable.get(name))} / {_yes(self.blendable.get(name))}"))
        rows.append(("8-bit store of a float channel", self.store_rule))
        return rows

    def __str__(self):
        width = max(len(label) for label, _ in self.lines())
        return "\n".join(f"{label:<{width}}  {value}" for label, value in self.lines())


def _yes(flag):
    return "yes" if flag else "no"


class FormatFlags(dict):
    """format -> flag, filled on the first question about a format: ``probe(fmt)`` renders into
    a 4x4 target of it (~5 ms a format on llvmpipe) and fills this and its sibling mapping. A name
    that is not a texture format stays absent (``get`` gives None)."""

    def __init__(self, probe):
        super().__init__()
        self._probe = probe

    def __missing__(self, fmt):
        if fmt not in TEXTURE_FORMATS:
            raise KeyError(fmt)
        self._probe(fmt)
        return dict.__getitem__(self, fmt)

    def get(self, fmt, default=None):
        return self[fmt] if fmt in TEXTURE_FORMATS else default


class Context:
    """A headless GL context and the one owner of the GL objects made through it."""

    def __init__(self, mgl, backend="egl", profile="core"):
        self.mgl = mgl
        self.backend = backend
        self.profile = profile
        self._gl_calls = {}
        self._program_users = {}  # id(program) -> the ProgramValues that set its uniforms last
        Context._current = self  # a new context is current
        self._owned = []
        self._programs = {}
        self._caps = None
        self._fullscreen = None

    _current = None  # the Context made current last (GL calls go to it, whoever makes them)

    def make_current(self):
        """Make this context the thread's current one: GL calls go to whichever context was made
        current last, so every object makes its own current before GL work (a no-op when it
        already is). A released context raises :class:`ContextError`."""
        if self.mgl is None:
            raise ContextError("this context was released; open a new one with open_context()")
        if Context._current is not self:
            self.mgl.__enter__()
            Context._current = self

    def flush(self):
        """glFlush: hand the queued GL work to the driver without waiting for it to finish.

        moderngl has no call for it, so it comes through moderngl's own GL function loader; where
        that loader is not there, this does nothing (a flush changes speed, never results).
        """
        self._gl_function("glFlush")()

    # -- ownership ---------------------------------------------------------------------------

    def own(self, obj):
        """Take ownership of a moderngl object; it is released with the context."""
        self._owned.append(obj)
        return obj

    def free(self, *objects):
        """Release objects made through this context before the context itself goes."""
        import moderngl

        self.make_current()  # GL names are per context: deleting them elsewhere deletes others
        if any(isinstance(obj, moderngl.Framebuffer) for obj in objects):
            # moderngl re-binds the last used framebuffer when it makes the next one; if that one
            # was deleted, GL answers INVALID_OPERATION. Park on the default framebuffer first.
            self.mgl.detect_framebuffer(0).use()
        for obj in objects:
            if obj is None:
                continue
            for i, owned in enumerate(self._owned):
                if owned is obj:
                    del self._owned[i]
                    obj.release()
                    break

    def live_objects(self):
        """Count of GL objects alive, by type name (a test can check a run leaks nothing)."""
        counts = {}
        for obj in self._owned:
            counts[type(obj).__name__] = counts.get(type(obj).__name__, 0) + 1
        return counts

    def release(self):
        """Release every owned object and the context; safe to call twice."""
        if self.mgl is not None:
            self.make_current()  # its objects' names must be deleted in it, not in another
        while self._owned:
            self._owned.pop().release()
        self._programs.clear()
        self._fullscreen = None
        if self.mgl is not None:
            self.mgl.release()
            self.mgl = None
        # Releasing a context may leave another (or none) current, whatever was before: the next
        # make_current() must switch for real.
        Context._current = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()

    # -- factories ---------------------------------------------------------------------------

    def texture(self, size, fmt="rgba8", data=None, filter_nearest=True):
        """A 2D texture of ``fmt`` (rgba8, rgba16f, rgba32f), NEAREST-sampled and clamped.

        Packed state must be sampled NEAREST: linear filtering would mix high and low bytes.
        """
        components, dtype = TEXTURE_FORMATS[fmt]
        tex = self.own(self.mgl.texture(tuple(size), components, data=data, dtype=dtype))
        import moderngl

        mode = moderngl.NEAREST if filter_nearest else moderngl.LINEAR
        tex.filter = (mode, mode)
        tex.repeat_x = tex.repeat_y = False
        return tex

    def compressed_texture(self, compressed):
        """A 2D texture holding :class:`~es2particles.fields.astc.Compressed` ASTC blocks as they are,
        NEAREST-sampled and clamped; :class:`CapabilityError` where the driver cannot take them.

        moderngl's ``texture`` checks data against the uncompressed size, so an owned RGBA8
        texture of that size is made and its level 0 replaced by glCompressedTexImage2D.
        """
        import moderngl

        from ..fields import astc

        if not isinstance(compressed, astc.Compressed):
            raise ParameterError(f"compressed must be an astc.Compressed (see astc.compress), got "
                                 f"{type(compressed).__name__}")
        reason = astc.unavailable(self, encode=False)
        if reason:
            raise CapabilityError(f"ASTC textures cannot be used: {reason}")
        self.make_current()  # the upload is a raw GL call: it goes to the current context
        upload = self._gl_function("glCompressedTexImage2D", ctypes.c_uint, ctypes.c_int,
                                   ctypes.c_uint, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                                   ctypes.c_int, ctypes.c_char_p, required=True)
        c = compressed
        tex = self.own(self.mgl.texture((c.width, c.height), 4))
        tex.use(0)
        upload(GL_TEXTURE_2D, 0, c.internal_format, c.width, c.height, 0, c.nbytes, c.data)
        error = self.mgl.error
        if error != "GL_NO_ERROR":
            self.free(tex)
            raise CapabilityError(f"glCompressedTexImage2D of {c.width}x{c.height} ASTC "
                                  f"{c.block[0]}x{c.block[1]} failed with {error}")
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        tex.repeat_x = tex.repeat_y = False
        return tex

    def framebuffer(self, texture, depth=None):
        return self.own(self.mgl.framebuffer(color_attachments=[texture],
                                             depth_attachment=depth))

    def buffer(self, data):
        return self.own(self.mgl.buffer(data))

    def program(self, vertex, fragment, defines=None, vertex_prelude=None, fragment_prelude=None,
                fragment_epilogue=None):
        """Compiled program for the shader files, defines and generated preludes and epilogue
        (see ``bindings.py``); compiled once, then cached."""
        key = (str(vertex), str(fragment), tuple(sorted((defines or {}).items())),
               tuple(vertex_prelude or ()), tuple(fragment_prelude or ()),
               tuple(fragment_epilogue or ()))
        if key not in self._programs:
            self._programs[key] = self.own(compile_program(self.mgl, vertex, fragment, defines,
                                                           vertex_prelude, fragment_prelude,
                                                           fragment_epilogue))
        return self._programs[key]

    @contextmanager
    def scope(self, framebuffer, blend=None, point_size=False, depth_test=False,
              depth_write=True, sprites=False):
        """GL state for one draw: target ``framebuffer``, blending (None, ``"add"``: ONE, ONE, or
        ``"over"``: premultiplied), program point size, depth test and depth writes, point
        sprites. Everything is switched off again on the way out, also when an exception passes
        through.

        ``sprites``: gl_PointCoord varies over each point. Core profiles and ES always do that;
        by the spec, the compatibility profile that :func:`open_context` prefers does it only with
        GL_POINT_SPRITE enabled, which moderngl has no flag for, so it is switched through the
        GL function loader. (Mesa varies it for ES shaders even without the switch.)"""
        import moderngl

        flags = moderngl.NOTHING
        if blend is not None:
            flags |= moderngl.BLEND
        if point_size:
            flags |= moderngl.PROGRAM_POINT_SIZE
        if depth_test:
            flags |= moderngl.DEPTH_TEST
        framebuffer.use()
        framebuffer.depth_mask = bool(depth_write)
        self.mgl.enable_only(flags)
        if blend is not None:
            self.mgl.blend_func = BLEND_FUNCTIONS[blend]
        point_sprite = sprites and self.profile == "compatibility"
        if point_sprite:
            self._gl_switch("glEnable", GL_POINT_SPRITE)
        try:
            yield
        finally:
            if point_sprite:
                self._gl_switch("glDisable", GL_POINT_SPRITE)
            framebuffer.depth_mask = True
            self.mgl.enable_only(moderngl.NOTHING)

    def _gl_switch(self, name, cap):
        """glEnable/glDisable of a capability moderngl does not name."""
        self._gl_function(name, ctypes.c_uint)(cap)

    def _gl_function(self, name, *argtypes, required=False):
        """A GL entry point moderngl has no call for, through moderngl's own function loader
        (loaded once). Where that loader is not there: a no-op for calls that change speed or
        state moderngl's drivers already have, never results; :class:`CapabilityError` for a
        ``required`` one, whose effect is the result (an upload)."""
        if name not in self._gl_calls:
            loader = getattr(self.mgl.mglo, "_context", None)
            address = loader.load_opengl_function(name) if loader is not None else 0
            self._gl_calls[name] = (ctypes.CFUNCTYPE(None, *argtypes)(address) if address
                                    else None)
        if self._gl_calls[name] is None:
            if required:
                raise CapabilityError(f"the GL function {name} cannot be loaded through "
                                      f"moderngl on the {self.backend} back-end")
            return lambda *args: None
        return self._gl_calls[name]

    def vertex_array(self, program, content):
        return self.own(self.mgl.vertex_array(program, content))

    def fullscreen(self, program):
        """A vertex array drawing the full-screen triangle of ``lib/fullscreen.vert``."""
        if self._fullscreen is None:
            self._fullscreen = self.buffer(np.array([-1, -1, 3, -1, -1, 3], dtype="f4"))
        return self.vertex_array(program, [(self._fullscreen, "2f", "a_position")])

    def group(self):
        """A new :class:`Group`: the GL objects of one component, released together."""
        return Group(self)


    # -- capabilities ------------------------------------------------------------------------

    @property
    def caps(self):
        """The :class:`Capabilities` report, probed once."""
        if self._caps is None:
            self._caps = _probe(self)
        return self._caps

    def require_format(self, fmt, blend=False):
        """Raise :class:`CapabilityError` unless ``fmt`` is renderable (and blendable)."""
        if fmt not in FORMAT_DTYPES:
            raise CapabilityError(f"format must be one of {sorted(FORMAT_DTYPES)}, got {fmt!r}")
        if not self.caps.renderable.get(fmt) or (blend and not self.caps.blendable.get(fmt)):
            need = "rendered to with additive blending" if blend else "rendered to"
            raise CapabilityError(f"format {fmt!r} cannot be {need} on {self.caps.renderer}")


def read_rgb(texture):
    """An RGBA8 texture as an (h, w, 3) uint8 image, top row first (GL's first row is the
    bottom)."""
    w, h = texture.size
    pixels = np.frombuffer(texture.read(), dtype=np.uint8).reshape(h, w, 4)
    return pixels[::-1, :, :3].copy()


def _probe(ctx):
    mgl = ctx.mgl
    info = mgl.info
    caps = Capabilities(
        backend=ctx.backend,
        profile=ctx.profile,
        vendor=str(info.get("GL_VENDOR", "?")),
        renderer=str(info.get("GL_RENDERER", "?")),
        version=str(info.get("GL_VERSION", "?")),
        max_texture_size=int(info.get("GL_MAX_TEXTURE_SIZE", 0)),
        max_vertex_texture_units=int(info.get("GL_MAX_VERTEX_TEXTURE_IMAGE_UNITS", 0)),
        point_size_range=tuple(info.get("GL_POINT_SIZE_RANGE", (1.0, 1.0))),
        probe_store_rule=lambda: _probe_store_rule(ctx),
    )

    def probe(fmt):
        renderable, blendable = _probe_format(ctx, fmt)
        dict.__setitem__(caps.renderable, fmt, renderable)
        dict.__setitem__(caps.blendable, fmt, blendable)

    caps.renderable, caps.blendable = FormatFlags(probe), FormatFlags(probe)
    return caps


def _draw_constant(ctx, fmt, colour, blends=1):
    """Render a constant colour into a 4x4 target of ``fmt``: once, then ``blends`` times more
    with additive blending; the first texel after each draw, as float64 (r32f: only .r means
    anything)."""
    from .command import FullscreenCommand

    group = ctx.group()
    try:
        tex = group.texture((4, 4), fmt)
        fbo = group.framebuffer(tex)
        fbo.clear(0, 0, 0, 0)
        command = FullscreenCommand(group, "lib/constant.frag", "format probe")
        command.set("u_colour", tuple(colour))
        components = TEXTURE_FORMATS[fmt][0]
        texels = []
        for draw in range(1 + blends):
            command.draw(fbo, {}, blend="add" if draw else None)
            texel = np.frombuffer(tex.read(), dtype=numpy_dtype(fmt)).reshape(-1, components)[0]
            texels.append(np.resize(texel.astype(np.float64), 4))
        return texels
    finally:
        group.release()


def _probe_format(ctx, fmt):
    """(renderable, blendable): one draw of 0.25 must store 0.25 (64 in RGBA8), and one more
    blended onto it must make 0.5 (128)."""
    try:
        once, twice = _draw_constant(ctx, fmt, (0.25, 0.5, 2.0, 1.0))
    except Exception:
        return False, False
    if ctx.mgl.error != "GL_NO_ERROR":
        return False, False
    if fmt == "rgba8":
        return bool(once[0] == 64), bool(twice[0] == 128)
    return bool(abs(once[0] - 0.25) < 1e-3), bool(abs(twice[0] - 0.5) < 1e-3)


def _probe_store_rule(ctx):
    """Which model of float -> byte conversion the driver's RGBA8 stores follow.

    Channel values are chosen between the models' answers: (10.6)/255 gives 11 under rounding and
    10 under truncation or floor(256c); (200.7)/255 gives 200 under truncation and 201 otherwise.
    """
    from ..twins.pack import store_unorm8

    colour = np.array([10.6, 200.7, 100.3, 254.9], dtype=np.float32) / np.float32(255)
    got = _draw_constant(ctx, "rgba8", colour, blends=0)[0]
    for rule in ("round", "truncate", "floor256"):
        if np.array_equal(store_unorm8(colour, rule), got):
            return "round-to-nearest" if rule == "round" else rule
    return "unknown (bytes %s)" % got.astype(int).tolist()


BLEND_FUNCTIONS = {"add": (1, 1), "over": (1, 0x0303)}  # (ONE, ONE), (ONE, ONE_MINUS_SRC_ALPHA)
GL_POINT_SPRITE = 0x8861
GL_TEXTURE_2D = 0x0DE1


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
        self.current()
        self.program[name].value = value
        self.values[name] = value

    def current(self):
        """Make the program hold this user's values (a no-op when it already does)."""
        users = self.ctx._program_users
        if users.get(id(self.program)) is not self:
            for name, value in self.values.items():
                self.program[name].value = value
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

    def depth(self, size):
        """A depth renderbuffer of ``size`` (for a framebuffer that depth-tests)."""
        return self._keep(self.ctx.own(self.ctx.mgl.depth_renderbuffer(tuple(size))))

    def buffer(self, data):
        return self._keep(self.ctx.buffer(data))

    def vertex_array(self, program, content):
        return self._keep(self.ctx.vertex_array(program, content))

    def fullscreen(self, program):
        return self._keep(self.ctx.fullscreen(program))

    def release(self):
        if self.ctx.mgl is not None:
            self.ctx.free(*reversed(self.objects))
        self.objects = []
