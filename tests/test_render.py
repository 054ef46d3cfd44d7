"""The point renderer's density against numpy binning of the same decoded positions."""

import numpy as np
import pytest

from es2particles import ParameterError, Simulation
from es2particles.frame.pipeline import Renderer
from es2particles.render.points import Density
from es2particles.scenes.dejong import DeJong

SIZE = (96, 64)  # not square, not a power of two: a swapped axis or a padded row would show
VIEW = (-2.0, -2.0, 2.0, 2.0)
# points.vert puts each point's square on the pixel grid itself, so a rasteriser's own sub-pixel
# snapping moves none; only float32 arithmetic on the way, ~1e-5 of a pixel here, leaves a point
# near an edge on either side.
SNAP = 1e-4


def binned(points, size, view):
    """float64 reference: each point counts in the pixel that contains it (row 0 at the bottom),
    and the number of points within the snapping distance of a pixel edge, which may land in
    the neighbouring pixel instead."""
    x0, y0, x1, y1 = view
    w, h = size
    fx = (points[:, 0] - x0) / (x1 - x0) * w
    fy = (points[:, 1] - y0) / (y1 - y0) * h
    inside = (fx >= 0) & (fx < w) & (fy >= 0) & (fy < h)
    px, py = np.floor(fx[inside]).astype(int), np.floor(fy[inside]).astype(int)
    density = np.bincount(py * w + px, minlength=w * h).astype(np.float64)

    def near_edge(f):
        return np.abs(f - np.round(f)) <= SNAP

    ambiguous = int(np.count_nonzero(inside & (near_edge(fx) | near_edge(fy))))
    return density, ambiguous


@pytest.fixture
def particles(gl):
    """2^15 particles, most near the centre and a tenth spread over the whole range."""
    rng = np.random.default_rng(11)
    with Simulation(gl, DeJong().graph(), 2 ** 15) as sim:
        points = rng.normal(0, 0.8, (sim.count, 2)).clip(-1.99, 1.99)
        points[: sim.count // 10] = rng.uniform(-1.99, 1.99, (sim.count // 10, 2))
        sim.upload("position", points)
        yield sim


def draw(gl, sim, view=VIEW, draw_slice=None, **settings):
    """The density target of the particles drawn as points, (h * w,) counts of intensity 1 (a
    float target holds the count; an 8-bit one holds count/255, its byte)."""
    with Renderer(gl, Density(view, draw_slice=draw_slice), sim, size=SIZE, point_size=1.0,
                  bloom=None, **settings) as renderer:
        renderer.draw()
        return renderer.read("density")[..., 0].reshape(-1).astype(float)


def test_density_is_numpy_binning_of_the_decoded_positions(gl, particles):
    view = (-1.5, -1.0, 1.5, 1.0)  # some particles fall outside and must not be counted
    got = draw(gl, particles, view)
    expected, ambiguous = binned(particles.download("position"), SIZE, view)
    moved = np.abs(got - expected).sum() / 2  # each misplaced point counts twice
    print(f"density of {particles.count} points: {got.sum():.0f} drawn, {expected.sum():.0f} "
          f"in view; {moved:.0f} in a neighbouring pixel, {ambiguous} within snapping distance "
          f"of an edge")
    assert abs(got.sum() - expected.sum()) <= ambiguous
    assert moved <= ambiguous


@pytest.mark.parametrize("draw_slice", [1000, 4097])
def test_sliced_draw_gives_the_same_density_as_one_call(gl, particles, draw_slice):
    whole = draw(gl, particles, draw_slice=particles.count)
    assert np.array_equal(whole, draw(gl, particles, draw_slice=draw_slice))


def test_draw_slice_must_be_a_positive_integer(gl, particles):
    for bad in (0, -5, 2.5):
        with pytest.raises(ParameterError, match="draw_slice"):
            Density(VIEW, draw_slice=bad)


@pytest.mark.parametrize("intensity", [1.0, 4.0])
def test_the_tone_map_brightens_with_intensity(gl, intensity):
    """t = log(1 + e d / m) / log(1 + 256 e), m the density of an even spread at unit intensity
    (n / pixels) and d the pixel's density, intensity i a hit: grey = t, stored to the nearest
    code. In float64 from the density's counts, every pixel within one code (float32's log).
    --intensity did nothing before (m was relative to it, so it cancelled); now it brightens."""
    from es2particles.frame.pipeline import Pipeline
    from es2particles.scenes.dejong import DeJong

    n, size, exposure = 2 ** 14, (128, 128), 4.0
    with Pipeline(gl, DeJong(reseed=True), n, size, steps=1, bloom=None, gradient=None,
                  intensity=intensity, exposure=exposure) as pipeline:
        next(pipeline.frames(1))
        image = pipeline.image()
        d = np.frombuffer(pipeline.executor.read("density"), np.float32).reshape(128, 128, -1)
        d = d[::-1, :, 0].astype(np.float64)  # top row first, as the image
    hits = d / intensity
    assert np.array_equal(hits, np.round(hits)) and hits.sum() == n  # i per hit, every point
    t = np.clip(np.log1p(exposure * d / (n / (128 * 128))) / np.log1p(exposure * 256), 0, 1)
    expected = np.round(t * 255)
    for k in range(3):
        assert np.abs(image[..., k] - expected).max() <= 1
    if intensity > 1:  # brighter than unit intensity's picture where anything landed
        unit = np.round(np.clip(np.log1p(exposure * hits / (n / (128 * 128)))
                                / np.log1p(exposure * 256), 0, 1) * 255)
        lit = hits > 0
        assert (image[..., 0][lit] > unit[lit]).mean() > 0.9
