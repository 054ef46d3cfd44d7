"""The GL edge: opening a headless context and probing it (``egl.py``), the context that owns
every GL object, the device beneath it (GL through moderngl, or one that records the calls), the
one draw command every draw goes through, shader loading, the generated interface of a stage, and
ASTC texture compression. Nothing above this package calls moderngl."""
