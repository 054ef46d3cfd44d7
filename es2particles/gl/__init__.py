"""The GL edge: opening a headless context and probing it (``egl.py``), the context that owns
every GL object, the device beneath it (desktop GL through moderngl, OpenGL ES through EGL, or one
that records the calls), the one draw command every draw goes through, shader loading, the
generated interface of a stage, and ASTC texture compression. Nothing above this package calls
moderngl.

``BACKENDS`` names the GL APIs ``--backend`` chooses among (here, where choosing one imports no GL
module): desktop OpenGL, OpenGL ES, or the first that opens."""

BACKENDS = ("gl", "gles", "auto")
