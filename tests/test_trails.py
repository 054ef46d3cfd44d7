"""Screen-space trails (issue 42, item 3, the fade): an animation's frames with --trails
fade:OPACITY against the same run's frames without, through the recurrence written here in
float64; a trail that fades out fully where a plain fade keeps a ghost; the refusals."""


import numpy as np
import pytest

from conftest import command
from es2particles.frame.pipeline import Pipeline
from es2particles.scenes.dejong import DeJong

SIZE = (128, 128)


def _frames(gl, trails, frames=8):
    scene = DeJong(reseed=True, animate_to=(1.9, -2.1, 2.2, -1.8))
    with Pipeline(gl, scene, particles=2 ** 14, size=SIZE, steps=1, bloom=None,
                  trails=trails) as p:
        return [p.image().astype(float) for _ in p.frames(frames)]


@pytest.mark.gl
def test_fade_trails_are_the_brighter_of_the_picture_and_the_last_frame_faded(gl):
    """Each frame with trails is max(picture, round(OPACITY x last - 0.6)) in codes, the pictures
    those of the same run without trails (the trails touch no state), the first frame's trail
    empty: all but a rounding's worth of pixels exact, none more than a code off. The coefficients
    move over the frames, so the last frame shows the earlier attractors fading."""
    opacity = 0.8
    plain, trailed = _frames(gl, "off"), _frames(gl, f"fade:{opacity}")
    want = plain[0]
    exact = []
    for t, (picture, got) in enumerate(zip(plain, trailed)):
        if t:
            want = np.maximum(picture, np.maximum(np.round(opacity * want - 0.6), 0))
        error = np.abs(got - want)
        assert error.max() <= 1, (t, error.max())
        exact.append(np.mean(error == 0))
    assert min(exact) > 0.99, exact
    assert np.mean(trailed[-1] > plain[-1] + 8) > 0.01  # the trail shows


@pytest.mark.gl
def test_a_wanted_frame_with_trails_draws_the_frames_before_it(gl):
    """A reseeded scene's frame needs nothing before it, but its trail does: asked for frame 5
    alone (as a cluster's task is), the pipeline draws frames 0 to 5 and gives the frame all of
    them give."""
    scene = DeJong(reseed=True, animate_to=(1.9, -2.1, 2.2, -1.8))
    settings = dict(particles=2 ** 14, size=SIZE, steps=1, bloom=None, trails="fade:0.8")
    with Pipeline(gl, scene, **settings) as p:
        alone = [p.image() for _ in p.frames(8, wanted=[5])]
    with Pipeline(gl, scene, **settings) as p:
        every = [p.image() for _ in p.frames(8)]
    assert len(alone) == 1 and np.array_equal(alone[0], every[5])


def test_a_trail_fades_out_fully_where_a_plain_fade_keeps_a_ghost():
    """A white pixel left behind over black: the trail's recurrence (less 0.6 of a code a frame,
    rounded to nearest) reaches 0 in 85 frames at 0.97, while x * 0.97 rounded to nearest sticks
    at 16 codes forever (webgl-wind's fade, whose descendants report the ghosts)."""
    ours, plain = 255.0, 255.0
    for frame in range(1, 1001):
        ours = max(np.round(0.97 * ours - 0.6), 0.0)
        plain = np.round(0.97 * plain)
        if ours == 0:
            break
    assert frame == 85 and ours == 0
    for _ in range(1000):
        plain = np.round(0.97 * plain)
    assert plain == 16


@pytest.mark.parametrize("words", [
    ["--trails", "fade:0.9"],  # a still
    ["--trails", "fade:1.5", "--frames", "3"],
    ["--trails", "fade:0", "--frames", "3"],
    ["--trails", "fade:x", "--frames", "3"],
    ["--trails", "ribbons:16", "--frames", "3"],
    ["--trails", "sometimes", "--frames", "3"],
])
def test_bad_trails_are_one_line(tmp_path, words):
    out = tmp_path / "x.webp"
    code, lines = command("run", "dejong", "--size", "32x32", *words, "--out", str(out))
    assert code == 2 and len(lines) == 1 and "--trails" in lines[0], lines
    assert not out.exists()
