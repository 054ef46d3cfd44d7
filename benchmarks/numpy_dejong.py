"""The de Jong picture with numpy and pillow alone: what a Python user writes without us, and the
peer the benchmark times our whole ``es2particles run`` command against. It imports nothing of
es2particles (importing our package would add its start-up to the peer's), so the ramp's stops
and the map are written out here; ``peers.py`` checks that the ramp is the same as ours.

Run: ``python benchmarks/numpy_dejong.py out.png`` (the default picture: 2^20 random points, 20
steps of three iterations) or ``python benchmarks/numpy_dejong.py --reseed out.png`` (the
article's: the 1024 x 1024 grid of texel centres, three iterations; ``es2particles run dejong
--reseed --particles 1048576 --steps 1``).
"""

import sys

import numpy as np
from PIL import Image, ImageColor

SIZE = (1024, 1024)
ARTICLE = (1.4, -2.3, 2.4, -2.1)
INFERNO = ["#000004", "#320a5e", "#781b6c", "#bb3654", "#ec6824", "#fbb41a", "#fcffa4"]


def ramp(stops):
    """(256, 3) uint8: the stops spread evenly and interpolated linearly."""
    stops = np.array([ImageColor.getrgb(c) for c in stops], dtype=np.float64)
    t = np.linspace(0, 1, 256)
    rgb = [np.interp(t, np.linspace(0, 1, len(stops)), stops[:, k]) for k in range(3)]
    return np.round(np.stack(rgb, axis=1)).astype(np.uint8)


def dejong(p, k, iterations):
    a, b, c, d = k
    x, y = p[:, 0], p[:, 1]
    for _ in range(iterations):
        x, y = np.sin(a * y) - np.cos(b * x), np.sin(c * x) - np.cos(d * y)
    return np.stack([x, y], axis=1)


class NumpyFrame:
    """A frame in numpy float32: positions (N, 2) in [-extent, extent]^2 -> bincount density ->
    log tone curve -> inferno ramp -> half-resolution Gaussian bloom -> uint8 image."""

    def __init__(self, size=SIZE, extent=2.0):
        self.size, self.extent = size, extent
        self.ramp = ramp(INFERNO)
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
    """The stateful job: ``count`` random points in [-2, 2]^2, three iterations a step."""

    def __init__(self, count, seed=0):
        self.p = np.random.default_rng(seed).uniform(-2, 2, (count, 2)).astype(np.float32)
        self.k = tuple(np.float32(c) for c in ARTICLE)
        self.frame = NumpyFrame()

    def step(self):
        self.p = dejong(self.p, self.k, 3)


def default_image(path, count=2 ** 20, steps=20):
    """The default picture (stateful, 20 steps)."""
    job = NumpyDeJong(count)
    for _ in range(steps):
        job.step()
    job.frame.density(job.p)
    Image.fromarray(job.frame.post()).save(path)


def reseeded_image(path, side=1024):
    """The article's picture: the side x side grid of texel centres over [-2, 2]^2, the map three
    times."""
    centres = (np.arange(side, dtype=np.float32) + np.float32(0.5)) * np.float32(4 / side) - 2
    y, x = np.meshgrid(centres, centres, indexing="ij")
    k = tuple(np.float32(c) for c in ARTICLE)
    frame = NumpyFrame()
    frame.density(dejong(np.stack([x.ravel(), y.ravel()], axis=1), k, 3))
    Image.fromarray(frame.post()).save(path)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--reseed"]:
        reseeded_image(sys.argv[2])
    else:
        default_image(sys.argv[1])
