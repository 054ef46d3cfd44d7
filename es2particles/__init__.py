"""es2particles: GPU particle systems in the OpenGL ES 2.0 style.

Particle state lives in textures (16-bit values packed into RGBA8 by default); a simulation step is
a graph of full-screen fragment passes; everything runs headless through an EGL context.

>>> from es2particles import open_context, PassGraph, Simulation
"""

from .context import Capabilities, Context, open_context
from .errors import (CapabilityError, ContextError, Es2ParticlesError, GraphError, ParameterError,
                     ShaderError)
from .graph import Pass, PassGraph, Plan
from .pipeline import Pipeline
from .simulation import Simulation
from .state import Layout, Quantity

__version__ = "0.1.0"
__all__ = [
    "Capabilities", "CapabilityError", "Context", "ContextError", "Es2ParticlesError",
    "GraphError", "Layout", "ParameterError", "Pass", "PassGraph", "Pipeline", "Plan", "Quantity",
    "ShaderError", "Simulation", "open_context",
]
