"""Trails (issue 42, item 3). The screen-space fade: an animation's frames with --trails
fade:OPACITY against the same run's frames without, through the recurrence written here in
float64; a trail that fades out fully where a plain fade keeps a ghost. Ribbons: the history
against the positions read back frame by frame, and the strips' pixels against the segments
projected here; no gaps where the fade trails leave them. The refusals."""


import numpy as np
import pytest

from conftest import command
from es2particles.frame.pipeline import Pipeline
from es2particles.frame.trails import COLOUR_2D
from es2particles.scenes.dejong import DeJong
from es2particles.scenes.fountain import Fountain
from es2particles.scenes.wind import Wind

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


MOVING = ["--animate-to", "1.9,-2.1,2.2,-1.8"]


@pytest.mark.parametrize("words", [
    ["--trails", "fade:0.9"],  # a still
    ["--trails", "fade:1.5", "--frames", "3"],
    ["--trails", "fade:0", "--frames", "3"],
    ["--trails", "fade:x", "--frames", "3"],
    ["--trails", "ribbons:16", "--frames", "3", "--reseed", *MOVING],  # reseeded: no path
    ["--trails", "sometimes", "--frames", "3"],
    ["--trails", "ribbons:1", "--frames", "3", *MOVING],
    ["--trails", "ribbons:65", "--frames", "3", *MOVING],
    ["--trails", "ribbons:x", "--frames", "3", *MOVING],
])
def test_bad_trails_are_one_line(tmp_path, words):
    out = tmp_path / "x.webp"
    code, lines = command("run", "dejong", "--size", "32x32", *words, "--out", str(out))
    assert code == 2 and len(lines) == 1 and "--trails" in lines[0], lines
    assert not out.exists()


@pytest.mark.gl
def test_ribbons_taller_than_the_largest_texture_are_one_line(tmp_path):
    """64 bands of the 2^20 particles' 1,024 rows pass any context's largest texture: refused
    when the frame is planned on the context, in one line naming --trails."""
    out = tmp_path / "x.webp"
    code, lines = command("run", "dejong", "--size", "32x32", "--trails", "ribbons:64",
                          "--frames", "3", *MOVING, "--out", str(out))
    assert code == 2 and len(lines) == 1 and "--trails" in lines[0], lines
    assert not out.exists()


def _ribbon_run(gl, trails, frames, k=8, scene=None, particles=2 ** 10):
    """The scene's frames (default the fountain's) with ``trails``: the last picture, each
    frame's positions and lives read back, the history, and the last frame's projection of
    world points to pixels (x right, y down) written here."""
    scene = scene or Fountain()
    with Pipeline(gl, scene, particles=particles, size=SIZE, trails=trails) as p:
        positions, lives, picture = [], [], None
        for _ in p.frames(frames, steps_per_frame=2):
            positions.append(p.sim.download("position"))
            lives.append(p.sim.download("life"))
            picture = p.image().astype(float)
        history = None
        if trails.startswith("ribbons"):
            w, h = p.plan.resources["ribbon history"].size
            history = np.frombuffer(p.executor.read("ribbon history"), np.float32).reshape(
                k, h // k, w, 4)
        if isinstance(scene, Wind):
            x0, y0, x1, y1 = scene.rendering().view

            def project(points):
                pixels = np.stack([(points[:, 0] - x0) / (x1 - x0) * SIZE[0],
                                   (1 - (points[:, 1] - y0) / (y1 - y0)) * SIZE[1]], axis=1)
                return pixels, np.ones(len(points), bool)
        else:
            camera = p.camera(frames - 1, frames)

            def project(points):
                pixels, _, visible = camera.project(points, SIZE)
                return pixels, visible
        return picture, positions, lives, history, project


@pytest.mark.gl
def test_the_ribbon_history_holds_the_last_k_frames_positions(gl):
    """After 11 frames of K = 8, band (frame mod 8) holds frame's positions (read back each
    frame) and age plus one where alive, 0 where not: the last 8 frames, as a ring."""
    frames, k = 11, 8
    _, positions, lives, history, _ = _ribbon_run(gl, f"ribbons:{k}", frames, k)
    n = len(positions[0])
    for frame in range(frames - k, frames):
        band = history[frame % k].reshape(-1, 4)[:n]
        age, lifetime = lives[frame].T
        alive = (age >= 0) & (age < lifetime)
        np.testing.assert_allclose(band[alive, :3], positions[frame][alive], rtol=0, atol=1e-5)
        np.testing.assert_allclose(band[:, 3], np.where(alive, age + 1, 0), rtol=0, atol=1e-5)


def _segments(history, k, newest, count):
    """Each rank's band, newest first, from the history read back."""
    return [history[(newest - r) % k].reshape(-1, 4)[:count] for r in range(k)]


def _ribbon_pixels(bands, project, k, samples=33):
    """Per segment rank r: the pixels (x, y) of ``samples`` points along every segment of one
    life (both ends alive, the newer no younger), projected here."""
    out = []
    for r in range(k - 1):
        newer, older = bands[r], bands[r + 1]
        ok = (newer[:, 3] > 0) & (older[:, 3] > 0) & (newer[:, 3] >= older[:, 3])
        rows = []
        for t in np.linspace(0, 1, samples):
            pixels, visible = project(newer[ok, :3] * (1 - t) + older[ok, :3] * t)
            x, y = np.floor(pixels[visible]).astype(int).T
            inside = (x >= 0) & (x < SIZE[0]) & (y >= 0) & (y < SIZE[1])
            rows.append((t, x[inside], y[inside]))
        out.append(rows)
    return out


def _stray(added, segments):
    """Pixels a ribbon lit (more than 2 codes added) further than 2 pixels from every segment."""
    near = np.zeros(SIZE[::-1], bool)
    for rows in segments:
        for _, x, y in rows:
            for dx in range(-2, 3):
                for dy in range(-2, 3):
                    near[np.clip(y + dy, 0, SIZE[1] - 1), np.clip(x + dx, 0, SIZE[0] - 1)] = True
    return (added > 2) & ~near


@pytest.mark.gl
def test_ribbons_join_each_particle_s_positions_without_gaps(gl):
    """Every segment between a particle's consecutive positions of the same life (from the
    history), sampled at 9 points and projected here, lights its pixels in the picture less the
    same run's picture without ribbons, wherever it is bright enough to see (the newer 70% of a
    ribbon, over pixels below 200 codes): all of them measured; the fade trails of the same frames
    leave a fifth of them dark (79% lit: fireballs move further a frame than they are wide).
    No ribbon lights a pixel more than 2 pixels from every such segment."""
    frames, k = 12, 8
    plain = _ribbon_run(gl, "off", frames)[0]
    ribbons, _, _, history, project = _ribbon_run(gl, f"ribbons:{k}", frames, k)
    faded = _ribbon_run(gl, "fade:0.9", frames)[0]
    segments = _ribbon_pixels(_segments(history, k, (frames - 1) % k, 2 ** 10), project, k)
    lit_r, lit_f, total = 0, 0, 0
    for rows in segments[:int(0.7 * (k - 1))]:
        for t, x, y in rows[::4]:
            dim = plain[y, x].max(axis=1) < 200
            total += dim.sum()
            lit_r += (ribbons[y, x, 0] - plain[y, x, 0] > 0)[dim].sum()
            lit_f += (faded[y, x, 0] - plain[y, x, 0] > 0)[dim].sum()
    print(f"{total} samples: ribbons light {lit_r / total:.2%}, fade trails {lit_f / total:.2%}")
    stray = _stray(ribbons[..., 0] - plain[..., 0], segments)
    assert total > 2000 and stray.sum() == 0, stray.sum()
    assert lit_r / total > 0.995
    assert lit_f / total < 0.9  # measured 79%: a fifth of the way between fireballs is dark


@pytest.mark.gl
def test_ribbons_end_where_a_life_does_and_fade_with_age(gl):
    """The wind's particles (2D) are born again at a random place when old or leaving the box:
    no ribbon joins a life to the next (no pixel lit more than 2 pixels from a segment of one
    life). Of 8 particles alone, a ribbon's light at the middle of its segment r (one over 3
    pixels long: away from its ends' square caps) is the colour times the fade 1 - (r + 1/2) /
    7, within a code (measured: 0.53; the output's rounding and the fade interpolated at the
    pixel's centre, not the segment's), over
    the dark background."""
    frames, k = 14, 8
    scene = Wind(grid="32x32")
    plain = _ribbon_run(gl, "off", frames, scene=scene)[0]
    ribbons, _, _, history, project = _ribbon_run(gl, f"ribbons:{k}", frames, k, scene=scene)
    bands = _segments(history, k, (frames - 1) % k, 2 ** 10)
    reborn = np.sum([(bands[r][:, 3] > 0) & (bands[r + 1][:, 3] > bands[r][:, 3])
                     for r in range(k - 1)])
    assert reborn > 20  # lives end within the ribbons' frames
    stray = _stray(ribbons[..., 0] - plain[..., 0], _ribbon_pixels(bands, project, k))
    assert stray.sum() == 0, stray.sum()
    plain = _ribbon_run(gl, "off", frames, scene=scene, particles=8)[0]
    ribbons, _, _, history, project = _ribbon_run(gl, f"ribbons:{k}", frames, k, scene=scene,
                                                  particles=8)
    added = ribbons - plain
    bands = _segments(history, k, (frames - 1) % k, 8)
    checked = 0
    for r in range(k - 1):
        newer, older = bands[r], bands[r + 1]
        ok = (newer[:, 3] > 0) & (older[:, 3] > 0) & (newer[:, 3] >= older[:, 3])
        a, b = project(newer[ok, :3])[0], project(older[ok, :3])[0]
        long = np.linalg.norm(a - b, axis=1) > 3  # the middle away from the ends' caps
        x, y = np.floor((a + b)[long] / 2).astype(int).T
        dark = plain[y, x].max(axis=1) < 20
        want = 255 * np.array(COLOUR_2D) * (1 - (r + 0.5) / (k - 1))
        assert np.all(np.abs(added[y, x][dark] - want) <= 1), (r, added[y, x][dark], want)
        checked += dark.sum()
    assert checked >= 20, checked
