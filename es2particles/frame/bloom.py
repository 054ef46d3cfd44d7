"""Bloom, the post stage the frame puts over any rendering's picture (``plan.plan_picture``):
a bright pass at 1/2 and 1/4 of the resolution, each blurred by a separable Gaussian (its taps
paired into linearly filtered fetches), and a composite onto the picture. Here in the frame's
layer, beside the trails, so the planner reaches it; ``render/post.py`` re-exports it with the
density's tone map."""

import numpy as np

from .parts import Ref, Resource, Stage


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


def stage(b, name, frag, size, uniforms, inputs, defines=None, what=""):
    """A post stage of plan builder ``b`` into an RGBA8 target of its own, ``name``, of
    ``size``; returns the name."""
    b.resource(Resource(name, "target", size, "rgba8", linear=True))
    b.stage(Stage(name, "post", frag, defines=defines or {}, inputs=inputs, target=Ref(name),
                  uniforms=uniforms, what=what))
    return name


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
