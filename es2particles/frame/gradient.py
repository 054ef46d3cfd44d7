"""The gradient map: a colour ramp (``io/ramps.py``) as a 256 x 1 resource of the frame, which
a density's tone map and a field's colouring read (``render/post.py``, ``render/field.py``), and
the post stage that recolours any other rendering's picture along it by each pixel's
brightness (``post/gradient.frag``; ``lib/ramp.glsl`` is the lookup these and the flame's
march share)."""

import numpy as np

from ..io.ramps import load_ramp
from .bloom import stage
from .parts import Ref, Resource


def ramp_resource(b, gradient):
    """The ramp ``gradient`` as resource "ramp" of plan builder ``b``: (defines, inputs) of a
    stage that colours with it (GRADIENT, u_ramp); None: ({}, {}), no ramp. A bad ramp fails
    here, before GL."""
    if gradient is None:
        return {}, {}
    ramp = load_ramp(gradient)
    b.resource(Resource("ramp", "image", (256, 1), "rgba8", linear=True,
                        data=np.asarray(ramp, np.uint8).reshape(1, 256, 4),
                        what=f"gradient map {gradient!r}"))
    return {"GRADIENT": None}, {"u_ramp": Ref("ramp")}


def plan_gradient_map(b, source, gradient):
    """Add the gradient map over the picture in resource ``source`` to plan builder ``b``: each
    pixel's Rec. 709 luma picks its colour along the ramp ``gradient``; returns its target.
    None: the picture as drawn (the plan says the map was left out)."""
    if gradient is None:
        b.left_out.append("gradient map (off: the picture as drawn)")
        return source
    defines, inputs = ramp_resource(b, gradient)
    inputs["u_source"] = Ref(source)
    return stage(b, "gradient map", "post/gradient.frag", b.resources[source].size, {}, inputs,
                 defines, f"the picture's luma along gradient map {gradient!r}")
