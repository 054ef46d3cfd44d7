"""The density's post stage, as a stage of the frame plan: the tone map with its gradient map,
which turns a density texture into a picture (a log curve of density, then a colour ramp,
``io/ramps.py``, or grey). It is optional: switched off, it makes no texture and never runs,
and the plan says it was left out. Bloom and the gradient map over any other picture, which
every rendering's picture takes, are the frame's (``frame/bloom.py``, ``frame/gradient.py``).
"""

import numpy as np

from ..frame.bloom import stage
from ..frame.gradient import ramp_resource
from ..frame.plan import Ref, Resource
from ..frame.settings import setting


def colouring(b, gradient, background, what="the scene's objects, under the particles"):
    """The gradient map (a ramp, or None: grey) and the scene's background image as resources
    of plan builder ``b``: (defines, inputs) of a stage that colours with them (GRADIENT and
    u_ramp, BACKGROUND and u_background)."""
    defines, inputs = ramp_resource(b, gradient)
    if gradient is None:
        b.left_out.append("gradient map (switched off: grey)")
    if background is not None:
        bh, bw = background.shape[:2]
        b.resource(Resource("background", "image", (bw, bh), "rgba8", linear=True,
                            data=np.ascontiguousarray(background, np.uint8),
                            what=what))
        defines["BACKGROUND"], inputs["u_background"] = None, Ref("background")
    return defines, inputs


def plan_post(b, source, mean_density, exposure, gradient="inferno", background=None,
              hue=None):
    """Add the tone map to plan builder ``b``, reading the density in resource ``source``: a
    log curve relative to ``mean_density``, the density of an evenly covered pixel; with the
    gradient map where ``gradient`` is a ramp, grey where None; over the ``background`` image
    of the scene's objects where one is given. Returns the name of its target: the picture.
    ``hue``: the quantity whose mean over a pixel's points (the density's second channel over
    its first) picks the colour along the gradient map, the log curve its brightness (None: the
    curve picks the colour)."""
    exposure = setting("exposure", exposure)
    w, h = b.resources[source].size
    defines, inputs = colouring(b, gradient, background)
    inputs["u_density"] = Ref(source)
    ramp = "GRADIENT" in defines
    if hue is not None:
        defines["HUE"] = None

    ramp_words = f"gradient map {gradient!r}" if ramp else "grey"
    if hue is not None and ramp:
        ramp_words += f" by the points' mean |{hue}|"
    return stage(b, "tone map", "post/tonemap.frag", (w, h),
                 {"u_mean": float(max(mean_density, 1e-12)), "u_exposure": exposure}, inputs,
                 defines, f"log curve, exposure {exposure:g}, {ramp_words}"
                 + (", over the scene's objects" if background is not None else ""))
