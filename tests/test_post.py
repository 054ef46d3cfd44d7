"""The post chain: the bloom blur's paired taps against a direct float64 Gaussian convolution;
the gradient map over any picture against its float64 lookup."""

import numpy as np
import pytest

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


LUMA = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709


def ramp_lookup(ramp, t):
    """float64 reference of the gradient map's lookup: ``t`` in [0, 1] at the ramp's texel
    centres 0..255, linear between them; ``ramp`` (256, 3) codes. Returns codes."""
    x = np.clip(t, 0.0, 1.0) * 255
    i0 = np.minimum(np.floor(x).astype(int), 254)
    f = (x - i0)[..., None]
    return ramp[i0] * (1 - f) + ramp[i0 + 1] * f


@pytest.mark.gl
@pytest.mark.parametrize("scene, ramp", [("fountain", "ice"), ("flame", "viridis"),
                                         ("confetti", "#000,#f80,#fff")])
def test_the_gradient_map_colours_any_picture_by_its_luma(gl, scene, ramp):
    """`--gradient RAMP` over a picture drawn in colour (sprites, a marched flame, quads): each
    pixel's Rec. 709 luma picks its colour along the ramp, against the float64 lookup of the
    picture drawn without it. Within a code (the ramp's 8-bit texels filtered, and a mediump
    luma: 2^-11, a tenth of a code), and unbiased: the mean within a quarter of a code, where a
    half-code bias of the map moves it by a half. Off by default: the picture as drawn."""
    from es2particles.frame.pipeline import Pipeline
    from es2particles.io.ramps import load_ramp
    from es2particles.scenes import scene_class

    def picture(**given):
        with Pipeline(gl, scene_class(scene)(), size=(96, 64), steps=30, **given) as p:
            p.step(0)
            return p.image().astype(np.float64), [s.name for s in p.plan.frame_stages]

    plain, stages = picture()
    assert "gradient map" not in stages
    mapped, stages = picture(gradient=ramp)
    assert stages[-1] == "gradient map"
    table = np.asarray(load_ramp(ramp), np.float64).reshape(256, 4)[:, :3]
    reference = np.round(ramp_lookup(table, plain / 255 @ LUMA))
    error = mapped - reference
    spread = np.ptp(plain @ LUMA)
    print(f"{scene} through {ramp!r}: luma spread {spread:.0f} codes; max |error| "
          f"{np.abs(error).max():.0f} codes, mean {error.mean():+.3f}")
    assert spread > 50, "the picture should have dark and bright parts"
    assert np.abs(error).max() <= 1 and abs(error.mean()) < 0.25
