"""es2particles: GPU particle systems in the OpenGL ES 2.0 style.

Particle state lives in textures (16-bit values packed into RGBA8 by default); a simulation step is
a graph of full-screen fragment passes; everything runs headless through an EGL context.

>>> from es2particles import open_context, PassGraph, Simulation
"""

import importlib

# name -> module: imported when first asked for, so `import es2particles.cli` (the program) does
# not import numpy and the GL binding before it has parsed its command line.
_EXPORTS = {
    "Capabilities": "gl.context", "Context": "gl.context", "open_context": "gl.egl",
    "CapabilityError": "errors", "ContextError": "errors", "Es2ParticlesError": "errors",
    "GraphError": "errors", "ParameterError": "errors", "ShaderError": "errors",
    "Pass": "frame.graph", "PassGraph": "frame.graph", "Plan": "frame.graph",
    "Pipeline": "frame.pipeline", "Simulation": "frame.simulation", "Layout": "frame.state",
    "Quantity": "frame.state", "Defaults": "frame.settings", "FrameSettings": "frame.settings",
    "Bloom": "frame.settings",
    "Params": "params", "param": "params", "Scene": "scenes.base", "Fill": "scenes.base",
    "Emitter": "scenes.emitter", "EmitterParams": "scenes.emitter", "Camera": "render.camera",
    "Density": "render.points", "Sprites": "render.sprites", "Renderer": "frame.pipeline",
    "save_image": "io.output", "save_animation": "io.output",
}


def __getattr__(name):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)


def __dir__():
    return sorted(list(globals()) + list(_EXPORTS))


__version__ = "0.1.0"
# The subpackages and modules (what pdoc documents, and what `import *` brings); the names above
# are reached as attributes (`from es2particles import Pipeline`), each from its module.
__all__ = ["errors", "params", "twins", "io", "gl", "fields", "frame", "render", "scenes", "run",
           "live", "export", "cluster", "report", "cli"]
