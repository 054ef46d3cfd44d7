"""Post stages, as stages of the frame plan: the density's tone map with its gradient map, which
turns a density texture into a picture, and bloom, which any rendering's picture takes. Each is
optional: a switched-off stage makes no texture and never runs, and the plan says it was left
out.

- Tone map (+ gradient map): log curve of density, then a colour ramp (``ramps.py``) or grey.
- Bloom (:func:`plan_bloom`): bright pass at half resolution, separable Gaussian blur at 1/2 and
  1/4 resolution, composite onto the picture.
"""

import numpy as np

from ..frame.plan import Ref, Resource, Stage
from ..frame.settings import Bloom, setting  # noqa: F401 - Bloom: the value plan_bloom takes
from .ramps import load_ramp


def blur_taps(sigma, taps=12):
    """(centre weight, [(offset, weight)] * taps/2) of a normalised Gaussian of ``taps`` texels
    each side, with neighbouring taps paired into one linearly filtered fetch (numpy twin of
    what ``post/blur.frag`` sums)."""
    x = np.arange(taps + 1, dtype=np.float64)
    w = np.exp(-0.5 * x ** 2 / sigma ** 2)
    w /= w[0] + 2 * w[1:].sum()
    pairs = []
    for i in range(1, taps + 1, 2):
        weight = w[i] + w[i + 1]
        pairs.append((float((i * w[i] + (i + 1) * w[i + 1]) / weight), float(weight)))
    return float(w[0]), pairs


def colouring(b, gradient, background, what="the scene's objects, under the particles"):
    """The gradient map (a ramp, or None: grey) and the scene's background image as resources
    of plan builder ``b``: (defines, inputs) of a stage that colours with them (GRADIENT and
    u_ramp, BACKGROUND and u_background)."""
    ramp = load_ramp(gradient) if gradient is not None else None  # bad ramps fail before GL
    defines, inputs = {}, {}
    if ramp is not None:
        b.resource(Resource("ramp", "image", (256, 1), "rgba8", linear=True,
                            data=np.asarray(ramp, np.uint8).reshape(1, 256, 4),
                            what=f"gradient map {gradient!r}"))
        defines["GRADIENT"], inputs["u_ramp"] = None, Ref("ramp")
    else:
        b.left_out.append("gradient map (switched off: grey)")
    if background is not None:
        bh, bw = background.shape[:2]
        b.resource(Resource("background", "image", (bw, bh), "rgba8", linear=True,
                            data=np.ascontiguousarray(background, np.uint8),
                            what=what))
        defines["BACKGROUND"], inputs["u_background"] = None, Ref("background")
    return defines, inputs


def stage(b, name, frag, size, uniforms, inputs, defines=None, what=""):
    """A post stage of plan builder ``b`` into an RGBA8 target of its own, ``name``, of
    ``size``; returns the name."""
    b.resource(Resource(name, "target", size, "rgba8", linear=True))
    b.stage(Stage(name, "post", frag, defines=defines or {}, inputs=inputs, target=Ref(name),
                  uniforms=uniforms, what=what))
    return name


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


def plan_bloom(b, source, bloom):
    """Add bloom to plan builder ``b`` over the picture in resource ``source`` (any rendering's,
    RGBA8): its bright, blur x and blur y at 1/2 and 1/4 size and its composite, where ``bloom``
    (a :class:`Bloom`) is not None. Returns the name of the picture then."""
    if bloom is None:
        b.left_out.append("bloom (switched off)")
        return source
    w, h = b.resources[source].size
    blurred = []
    for div in (2, 4):
        level = (max(1, w // div), max(1, h // div))
        # Sigma is in texels of each level, so the quarter level glows twice as wide.
        centre, pairs = blur_taps(bloom.radius)
        names = [f"bloom {what} 1/{div}" for what in ("bright", "blur x", "blur y")]
        stage(b, names[0], "post/bright.frag", level, {"u_threshold": bloom.threshold},
              {"u_source": Ref(source)}, what=f"threshold {bloom.threshold:g}")
        stage(b, names[1], "post/blur.frag", level,
              {"u_direction": (1 / level[0], 0.0), "u_centre": centre, "u_taps": pairs},
              {"u_source": Ref(names[0])}, what=f"sigma {bloom.radius:g}")
        stage(b, names[2], "post/blur.frag", level,
              {"u_direction": (0.0, 1 / level[1]), "u_centre": centre, "u_taps": pairs},
              {"u_source": Ref(names[1])}, what=f"sigma {bloom.radius:g}")
        blurred.append(names[2])
    return stage(b, "bloom composite", "post/composite.frag", (w, h),
                 {"u_intensity": bloom.intensity / 2},
                 {"u_source": Ref(source), "u_bloom0": Ref(blurred[0]),
                  "u_bloom1": Ref(blurred[1])}, what=f"intensity {bloom.intensity:g}")
