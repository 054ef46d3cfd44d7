"""Rendered images: size, not blank, not saturated; what the gradient map and bloom do."""

import numpy as np
import pytest

from masks import dilate
from es2particles.frame.pipeline import Pipeline
from es2particles import Bloom
from es2particles.scenes.dejong import DeJong


def render(ctx, gradient="inferno", bloom=None, particles=2 ** 18, size=(256, 256), seed=0):
    with Pipeline(ctx, DeJong(), particles, size, gradient=gradient, bloom=bloom, seed=seed) as p:
        p.step(10)
        return p.image()


def save_diff(folder, name, a, b):
    """On failure, leave the two images and their difference in the test's temporary
    ``folder`` for a person (pytest keeps the last runs' folders); returns their path, for the
    failure's message."""
    from PIL import Image

    diff = np.abs(a.astype(int) - b.astype(int)).clip(0, 255).astype(np.uint8)
    path = folder / f"{name}.png"
    Image.fromarray(np.concatenate([a, b, diff], axis=1)).save(path)
    return path


def test_image_is_the_right_size_not_blank_not_saturated(gl):
    image = render(gl, size=(320, 200))
    assert image.shape == (200, 320, 3) and image.dtype == np.uint8
    lit = (image.max(axis=2) > 10).mean()
    saturated = (image.min(axis=2) >= 250).mean()
    print(f"lit fraction {lit:.3f}, saturated fraction {saturated:.4f}")
    assert 0.2 < lit < 0.95, "the attractor should cover part of the picture, not none or all"
    assert saturated < 0.01


def test_grey_and_gradient_maps(gl):
    grey = render(gl, gradient=None)
    assert np.array_equal(grey[..., 0], grey[..., 1]) and np.array_equal(grey[..., 1], grey[..., 2])
    red = render(gl, gradient="#000000,#ff0000")
    assert red[..., 1:].max() == 0 and red[..., 0].max() > 200
    # The ramp is a function of the grey level: equal grey, equal colour.
    inferno = render(gl, gradient="inferno")
    g = grey[..., 0].ravel()
    for level in np.unique(g)[::17]:
        colours = inferno.reshape(-1, 3)[g == level]
        assert np.ptp(colours, axis=0).max() <= 2


def test_bloom_spreads_light_around_bright_regions_and_zero_bloom_changes_nothing(gl, tmp_path):
    plain = render(gl, bloom=None)
    zero = render(gl, bloom=Bloom(intensity=0.0))
    if not np.array_equal(plain, zero):
        path = save_diff(tmp_path, "bloom_zero", plain, zero)
        pytest.fail(f"bloom of intensity 0 must equal no bloom (the two images and their "
                    f"difference: {path})")
    bloomed = render(gl, bloom=Bloom(threshold=0.3, radius=3, intensity=2.0))
    assert np.all(bloomed.astype(int) >= plain.astype(int) - 1), "bloom only adds light"
    gain = bloomed.astype(int).sum() - plain.astype(int).sum()
    assert gain > 0
    # The glow lands next to bright pixels, including on pixels that were dark.
    luma = plain.mean(axis=2)
    dark = luma < 5
    bright = luma > 100  # ~2,200 pixels (above 150 there were only ~8, and no dark one near)
    near_bright = dilate(bright, 4) & dark
    far = dark & ~dilate(bright, 24)
    lift_near = (bloomed.mean(axis=2) - luma)[near_bright].mean()
    lift_far = (bloomed.mean(axis=2) - luma)[far].mean() if far.any() else 0.0
    print(f"bloom lift: near bright {lift_near:.2f}, far {lift_far:.2f}")
    assert lift_near > lift_far + 1


def test_same_arguments_same_image(gl):
    assert np.array_equal(render(gl, seed=3), render(gl, seed=3))
    assert not np.array_equal(render(gl, seed=3), render(gl, seed=4))


@pytest.mark.slow
@pytest.mark.parametrize("size", [0, 100, 2 ** 20 - 1, 2 ** 21 + 7, 5 * 2 ** 20 + 3])
def test_deflate_in_pieces_inflates_to_the_same_bytes(size):
    """Large data is deflated in pieces on threads and joined into one zlib stream: the standard
    inflater must give back every byte, at every level."""
    import zlib

    from es2particles.io.output import deflate

    data = np.random.default_rng(size).integers(0, 6, size, dtype=np.uint8).tobytes()
    for level in (0, 1, 6, 9):
        assert zlib.decompress(deflate(data, level)) == data, (size, level)
