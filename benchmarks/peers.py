"""The peers the benchmark times on the same jobs: a numpy float32 pipeline for each scene, and
datashader (with numba) for de Jong, which is what a Python user would pick for attractor images.

The numpy peer lives in ``numpy_dejong.py``, which imports numpy and pillow alone: it is also the
script timed against the whole ``es2particles run`` command.
"""

import io

import numpy as np
from PIL import Image

from es2particles.io.ramps import load_ramp
from es2particles.scenes.dejong import ARTICLE_COEFFICIENTS
from numpy_dejong import SIZE, NumpyDeJong, NumpyFrame  # noqa: F401 (the bench imports them)

# The peer script carries its own copy of the ramp's stops: it must match ours.
assert np.array_equal(NumpyFrame().ramp, load_ramp("inferno")[:, :3]), "numpy_dejong.INFERNO"


def png_bytes(image):
    """PNG bytes with pillow's defaults (level 6): what a numpy + pillow user gets."""
    buffer = io.BytesIO()
    Image.fromarray(image).save(buffer, format="PNG")
    return buffer.getvalue()


def datashader_counts(count, view, size=SIZE, seed=0):
    """(step, counts) callables of a datashader + numba job for the accumulation table, or None
    if not installed: ``count`` random points in [-2, 2]^2, ``step()`` three iterations of the
    map, ``counts()`` the (h, w) float64 count of points on each pixel of ``view`` (row 0 at the
    bottom, as our density)."""
    try:
        import datashader as ds
        import numba  # noqa: F401
        import pandas as pd
    except ImportError:
        return None
    step, _, _, _ = datashader_dejong(count, seed)  # compiled, and its arrays
    x, y = step.x, step.y
    x0, y0, x1, y1 = view
    canvas = ds.Canvas(plot_width=size[0], plot_height=size[1], x_range=(x0, x1), y_range=(y0, y1))
    frame = pd.DataFrame({"x": x, "y": y}, copy=False)

    def counts():
        return np.asarray(canvas.points(frame, "x", "y", agg=ds.count()).values, np.float64)

    return step, counts


def datashader_dejong(count, seed=0):
    """(step, render, post, encode) callables for datashader + numba, or None if not installed."""
    try:
        import datashader as ds
        import datashader.transfer_functions as tf
        import numba
        import pandas as pd
    except ImportError:
        return None

    @numba.njit(parallel=True, fastmath=False)
    def step_numba(x, y, a, b, c, d):
        for i in numba.prange(x.shape[0]):
            xi, yi = x[i], y[i]
            for _ in range(3):
                xi, yi = np.sin(a * yi) - np.cos(b * xi), np.sin(c * xi) - np.cos(d * yi)
            x[i], y[i] = xi, yi

    rng = np.random.default_rng(seed)
    x = rng.uniform(-2, 2, count).astype(np.float32)
    y = rng.uniform(-2, 2, count).astype(np.float32)
    coefficients = tuple(np.float32(k) for k in ARTICLE_COEFFICIENTS)
    canvas = ds.Canvas(plot_width=SIZE[0], plot_height=SIZE[1], x_range=(-2, 2), y_range=(-2, 2))
    colours = ["#" + "".join(f"{v:02x}" for v in rgb) for rgb in load_ramp("inferno")[:, :3]]
    state = {}

    def step():
        step_numba(x, y, *coefficients)
    step.x, step.y = x, y  # the arrays it moves in place

    def render():
        state["agg"] = canvas.points(pd.DataFrame({"x": x, "y": y}, copy=False), "x", "y")

    def post():
        state["img"] = tf.shade(state["agg"], cmap=colours, how="log")

    def encode():
        return png_bytes(np.asarray(state["img"].to_pil().convert("RGB")))

    step()  # compile
    return step, render, post, encode
