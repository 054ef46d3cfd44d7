"""The bloom blur's paired taps against a direct float64 Gaussian convolution."""

import numpy as np

from es2particles.frame.bloom import blur_taps


def test_paired_linear_taps_equal_the_25_tap_gaussian():
    sigma, taps = 3.0, 12
    centre, pairs = blur_taps(sigma, taps)
    signal = np.random.default_rng(0).random(200)
    padded = np.pad(signal, 20)
    grid = np.arange(len(padded))

    def fetch(x):  # linear filtering, as the sampler does
        return np.interp(x, grid, padded)

    i = np.arange(20, 20 + len(signal))
    paired = centre * padded[i] + sum(w * (fetch(i + o) + fetch(i - o)) for o, w in pairs)
    x = np.arange(-taps, taps + 1)
    kernel = np.exp(-0.5 * x ** 2 / sigma ** 2)
    direct = np.convolve(padded, kernel / kernel.sum(), "same")[i]
    assert np.abs(paired - direct).max() < 1e-12
    assert abs(centre + 2 * sum(w for _, w in pairs) - 1) < 1e-12
