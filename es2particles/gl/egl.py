"""Opening a headless context, and probing what it can do.

:func:`open_context` tries moderngl's EGL back-end first (no display needed: Mesa llvmpipe on a
machine without a GPU, the vendor's driver where there is one), then the other standalone
back-ends, and returns a :class:`~es2particles.gl.context.Context` over a
:class:`~es2particles.gl.device.GLDevice` whose capabilities are probed once, at start-up: the
limits the driver reports, and per texture format, the first time one is asked for, whether it
can be rendered to and blended into (a draw into a 4x4 target of it).
"""

import os
import sys

import numpy as np

from ..errors import ContextError
from . import BACKENDS
from .command import DrawCommand
from .context import TEXTURE_FORMATS, Capabilities, Context, FormatFlags, numpy_dtype
from .device import DrawState, GLDevice

INSTALL_HINT = (
    "install a GL driver with EGL: on Debian/Ubuntu 'apt-get install libegl1 libgl1 "
    "libgl1-mesa-dri libegl-mesa0' (Mesa llvmpipe renders on the CPU; a GPU's own driver also "
    "works)"
)


def chosen_backend(backend=None):
    """``backend``, or ES2PARTICLES_BACKEND's, or auto; anything else is refused naming where it
    came from."""
    where = "--backend"
    if backend is None:
        backend, where = os.environ.get("ES2PARTICLES_BACKEND") or "auto", "ES2PARTICLES_BACKEND"
    if backend not in BACKENDS:
        raise ContextError(f"{where} must be one of {', '.join(BACKENDS)}, got {backend!r}")
    return backend


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


def open_context(device=None, backend=None):
    """Make a headless :class:`Context`, or raise :class:`ContextError` saying what to install.
    ``device``: the index of the EGL device to render on, where a machine has several GPUs
    (None: the driver's first). ``backend``: ``gl`` (desktop OpenGL through moderngl), ``gles``
    (OpenGL ES through EGL), or ``auto`` (desktop GL where moderngl can make a context, ES
    otherwise); None: ES2PARTICLES_BACKEND's, else auto."""
    backend = chosen_backend(backend)
    failures = []
    if backend in ("gl", "auto"):
        try:
            return Context(_desktop(device), probe=probe_capabilities)
        except ContextError as error:
            if backend == "gl":
                raise
            failures.append(str(error))
    try:
        from .gles import GLESDevice

        return Context(GLESDevice(device), probe=probe_capabilities)
    except ContextError as error:
        failures.append(f"OpenGL ES: {error}")
    raise ContextError("; ".join(failures))


def _desktop(device):
    """A moderngl device on moderngl's EGL back-end, else its default one."""
    import moderngl

    failures = []
    for backend in ("egl", None):
        kwargs = {"standalone": True}
        if backend:
            kwargs["backend"] = backend
        if device is not None and backend == "egl":
            kwargs["device_index"] = int(device)
        errors = []
        for profile, version in _profiles():
            try:
                mgl = _create(moderngl, require=version, **kwargs)
            except Exception as error:  # the binding raises bare Exceptions with the loader's words
                errors.append(str(error).strip() or type(error).__name__)
                continue
            if mgl.version_code >= MIN_GL_VERSION:
                return GLDevice(mgl, backend or "default", profile)
            errors.append(f"{profile} profile is GL {mgl.version_code}, below {MIN_GL_VERSION}")
            mgl.release()
        unique = list(dict.fromkeys(errors))  # a missing library fails both profiles alike
        failures.append(f"{backend or 'default'}: " + "; ".join(unique))
    raise ContextError("no headless OpenGL context could be made; " + INSTALL_HINT
                       + " (tried: " + "; ".join(" ".join(f.split()) for f in failures) + ")")


# The libraries' names every Linux GL install has (glvnd's and Mesa's alike): given, they spare
# glcontext its ctypes.util.find_library, which runs `ldconfig -p` twice (~5 ms of a still's
# start). glcontext's GLCONTEXT_LINUX_LIBGL / _LIBEGL still choose others.
LINUX_LIBRARIES = {"libgl": "libGL.so.1", "libegl": "libEGL.so.1"}


def _create(moderngl, **kwargs):
    """moderngl.create_context, naming the EGL back-end's libraries on Linux; where one is not
    found under its name, asking again as glcontext would (find_library)."""
    if kwargs.get("backend") == "egl" and sys.platform.startswith("linux"):
        try:
            return moderngl.create_context(**kwargs, **LINUX_LIBRARIES)
        except Exception as error:  # glcontext says "libEGL.so.1 not loaded"
            if not any(f"{name} not loaded" in str(error) for name in LINUX_LIBRARIES.values()):
                raise
    return moderngl.create_context(**kwargs)


def probe_capabilities(ctx):
    """The :class:`Capabilities` of a GL context: its limits now, each format's flags when first
    asked for, the 8-bit store rule when first asked for."""
    info = ctx.device.info()
    caps = Capabilities(
        backend=ctx.backend,
        profile=ctx.profile,
        vendor=str(info.get("GL_VENDOR", "?")),
        renderer=str(info.get("GL_RENDERER", "?")),
        version=str(info.get("GL_VERSION", "?")),
        max_texture_size=int(info.get("GL_MAX_TEXTURE_SIZE", 0)),
        max_vertex_texture_units=int(info.get("GL_MAX_VERTEX_TEXTURE_IMAGE_UNITS", 0)),
        point_size_range=tuple(info.get("GL_POINT_SIZE_RANGE", (1.0, 1.0))),
        extensions=frozenset(ctx.device.extensions()),
        probe_store_rule=lambda: _probe_store_rule(ctx),
        probe_multiply_add=lambda: _probe_multiply_add(ctx),
        probe_precision=ctx.device.shader_precision,
        probe_point_size=lambda: _probe_point_size(ctx),
    )

    def probe_format(fmt):
        renderable, blendable = _probe_format(ctx, fmt)
        dict.__setitem__(caps.renderable, fmt, renderable)
        dict.__setitem__(caps.blendable, fmt, blendable)

    caps.renderable, caps.blendable = FormatFlags(probe_format), FormatFlags(probe_format)
    return caps


def _draw_constant(ctx, fmt, colour, blends=1, shader="lib/constant.frag", uniform="u_colour"):
    """Render a constant colour into a 4x4 target of ``fmt``: once, then ``blends`` times more
    with additive blending; the first texel after each draw, as float64 (r32f: only .r means
    anything). ``shader`` and its ``uniform``: another probe's constant."""
    group = ctx.group()
    try:
        tex = group.texture((4, 4), fmt)
        fbo = group.framebuffer(tex)
        ctx.clear(fbo, (0, 0, 0, 0))
        command = DrawCommand(group, "format probe", shader)
        command.set(uniform, tuple(colour))
        components = TEXTURE_FORMATS[fmt][0]
        texels = []
        for draw in range(1 + blends):
            command.state = DrawState(blend="add" if draw else None)
            command.draw(fbo, {})
            texel = np.frombuffer(ctx.read(tex), dtype=numpy_dtype(fmt)).reshape(-1, components)[0]
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
    if ctx.error() != "GL_NO_ERROR":
        return False, False
    if fmt == "rgba8":
        return bool(once[0] == 64), bool(twice[0] == 128)
    return bool(abs(once[0] - 0.25) < 1e-3), bool(abs(twice[0] - 0.5) < 1e-3)


POINT_PROBE_WIDTH = 4096  # the widest point the probe can see (wider than any picture's side here)


def _probe_point_size(ctx):
    """The width in pixels of the widest point the driver draws, up to a row of
    POINT_PROBE_WIDTH texels: one point asked for as wide as the row, at its centre, and its lit
    texels counted. Drivers may draw wider than their reported range: NVIDIA's ES context
    reports 1..10 and its desktop GL 1..189.875 (POINT_SIZE_RANGE), and both draw 2048."""
    width = min(POINT_PROBE_WIDTH, ctx.caps.max_texture_size)
    group = ctx.group()
    try:
        tex = group.texture((width, 1), "rgba8")
        fbo = group.framebuffer(tex)
        ctx.clear(fbo, (0, 0, 0, 0))
        centre = group.buffer(np.zeros(2, dtype="f4").tobytes())
        command = DrawCommand(group, "point size probe", "lib/constant.frag",
                              vertex="lib/point_probe.vert",
                              vertices=[(centre, "2f", "a_position")], primitive="points",
                              state=DrawState(point_size=True))
        command.set("u_colour", (1.0, 1.0, 1.0, 1.0))
        command.set("u_size", float(width))
        command.draw(fbo, {})
        lit = np.frombuffer(ctx.read(tex), dtype=np.uint8).reshape(-1, 4)[:, 0] > 127
        return int(lit.sum())
    finally:
        group.release()


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


def _probe_multiply_add(ctx):
    """Whether a shader's a * b + c is one rounding (fused) or two: lib/fma_probe.frag. NVIDIA's
    driver fuses, llvmpipe does not; a numpy twin that rounds each step (twins/trig.py) then
    matches the shader only to within an ulp or so, not bit for bit."""
    if not ctx.caps.renderable.get("rgba32f"):
        return "unknown (no rgba32f target)"
    a = float(np.float32(1 + 2.0 ** -12))
    got = _draw_constant(ctx, "rgba32f", (a, a, 1 + 2.0 ** -11), blends=0,
                         shader="lib/fma_probe.frag", uniform="u_abc")[0][0]
    return {0.0: "two roundings", 1.0: "fused (one rounding)"}.get(float(got), f"unknown ({got!r})")
