"""The emitter family (scenes/emitter.py): the camera from --eye, --target and --fov, fixed or
orbiting from where --eye puts it; and a sprite picture with no lit pixel warns, naming the
sprite size, the attenuation and the camera distance."""

import warnings

import numpy as np
import pytest

from es2particles.cli import main
from es2particles.errors import NothingDrawnWarning, ParameterError
from es2particles.frame.pipeline import Pipeline
from es2particles.scenes import Collision3D, Fountain, Smoke


@pytest.mark.parametrize("cls", [Fountain, Collision3D, Smoke])
def test_the_camera_is_the_one_the_options_place(cls):
    scene = cls(eye=(3.0, 2.0, -4.0), target=(0.5, 1.0, 0.5), fov=30.0)
    camera = scene.camera_at(0, 1)
    assert camera.eye == (3.0, 2.0, -4.0) and camera.target == (0.5, 1.0, 0.5)
    assert camera.fov == 30.0


def test_an_orbit_starts_at_the_eye_and_circles_the_target_at_its_height():
    eye, target = np.array([3.0, 2.0, -4.0]), np.array([0.5, 1.0, 0.5])
    scene = Fountain(eye=tuple(eye), target=tuple(target), camera="orbit")
    radius = np.hypot(*(eye - target)[[0, 2]])
    for frame, frames in ((0, 8), (2, 8), (4, 8), (7, 8)):
        got = np.array(scene.camera_at(frame, frames).eye)
        angle = np.arctan2(*(eye - target)[[0, 2]]) + 2 * np.pi * frame / frames
        expected = target + [radius * np.sin(angle), eye[1] - target[1], radius * np.cos(angle)]
        assert np.allclose(got, expected, atol=1e-12), (frame, got, expected)
    assert np.allclose(scene.camera_at(0, 8).eye, eye)


def test_the_eye_must_not_be_the_target():
    with pytest.raises(ParameterError, match="--eye and --target must differ"):
        Fountain(eye=(0.0, 1.0, 0.0), target=(0.0, 1.0, 0.0))


def unlit_expectation(scene, point_size, height):
    """The figures the warning must give, from the scene's declared camera, in float64."""
    p = scene.params
    default = type(p)()
    d0 = np.linalg.norm(np.subtract(default.eye, default.target))
    d = np.linalg.norm(np.subtract(p.eye, p.target))
    return 1 / d0 ** 2, d, point_size * height / 1024 / np.sqrt(d * d / d0 ** 2)


@pytest.mark.parametrize("given", [{"point_size": 1.0, "size": (32, 24)},  # the least size
                                   {"point_size": 2.0, "size": (128, 96), "eye_far": 1}])
def test_a_picture_with_no_lit_sprite_warns_with_its_figures(gl, given):
    scene = Fountain(eye=(0.0, 3.0, 60.0)) if given.get("eye_far") else Fountain()
    size = given["size"]
    c, d, diameter = unlit_expectation(scene, given["point_size"], size[1])
    with Pipeline(gl, scene, particles=512, size=size, point_size=given["point_size"]) as p:
        with pytest.warns(NothingDrawnWarning) as caught:
            next(p.frames())
    text = str(caught[0].message)
    assert f"point size {given['point_size']:g}" in text
    assert f"attenuation (0, 0, {c:g})" in text
    assert f"{diameter:.2g} pixels across" in text and f"distance {d:.3g}" in text


def test_a_picture_with_lit_sprites_does_not_warn_and_is_the_same_with_the_check(gl):
    """The check draws the first frame without its sprites before the frame itself: the
    picture, and a sort spread over frames, are the same as with no check."""
    images = []
    for check in (True, False):
        with Pipeline(gl, Smoke(sort="5"), particles=1024, size=(96, 64), steps=30) as p:
            if not check:
                p._unlit_check = None
            with warnings.catch_warnings():
                warnings.simplefilter("error", NothingDrawnWarning)
                images.append([p.image() for _ in p.frames(3)])
    assert all(np.array_equal(a, b) for a, b in zip(*images))
    assert images[0][0].std() > 1  # something is drawn


@pytest.mark.gl
def test_the_command_line_says_the_warning_in_one_line(tmp_path, capsys):
    out = tmp_path / "f.png"
    assert main(["run", "fountain", "--particles", "512", "--size", "32x32", "--point-size",
                 "1", "--out", str(out)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [line for line in err if line.startswith("es2particles: warning: frame 0: no "
                                                           "sprite lit a pixel")] and len(err) == 1
    assert out.is_file()  # a warning, not an error: the picture is what was asked for
