"""OpenGL ES through EGL's ES API: the device for machines whose driver offers ES and not a desktop
profile moderngl can use (a Raspberry Pi's VideoCore, Mali boards under Panfrost), and the check
that the package's ES 2.0 code runs in an ES context, not only in the browser.

A thin ctypes layer over libEGL and libGLESv2, not PyOpenGL: the device needs 76 entry points
(the glUniform family is 14 of them), all of ES 2.0 core (ASTC and the float formats are ES 2.0
calls with an extension's enums), which ctypes calls directly, with no further dependency.
:class:`GLESDevice` answers the same interface as the moderngl
:class:`~es2particles.gl.device.GLDevice`, so the executor and the plans do not change.

What ES fixes that desktop GL leaves to flags: every point is a sprite and takes its size from the
vertex shader (no PROGRAM_POINT_SIZE or POINT_SPRITE switch), and there are no vertex array
objects in ES 2.0 (a vertex array here is the attribute bindings, set at each draw). On an ES 3
context (what Mesa and NVIDIA answer to a request for ES 2) the float textures are made with sized
internal formats, which the float render-target extensions need; on an ES 2.0 context, with the
unsized ones of OES_texture_float and OES_texture_half_float.
"""

import ctypes
import re

import numpy as np

from ..errors import CapabilityError, ContextError
from ..io.signals import signals_held
from .device import (BLEND_FUNCTIONS, PRECISIONS, ActiveUniform, ModernglLike,
                     ProgramError)

# -- enums (the ES 2.0 headers' values) ---------------------------------------------------------
EGL_NONE, EGL_EXTENSIONS, EGL_RENDERABLE_TYPE = 0x3038, 0x3055, 0x3040
EGL_OPENGL_ES2_BIT, EGL_OPENGL_ES_API, EGL_CONTEXT_CLIENT_VERSION = 0x4, 0x30A0, 0x3098
EGL_PLATFORM_DEVICE_EXT, EGL_SURFACE_TYPE = 0x313F, 0x3033

TEXTURE_2D, TEXTURE0, RGBA, RED = 0x0DE1, 0x84C0, 0x1908, 0x1903
UNSIGNED_BYTE, UNSIGNED_INT, FLOAT = 0x1401, 0x1405, 0x1406
HALF_FLOAT, HALF_FLOAT_OES = 0x140B, 0x8D61
RGBA8, RGBA16F, RGBA32F, R32F = 0x8058, 0x881A, 0x8814, 0x822E
DEPTH_COMPONENT, DEPTH_COMPONENT16, DEPTH_COMPONENT24 = 0x1902, 0x81A5, 0x81A6
FRAMEBUFFER, RENDERBUFFER, COLOR_ATTACHMENT0, DEPTH_ATTACHMENT = 0x8D40, 0x8D41, 0x8CE0, 0x8D00
FRAMEBUFFER_COMPLETE = 0x8CD5
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER, STATIC_DRAW = 0x8892, 0x8893, 0x88E4
TEXTURE_MIN_FILTER, TEXTURE_MAG_FILTER, TEXTURE_WRAP_S, TEXTURE_WRAP_T = 0x2801, 0x2800, 0x2802, \
    0x2803
NEAREST, LINEAR, CLAMP_TO_EDGE = 0x2600, 0x2601, 0x812F
UNPACK_ALIGNMENT, PACK_ALIGNMENT = 0x0CF5, 0x0D05
VERTEX_SHADER, FRAGMENT_SHADER = 0x8B31, 0x8B30
COMPILE_STATUS, LINK_STATUS, INFO_LOG_LENGTH = 0x8B81, 0x8B82, 0x8B84
ACTIVE_UNIFORMS, ACTIVE_ATTRIBUTES = 0x8B86, 0x8B89
BLEND, DEPTH_TEST, LESS = 0x0BE2, 0x0B71, 0x0201
COLOR_BUFFER_BIT, DEPTH_BUFFER_BIT = 0x4000, 0x0100
POINTS, TRIANGLES = 0x0000, 0x0004
VENDOR, RENDERER, VERSION, SHADING_LANGUAGE_VERSION, EXTENSIONS = 0x1F00, 0x1F01, 0x1F02, \
    0x8B8C, 0x1F03
# glGetIntegerv / glGetFloatv queries that info() reports, by the name moderngl's info uses.
INTEGERS = {"GL_MAX_TEXTURE_SIZE": 0x0D33, "GL_MAX_VERTEX_TEXTURE_IMAGE_UNITS": 0x8B4C,
            "GL_MAX_TEXTURE_IMAGE_UNITS": 0x8872, "GL_MAX_VERTEX_ATTRIBS": 0x8869,
            "GL_MAX_RENDERBUFFER_SIZE": 0x84E8, "GL_MAX_VARYING_VECTORS": 0x8DFC}
ALIASED_POINT_SIZE_RANGE = 0x846E
ERRORS = {0: "GL_NO_ERROR", 0x0500: "GL_INVALID_ENUM", 0x0501: "GL_INVALID_VALUE",
          0x0502: "GL_INVALID_OPERATION", 0x0505: "GL_OUT_OF_MEMORY",
          0x0506: "GL_INVALID_FRAMEBUFFER_OPERATION"}
SAMPLER_2D = 0x8B5E
# a uniform's GL type -> (glUniform call family, components per element)
UNIFORM_TYPES = {0x1406: ("f", 1), 0x8B50: ("f", 2), 0x8B51: ("f", 3), 0x8B52: ("f", 4),
                 0x1404: ("i", 1), 0x8B53: ("i", 2), 0x8B54: ("i", 3), 0x8B55: ("i", 4),
                 0x8B56: ("i", 1), 0x8B57: ("i", 2), 0x8B58: ("i", 3), 0x8B59: ("i", 4),
                 0x8B5A: ("m", 2), 0x8B5B: ("m", 3), 0x8B5C: ("m", 4),
                 SAMPLER_2D: ("i", 1), 0x8B60: ("i", 1)}

_u, _i, _f, _p = ctypes.c_uint, ctypes.c_int, ctypes.c_float, ctypes.c_void_p
# name -> (result, argument types): the entry points the device calls
SIGNATURES = {
    "glGetError": (_u, ()), "glGetString": (ctypes.c_char_p, (_u,)),
    "glGetIntegerv": (None, (_u, _p)), "glGetFloatv": (None, (_u, _p)),
    "glFlush": (None, ()), "glFinish": (None, ()),
    "glEnable": (None, (_u,)), "glDisable": (None, (_u,)), "glIsEnabled": (ctypes.c_ubyte, (_u,)),
    "glBlendFunc": (None, (_u, _u)), "glDepthFunc": (None, (_u,)),
    "glDepthMask": (None, (ctypes.c_ubyte,)), "glColorMask": (None, (ctypes.c_ubyte,) * 4),
    "glViewport": (None, (_i, _i, _i, _i)), "glClearColor": (None, (_f, _f, _f, _f)),
    "glClearDepthf": (None, (_f,)), "glClear": (None, (_u,)),
    "glPixelStorei": (None, (_u, _i)),
    "glGenTextures": (None, (_i, _p)), "glDeleteTextures": (None, (_i, _p)),
    "glBindTexture": (None, (_u, _u)), "glActiveTexture": (None, (_u,)),
    "glTexParameteri": (None, (_u, _u, _i)),
    "glTexImage2D": (None, (_u, _i, _i, _i, _i, _i, _u, _u, _p)),
    "glTexSubImage2D": (None, (_u, _i, _i, _i, _i, _i, _u, _u, _p)),
    "glCompressedTexImage2D": (None, (_u, _i, _u, _i, _i, _i, _i, _p)),
    "glGenFramebuffers": (None, (_i, _p)), "glDeleteFramebuffers": (None, (_i, _p)),
    "glBindFramebuffer": (None, (_u, _u)),
    "glFramebufferTexture2D": (None, (_u, _u, _u, _u, _i)),
    "glFramebufferRenderbuffer": (None, (_u, _u, _u, _u)),
    "glCheckFramebufferStatus": (_u, (_u,)),
    "glGenRenderbuffers": (None, (_i, _p)), "glDeleteRenderbuffers": (None, (_i, _p)),
    "glBindRenderbuffer": (None, (_u, _u)),
    "glRenderbufferStorage": (None, (_u, _u, _i, _i)),
    "glReadPixels": (None, (_i, _i, _i, _i, _u, _u, _p)),
    "glGenBuffers": (None, (_i, _p)), "glDeleteBuffers": (None, (_i, _p)),
    "glBindBuffer": (None, (_u, _u)), "glBufferData": (None, (_u, ctypes.c_ssize_t, _p, _u)),
    "glBufferSubData": (None, (_u, ctypes.c_ssize_t, ctypes.c_ssize_t, _p)),
    "glCreateShader": (_u, (_u,)), "glDeleteShader": (None, (_u,)),
    "glShaderSource": (None, (_u, _i, _p, _p)), "glCompileShader": (None, (_u,)),
    "glGetShaderiv": (None, (_u, _u, _p)), "glGetShaderInfoLog": (None, (_u, _i, _p, _p)),
    "glCreateProgram": (_u, ()), "glDeleteProgram": (None, (_u,)),
    "glAttachShader": (None, (_u, _u)), "glLinkProgram": (None, (_u,)),
    "glGetProgramiv": (None, (_u, _u, _p)), "glGetProgramInfoLog": (None, (_u, _i, _p, _p)),
    "glUseProgram": (None, (_u,)),
    "glGetActiveUniform": (None, (_u, _u, _i, _p, _p, _p, _p)),
    "glGetActiveAttrib": (None, (_u, _u, _i, _p, _p, _p, _p)),
    "glGetUniformLocation": (_i, (_u, ctypes.c_char_p)),
    "glGetAttribLocation": (_i, (_u, ctypes.c_char_p)),
    "glEnableVertexAttribArray": (None, (_u,)), "glDisableVertexAttribArray": (None, (_u,)),
    "glVertexAttribPointer": (None, (_u, _i, _u, ctypes.c_ubyte, _i, _p)),
    "glDrawArrays": (None, (_u, _i, _i)), "glDrawElements": (None, (_u, _i, _u, _p)),
    "glGetShaderPrecisionFormat": (None, (_u, _u, _p, _p)),
    **{f"glUniform{n}{t}v": (None, (_i, _i, _p)) for n in "1234" for t in "fi"},
    **{f"glUniformMatrix{n}fv": (None, (_i, _i, ctypes.c_ubyte, _p)) for n in "234"},
}
EGL_SIGNATURES = {
    "eglGetDisplay": (_p, (_p,)), "eglInitialize": (_u, (_p, _p, _p)),
    "eglBindAPI": (_u, (_u,)), "eglChooseConfig": (_u, (_p, _p, _p, _i, _p)),
    "eglCreateContext": (_p, (_p, _p, _p, _p)), "eglMakeCurrent": (_u, (_p, _p, _p, _p)),
    "eglDestroyContext": (_u, (_p, _p)), "eglGetError": (_i, ()),
    "eglQueryString": (ctypes.c_char_p, (_p, _i)), "eglGetProcAddress": (_p, (ctypes.c_char_p,)),
}


def _bind(library, signatures):
    """An object whose attributes are ``library``'s functions, typed by ``signatures``."""
    class Calls:
        pass

    calls = Calls()
    for name, (result, arguments) in signatures.items():
        try:
            function = getattr(library, name)
        except AttributeError:
            continue  # looked for only where used (an ES 2.0 library without glClearDepthf...)
        function.restype, function.argtypes = result, list(arguments)
        setattr(calls, name, function)
    return calls


def _load(names, what):
    for name in names:
        try:
            return ctypes.CDLL(name)
        except OSError:
            continue
    raise ContextError(f"{what} ({' or '.join(names)}) cannot be loaded: on Debian/Ubuntu "
                       "'apt-get install libegl1 libgles2 libegl-mesa0'")


class Handle(ModernglLike):
    """A GL object of the ES device: its kind (as the recording device names them), its GL name,
    and what the device keeps of it."""

    def __init__(self, device, kind, name, **details):
        self.device, self.kind, self.name = device, kind, name
        self.__dict__.update(details)

    def __repr__(self):
        return f"<GLES {self.kind} {self.name}>"


# a moderngl-style vertex format item the device reads: "2f" or "2f4" (floats), "4f1" (normalised
# bytes), "3x4" or "x" (padding, 4 or 1 bytes an item)
_FORMAT_ITEM = re.compile(r"^(\d*)(f|x)(1|4)?$")


class GLESDevice:
    """OpenGL ES 2.0 through EGL (see the module's docstring): objects, draws, reads and writes."""

    draws = True
    backend, profile = "gles", "es"

    def __init__(self, device_index=None):
        self.egl = _bind(_load(["libEGL.so.1", "libEGL.so"], "libEGL"), EGL_SIGNATURES)
        self.gl = _bind(_load(["libGLESv2.so.2", "libGLESv2.so"], "libGLESv2"), SIGNATURES)
        self.display, self.context = self._open(device_index)
        try:
            self.make_current()
        except ContextError:
            self.egl.eglDestroyContext(self.display, self.context)
            raise
        version = self.gl.glGetString(VERSION).decode(errors="replace")
        found = re.search(r"OpenGL ES (\d+)\.(\d+)", version)
        self.es3 = bool(found) and int(found.group(1)) >= 3
        self._formats = _texture_formats(self.es3)
        self._read_framebuffers = {}
        self.gl.glPixelStorei(UNPACK_ALIGNMENT, 1)
        self.gl.glPixelStorei(PACK_ALIGNMENT, 1)
        self.gl.glDepthFunc(LESS)

    def _open(self, device_index):
        """(display, context): the EGL device's display where EGL lists devices (no window
        system needed), else the default display; an ES 2 context current on no surface."""
        egl = self.egl
        display = None
        extensions = (egl.eglQueryString(None, EGL_EXTENSIONS) or b"").decode()
        if "EGL_EXT_platform_device" in extensions:
            query = _proc(egl, "eglQueryDevicesEXT", _u, _i, _p, _p)
            platform = _proc(egl, "eglGetPlatformDisplayEXT", _p, _u, _p, _p)
            devices, count = (_p * 16)(), _i()
            if query and platform and query(16, devices, ctypes.byref(count)) and count.value:
                index = 0 if device_index is None else int(device_index)
                if not 0 <= index < count.value:
                    raise ContextError(f"EGL device {index} does not exist (there are "
                                       f"{count.value})")
                display = platform(EGL_PLATFORM_DEVICE_EXT, devices[index], None)
        if not display and device_index is not None:
            raise ContextError(f"EGL device {device_index} cannot be chosen here: this EGL lists "
                               "no devices (EGL_EXT_platform_device)")
        if not display:
            display = egl.eglGetDisplay(None)
        if not display or not egl.eglInitialize(display, None, None):
            raise ContextError(f"EGL could not open a display (EGL error "
                               f"0x{egl.eglGetError():04x})")
        if not egl.eglBindAPI(EGL_OPENGL_ES_API):
            raise ContextError("this EGL has no OpenGL ES API")
        listed = (egl.eglQueryString(display, EGL_EXTENSIONS) or b"").decode()
        if "EGL_KHR_surfaceless_context" not in listed:
            raise ContextError("this EGL cannot make a context current with no surface "
                               "(EGL_KHR_surfaceless_context)")
        # any surface type: the context draws into framebuffer objects, never a surface
        attributes = (_i * 5)(EGL_RENDERABLE_TYPE, EGL_OPENGL_ES2_BIT, EGL_SURFACE_TYPE, 0,
                              EGL_NONE)
        config, found = _p(), _i()
        if not egl.eglChooseConfig(display, attributes, ctypes.byref(config), 1,
                                   ctypes.byref(found)) or not found.value:
            if "EGL_KHR_no_config_context" not in listed:
                raise ContextError("this EGL has no config for OpenGL ES 2")
            config = None  # EGL_KHR_no_config_context: a context of no config
        context = egl.eglCreateContext(display, config, None,
                                       (_i * 3)(EGL_CONTEXT_CLIENT_VERSION, 2, EGL_NONE))
        if not context:
            raise ContextError(f"EGL could not make an OpenGL ES 2 context (EGL error "
                               f"0x{egl.eglGetError():04x})")
        return display, context

    # -- the context ---------------------------------------------------------------------------

    def info(self):
        gl = self.gl
        out = {name: (gl.glGetString(enum) or b"").decode(errors="replace")
               for name, enum in (("GL_VENDOR", VENDOR), ("GL_RENDERER", RENDERER),
                                  ("GL_VERSION", VERSION),
                                  ("GL_SHADING_LANGUAGE_VERSION", SHADING_LANGUAGE_VERSION))}
        for name, enum in INTEGERS.items():
            value = _i()
            gl.glGetIntegerv(enum, ctypes.byref(value))
            out[name] = value.value
        span = (_f * 2)()
        gl.glGetFloatv(ALIASED_POINT_SIZE_RANGE, span)
        out["GL_POINT_SIZE_RANGE"] = (span[0], span[1])  # ES has only the aliased range
        self.error()  # a query this ES lacks leaves its error behind: not the caller's
        return out

    def extensions(self):
        return set((self.gl.glGetString(EXTENSIONS) or b"").decode().split())

    def error(self):
        code = self.gl.glGetError()
        return ERRORS.get(code, f"GL error 0x{code:04x}")

    def shader_precision(self):
        """glGetShaderPrecisionFormat (ES 2.0 core): as GLDevice.shader_precision."""
        table = {}
        for shader, shader_enum in (("vertex", VERTEX_SHADER), ("fragment", FRAGMENT_SHADER)):
            table[shader] = {}
            for i, name in enumerate(PRECISIONS):
                span, bits = (_i * 2)(), _i()
                self.gl.glGetShaderPrecisionFormat(shader_enum, 0x8DF0 + i, span,
                                                   ctypes.byref(bits))
                table[shader][name] = (span[0], span[1], bits.value)
        if self.error() != "GL_NO_ERROR" or not any(any(v) for v in table["fragment"].values()):
            return None
        return table

    def make_current(self):
        # eglMakeCurrent acts on the thread's current API, which moderngl's EGL leaves on desktop
        # OpenGL whenever it makes a context
        self.egl.eglBindAPI(EGL_OPENGL_ES_API)
        if not self.egl.eglMakeCurrent(self.display, None, None, self.context):
            raise ContextError(f"eglMakeCurrent failed (EGL error 0x{self.egl.eglGetError():04x})")

    def flush(self):
        self.gl.glFlush()

    def finish(self):
        self.gl.glFinish()

    def screen(self):
        raise ContextError("this context has no window to draw on (it is headless)")

    def close(self):
        for framebuffer in self._read_framebuffers.values():
            self.gl.glDeleteFramebuffers(1, ctypes.byref(_u(framebuffer)))
        self._read_framebuffers = {}
        self.egl.eglBindAPI(EGL_OPENGL_ES_API)  # release the ES context, not another API's
        self.egl.eglMakeCurrent(self.display, None, None, None)
        self.egl.eglDestroyContext(self.display, self.context)
        self.context = None
        # not eglTerminate: the display is the process's, and moderngl's contexts share it

    # -- objects -------------------------------------------------------------------------------

    def _gen(self, call):
        name = _u()
        call(1, ctypes.byref(name))
        return name.value

    def texture(self, size, components, dtype, data=None, linear=False):
        gl = self.gl
        internal, fmt, kind = self._formats[components, dtype]
        tex = Handle(self, "texture", self._gen(gl.glGenTextures), size=tuple(size),
                     components=components, dtype=dtype, upload=(fmt, kind))
        gl.glBindTexture(TEXTURE_2D, tex.name)
        mode = LINEAR if linear else NEAREST
        for parameter, value in ((TEXTURE_MIN_FILTER, mode), (TEXTURE_MAG_FILTER, mode),
                                 (TEXTURE_WRAP_S, CLAMP_TO_EDGE), (TEXTURE_WRAP_T, CLAMP_TO_EDGE)):
            gl.glTexParameteri(TEXTURE_2D, parameter, value)
        gl.glTexImage2D(TEXTURE_2D, 0, internal, size[0], size[1], 0, fmt, kind,
                        _pointer(data, self._nbytes(tex)))
        return tex

    def _nbytes(self, tex):
        return tex.size[0] * tex.size[1] * tex.components * int(tex.dtype[1])

    def compressed_texture(self, compressed):
        gl, c = self.gl, compressed
        tex = Handle(self, "texture", self._gen(gl.glGenTextures), size=(c.width, c.height),
                     components=4, dtype="f1", upload=None)
        gl.glBindTexture(TEXTURE_2D, tex.name)
        for parameter, value in ((TEXTURE_MIN_FILTER, NEAREST), (TEXTURE_MAG_FILTER, NEAREST),
                                 (TEXTURE_WRAP_S, CLAMP_TO_EDGE), (TEXTURE_WRAP_T, CLAMP_TO_EDGE)):
            gl.glTexParameteri(TEXTURE_2D, parameter, value)
        gl.glCompressedTexImage2D(TEXTURE_2D, 0, c.internal_format, c.width, c.height, 0,
                                  c.nbytes, c.data)
        return tex, self.error()

    def depth_buffer(self, size, texture=False):
        """A depth renderbuffer, or a depth texture (ES 3, or ES 2's OES_depth_texture): 24 bits
        where the context has them (ES 3, OES_depth24), as moderngl's; else 16."""
        gl = self.gl
        if texture:
            depth = Handle(self, "depth buffer", self._gen(gl.glGenTextures), size=tuple(size),
                           texture=True, components=1, dtype="f4")
            gl.glBindTexture(TEXTURE_2D, depth.name)
            for parameter in (TEXTURE_MIN_FILTER, TEXTURE_MAG_FILTER):
                gl.glTexParameteri(TEXTURE_2D, parameter, NEAREST)
            for parameter in (TEXTURE_WRAP_S, TEXTURE_WRAP_T):
                gl.glTexParameteri(TEXTURE_2D, parameter, CLAMP_TO_EDGE)
            gl.glTexImage2D(TEXTURE_2D, 0, DEPTH_COMPONENT24 if self.es3 else DEPTH_COMPONENT,
                            size[0], size[1], 0, DEPTH_COMPONENT, UNSIGNED_INT, None)
            return depth
        depth = Handle(self, "depth buffer", self._gen(gl.glGenRenderbuffers), size=tuple(size),
                       texture=False)
        gl.glBindRenderbuffer(RENDERBUFFER, depth.name)
        bits24 = self.es3 or "GL_OES_depth24" in self.extensions()
        gl.glRenderbufferStorage(RENDERBUFFER, DEPTH_COMPONENT24 if bits24 else DEPTH_COMPONENT16,
                                 size[0], size[1])
        return depth

    def framebuffer(self, colour, depth=None):
        gl = self.gl
        fbo = Handle(self, "framebuffer", self._gen(gl.glGenFramebuffers), size=colour.size,
                     depth=depth)
        gl.glBindFramebuffer(FRAMEBUFFER, fbo.name)
        gl.glFramebufferTexture2D(FRAMEBUFFER, COLOR_ATTACHMENT0, TEXTURE_2D, colour.name, 0)
        if depth is not None and depth.texture:
            gl.glFramebufferTexture2D(FRAMEBUFFER, DEPTH_ATTACHMENT, TEXTURE_2D, depth.name, 0)
        elif depth is not None:
            gl.glFramebufferRenderbuffer(FRAMEBUFFER, DEPTH_ATTACHMENT, RENDERBUFFER, depth.name)
        status = gl.glCheckFramebufferStatus(FRAMEBUFFER)
        gl.glBindFramebuffer(FRAMEBUFFER, 0)
        if status != FRAMEBUFFER_COMPLETE:
            gl.glDeleteFramebuffers(1, ctypes.byref(_u(fbo.name)))
            raise ContextError(f"a framebuffer of this texture is not complete (status "
                               f"0x{status:04x}): the format cannot be rendered to here")
        return fbo

    def buffer(self, data):
        data = bytes(data)
        buf = Handle(self, "buffer", self._gen(self.gl.glGenBuffers), nbytes=len(data))
        self.gl.glBindBuffer(ARRAY_BUFFER, buf.name)
        self.gl.glBufferData(ARRAY_BUFFER, len(data), data, STATIC_DRAW)
        self.gl.glBindBuffer(ARRAY_BUFFER, 0)
        return buf

    def program(self, vertex, fragment):
        """Compile and link; a failure raises ProgramError in the words moderngl uses (the
        stage, then the driver's log), which the shader module turns into file and line."""
        gl = self.gl
        with signals_held():  # see there: a compile is not to be cut by a signal
            shaders = []
            try:
                for kind, label, text in ((VERTEX_SHADER, "vertex_shader", vertex),
                                          (FRAGMENT_SHADER, "fragment_shader", fragment)):
                    shader = gl.glCreateShader(kind)
                    shaders.append(shader)
                    source = ctypes.c_char_p(text.encode())
                    gl.glShaderSource(shader, 1, ctypes.byref(source), None)
                    gl.glCompileShader(shader)
                    if not _status(gl.glGetShaderiv, shader, COMPILE_STATUS):
                        log = _log(gl.glGetShaderiv, gl.glGetShaderInfoLog, shader)
                        raise ProgramError(f"GLSL Compiler failed\n\n{label}\n=\n{log}")
                name = gl.glCreateProgram()
                for shader in shaders:
                    gl.glAttachShader(name, shader)
                gl.glLinkProgram(name)
                if not _status(gl.glGetProgramiv, name, LINK_STATUS):
                    log = _log(gl.glGetProgramiv, gl.glGetProgramInfoLog, name)
                    gl.glDeleteProgram(name)
                    raise ProgramError(f"GLSL Linker failed\n\n{log}")
            finally:
                for shader in shaders:
                    gl.glDeleteShader(shader)  # kept by the program until it goes
        return Handle(self, "program", name, uniforms=self._actives(name, gl.glGetActiveUniform,
                                                                ACTIVE_UNIFORMS),
                      attributes=self._actives(name, gl.glGetActiveAttrib, ACTIVE_ATTRIBUTES))

    def _actives(self, program, call, which):
        """name -> (location, GL type, array length) of a linked program's active uniforms
        or attributes ("u_x[0]" named u_x)."""
        gl = self.gl
        locate = gl.glGetUniformLocation if which == ACTIVE_UNIFORMS else gl.glGetAttribLocation
        count, out = _i(), {}
        gl.glGetProgramiv(program, which, ctypes.byref(count))
        for index in range(count.value):
            text, length, size, kind = ctypes.create_string_buffer(256), _i(), _i(), _u()
            call(program, index, 256, ctypes.byref(length), ctypes.byref(size),
                 ctypes.byref(kind), text)
            name = text.value.decode()
            if name.startswith("gl_"):
                continue
            out[name.removesuffix("[0]")] = (locate(program, text.value), kind.value, size.value)
        return out

    def uniforms(self, program):
        return {name: ActiveUniform(kind == SAMPLER_2D, size)
                for name, (_, kind, size) in program.uniforms.items()}

    def set_uniform(self, program, name, value):
        """Set a uniform; a value of the wrong shape or kind raises ValueError, as moderngl's
        packing does (the draw command says it in one line), rather than setting part of it or
        leaving a GL error behind."""
        location, kind, length = program.uniforms[name]
        family, width = UNIFORM_TYPES[kind]
        per = width * width if family == "m" else width
        values = np.asarray(value, dtype=np.float64).ravel()
        count = values.size // per
        if values.size % per or not 1 <= count <= length:
            raise ValueError(f"{values.size} number(s) do not fill {length} element(s) of "
                             f"{per}")
        if family == "i" and not np.array_equal(values, np.round(values)):
            raise ValueError(f"an int uniform takes whole numbers, got {value!r}")
        self.gl.glUseProgram(program.name)
        if family == "i":
            data = np.ascontiguousarray(values, dtype=np.int32)
            getattr(self.gl, f"glUniform{width}iv")(location, count, data.ctypes.data)
        elif family == "f":
            data = np.ascontiguousarray(values, dtype=np.float32)
            getattr(self.gl, f"glUniform{width}fv")(location, count, data.ctypes.data)
        else:  # column-major, as moderngl takes a matrix (ES 2.0 allows no transpose)
            data = np.ascontiguousarray(values, dtype=np.float32)
            getattr(self.gl, f"glUniformMatrix{width}fv")(location, count, 0, data.ctypes.data)

    def vertex_array(self, program, content, indices=None):
        """The attribute bindings of ``content`` (moderngl's form: buffer, "2f 4f1 3x4",
        names...), set at each draw (ES 2.0 has no vertex array objects); attributes the
        program does not use are skipped, as padding."""
        if indices is not None and not self.es3 and \
                "GL_OES_element_index_uint" not in self.extensions():
            raise CapabilityError("32-bit vertex indices need OpenGL ES 3 or "
                                  "OES_element_index_uint, which this ES 2.0 context lacks")
        bindings, vertices = [], None
        for buffer, layout, *names in content:
            items = [_FORMAT_ITEM.match(item) for item in layout.split()]
            if None in items:
                raise ContextError(f"vertex format {layout!r} is not one this device reads "
                                   "(floats 'Nf', normalised bytes 'Nf1', padding 'Nx4')")
            stride = sum(int(m.group(1) or 1) * _item_bytes(m) for m in items)
            offset, named = 0, iter(names)
            for match in items:
                count, kind, size = int(match.group(1) or 1), match.group(2), _item_bytes(match)
                if kind != "x":
                    name = next(named)
                    if name in program.attributes:
                        gl_type, normalised = (UNSIGNED_BYTE, 1) if size == 1 else (FLOAT, 0)
                        bindings.append((buffer, program.attributes[name][0], count, gl_type,
                                         normalised, stride, offset))
                offset += count * size
            vertices = buffer.nbytes // stride if vertices is None else \
                min(vertices, buffer.nbytes // stride)
        return Handle(self, "vertex array", 0, program=program, bindings=bindings, indices=indices,
                      vertices=indices.nbytes // 4 if indices is not None else vertices or 0)

    def release(self, obj):
        gl, name = self.gl, ctypes.byref(_u(obj.name))
        if obj.kind == "texture" or (obj.kind == "depth buffer" and obj.texture):
            framebuffer = self._read_framebuffers.pop(obj.name, None)
            if framebuffer is not None:
                gl.glDeleteFramebuffers(1, ctypes.byref(_u(framebuffer)))
            gl.glDeleteTextures(1, name)
        elif obj.kind == "depth buffer":
            gl.glDeleteRenderbuffers(1, name)
        elif obj.kind == "framebuffer":
            gl.glDeleteFramebuffers(1, name)
        elif obj.kind == "buffer":
            gl.glDeleteBuffers(1, name)
        elif obj.kind == "program":
            gl.glDeleteProgram(obj.name)

    # -- work ------------------------------------------------------------------------------------

    def _target(self, framebuffer):
        self.gl.glBindFramebuffer(FRAMEBUFFER, framebuffer.name)
        self.gl.glViewport(0, 0, *framebuffer.size)

    def clear(self, framebuffer, colour, depth=None):
        """As moderngl's clear: the colour, and the depth (to 1 unless given) where the
        framebuffer has a depth buffer."""
        gl = self.gl
        self._target(framebuffer)
        gl.glColorMask(1, 1, 1, 1)
        gl.glDepthMask(1)
        gl.glClearColor(*colour)
        bits = COLOR_BUFFER_BIT
        if framebuffer.depth is not None:
            gl.glClearDepthf(1.0 if depth is None else depth)
            bits |= DEPTH_BUFFER_BIT
        gl.glClear(bits)

    def read(self, texture, components=None):
        """A texture's bytes, bottom row first: read through a framebuffer of it as RGBA
        (UNSIGNED_BYTE, or FLOAT for the float formats: the reads ES guarantees), then cut to
        the texture's own type and ``components``."""
        gl = self.gl
        if texture.name not in self._read_framebuffers:
            fbo = self._gen(gl.glGenFramebuffers)
            gl.glBindFramebuffer(FRAMEBUFFER, fbo)
            gl.glFramebufferTexture2D(FRAMEBUFFER, COLOR_ATTACHMENT0, TEXTURE_2D, texture.name, 0)
            self._read_framebuffers[texture.name] = fbo
        gl.glBindFramebuffer(FRAMEBUFFER, self._read_framebuffers[texture.name])
        status = gl.glCheckFramebufferStatus(FRAMEBUFFER)
        if status != FRAMEBUFFER_COMPLETE:
            raise CapabilityError(f"this {texture.kind} cannot be read back here: a framebuffer "
                                  f"of it is not complete (status 0x{status:04x})")
        w, h = texture.size
        byte = texture.dtype == "f1"
        out = np.empty((h, w, 4), np.uint8 if byte else np.float32)
        gl.glReadPixels(0, 0, w, h, RGBA, UNSIGNED_BYTE if byte else FLOAT, out.ctypes.data)
        error = self.error()
        if error != "GL_NO_ERROR":
            raise CapabilityError(f"glReadPixels of a {texture.dtype} texture failed with {error}")
        keep = texture.components if components is None else components
        out = out[:, :, :keep]
        if texture.dtype == "f2":
            out = out.astype(np.float16)
        return np.ascontiguousarray(out).tobytes()

    def write(self, obj, data):
        gl = self.gl
        if obj.kind == "buffer":  # into the buffer's store, as moderngl's write
            data = bytes(data)
            if len(data) > obj.nbytes:
                raise ContextError(f"{len(data)} bytes do not fit a buffer of {obj.nbytes}")
            gl.glBindBuffer(ARRAY_BUFFER, obj.name)
            gl.glBufferSubData(ARRAY_BUFFER, 0, len(data), data)
            gl.glBindBuffer(ARRAY_BUFFER, 0)
            return
        fmt, kind = obj.upload
        gl.glBindTexture(TEXTURE_2D, obj.name)
        gl.glTexSubImage2D(TEXTURE_2D, 0, 0, 0, obj.size[0], obj.size[1], fmt, kind,
                           _pointer(data, self._nbytes(obj)))

    def draw(self, vertex_array, framebuffer, textures, state, primitive, first=0, count=None,
             label=None):
        gl = self.gl
        for unit, texture in textures.items():
            gl.glActiveTexture(TEXTURE0 + unit)
            gl.glBindTexture(TEXTURE_2D, texture.name)
        gl.glActiveTexture(TEXTURE0)
        va = vertex_array
        mode = POINTS if primitive == "points" else TRIANGLES
        count = va.vertices - first if count is None else count
        with self.scope(framebuffer, state):
            gl.glUseProgram(va.program.name)
            for buffer, location, size, kind, normalised, stride, offset in va.bindings:
                gl.glBindBuffer(ARRAY_BUFFER, buffer.name)
                gl.glEnableVertexAttribArray(location)
                gl.glVertexAttribPointer(location, size, kind, normalised, stride, offset)
            gl.glBindBuffer(ARRAY_BUFFER, 0)
            try:
                if va.indices is not None:
                    gl.glBindBuffer(ELEMENT_ARRAY_BUFFER, va.indices.name)
                    gl.glDrawElements(mode, count, UNSIGNED_INT, int(first) * 4)
                    gl.glBindBuffer(ELEMENT_ARRAY_BUFFER, 0)
                else:
                    gl.glDrawArrays(mode, first, count)
            finally:
                for binding in va.bindings:
                    gl.glDisableVertexAttribArray(binding[1])

    def scope(self, framebuffer, state):
        """``state`` for one draw (see GLDevice.scope); every point is a sprite sized by its
        shader in ES, so those two flags ask for nothing."""
        return _Scope(self.gl, self._target, framebuffer, state)


class _Scope:
    def __init__(self, gl, target, framebuffer, state):
        self.gl, self.target, self.framebuffer, self.state = gl, target, framebuffer, state

    def __enter__(self):
        gl, state = self.gl, self.state
        self.target(self.framebuffer)
        gl.glDepthMask(1 if state.depth_write else 0)
        if not state.colour_write:
            gl.glColorMask(0, 0, 0, 0)
        if state.blend is not None:
            gl.glEnable(BLEND)
            gl.glBlendFunc(*BLEND_FUNCTIONS[state.blend])
        if state.depth_test:
            gl.glEnable(DEPTH_TEST)

    def __exit__(self, *exc):
        gl = self.gl
        gl.glDepthMask(1)
        gl.glColorMask(1, 1, 1, 1)
        gl.glDisable(BLEND)
        gl.glDisable(DEPTH_TEST)


def _texture_formats(es3):
    """(components, moderngl dtype) -> (internal format, format, type)."""
    if es3:
        return {(4, "f1"): (RGBA8, RGBA, UNSIGNED_BYTE), (4, "f2"): (RGBA16F, RGBA, HALF_FLOAT),
                (4, "f4"): (RGBA32F, RGBA, FLOAT), (1, "f4"): (R32F, RED, FLOAT)}
    return {(4, "f1"): (RGBA, RGBA, UNSIGNED_BYTE), (4, "f2"): (RGBA, RGBA, HALF_FLOAT_OES),
            (4, "f4"): (RGBA, RGBA, FLOAT), (1, "f4"): (RED, RED, FLOAT)}  # RED: EXT_texture_rg


def _item_bytes(match):
    """Bytes of one component of a vertex format item ("f": 4, "f1": 1, "x": 1, "x4": 4)."""
    return int(match.group(3) or (4 if match.group(2) == "f" else 1))


def _pointer(data, nbytes):
    """``data`` (bytes-like, or None) as a pointer for an upload of ``nbytes``."""
    if data is None:
        return None
    data = bytes(data)
    if len(data) != nbytes:
        raise ContextError(f"texture data is {len(data)} bytes; the texture holds {nbytes}")
    return data


def _proc(egl, name, result, *arguments):
    address = egl.eglGetProcAddress(name.encode())
    return ctypes.CFUNCTYPE(result, *arguments)(address) if address else None


def _status(query, name, which):
    value = _i()
    query(name, which, ctypes.byref(value))
    return value.value


def _log(query, read, name):
    size = max(1, _status(query, name, INFO_LOG_LENGTH))
    text = ctypes.create_string_buffer(size)
    read(name, size, None, text)
    return text.value.decode(errors="replace")
