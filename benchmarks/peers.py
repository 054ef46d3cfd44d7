"""The peers the benchmark times on the same jobs: a numpy float32 pipeline for each scene, and
datashader (with numba) for de Jong, which is what a Python user would pick for attractor images.

``numpy_dejong_image`` is also run as a script (``python benchmarks/peers.py out.png``): the numpy +
pillow way to make the article's picture, timed against the ``es2particles run`` command.
"""

import io
import sys

import numpy as np
from PIL import Image

from es2particles.ramps import load_ramp
from es2particles.scenes.dejong import ARTICLE_COEFFICIENTS, dejong_map

SIZE = (1024, 1024)


def png_bytes(image):
    """PNG bytes with pillow's defaults (level 6): what a numpy + pillow user gets."""
    buffer = io.BytesIO()
    Image.fromarray(image).save(buffer, format="PNG")
    return buffer.getvalue()


class NumpyFrame:
    """A frame in numpy float32: positions (N, 2) in [-2, 2]^2 -> bincount density -> log tone
    curve -> inferno ramp -> half-resolution Gaussian bloom -> uint8 image."""

    def __init__(self, size=SIZE, extent=2.0):
        self.size, self.extent = size, extent
        self.ramp = load_ramp("inferno")[:, :3]
        kernel = np.exp(-0.5 * (np.arange(-12, 13) / 3.0) ** 2).astype(np.float32)
        self.kernel = kernel / kernel.sum()

    def density(self, p):
        w, h = self.size
        ij = ((p + self.extent) * np.float32(w / (2 * self.extent))).astype(np.int32).clip(0, w - 1)
        self.counts = np.bincount(ij[:, 1] * w + ij[:, 0], minlength=w * h).reshape(h, w)
        self.count = len(p)

    def post(self):
        mean = self.count / self.counts.size
        t = np.log1p(np.float32(4) * self.counts / mean) / np.log1p(np.float32(4 * 256))
        image = self.ramp[(np.clip(t, 0, 1) * 255).astype(np.uint8)].astype(np.float32) / 255
        h, w = self.counts.shape
        half = image.reshape(h // 2, 2, w // 2, 2, 3).mean(axis=(1, 3))
        bright = half * (half.mean(axis=2, keepdims=True) > 0.6)
        blur = np.apply_along_axis(np.convolve, 0, bright, self.kernel, "same")
        blur = np.apply_along_axis(np.convolve, 1, blur, self.kernel, "same")
        glow = blur.repeat(2, axis=0).repeat(2, axis=1)
        self.image = (np.minimum(image + 0.8 * glow, 1) * 255).astype(np.uint8)[::-1]
        return self.image


class NumpyDeJong:
    def __init__(self, count, seed=0):
        self.p = np.random.default_rng(seed).uniform(-2, 2, (count, 2)).astype(np.float32)
        self.k = tuple(np.float32(c) for c in ARTICLE_COEFFICIENTS)
        self.frame = NumpyFrame()

    def step(self):
        self.p = dejong_map(self.p, self.k, 3).astype(np.float32)


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

    def render():
        state["agg"] = canvas.points(pd.DataFrame({"x": x, "y": y}, copy=False), "x", "y")

    def post():
        state["img"] = tf.shade(state["agg"], cmap=colours, how="log")

    def encode():
        return png_bytes(np.asarray(state["img"].to_pil().convert("RGB")))

    step()  # compile
    return step, render, post, encode


def numpy_dejong_image(path, count=2 ** 20, steps=20):
    """The article's picture with numpy and pillow alone."""
    job = NumpyDeJong(count)
    for _ in range(steps):
        job.step()
    job.frame.density(job.p)
    Image.fromarray(job.frame.post()).save(path)


if __name__ == "__main__":
    numpy_dejong_image(sys.argv[1])
