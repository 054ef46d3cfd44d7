"""Animations written frame by frame: MP4 through ffmpeg (the video extra), WebP/GIF/APNG
assembled from spilled frames; nothing is left behind by a failure."""

import numpy as np
import pytest

from conftest import needs

from es2particles.cli import main
from es2particles.io.output import AnimationWriter

imageio_ffmpeg = needs("imageio_ffmpeg", "test")


@pytest.mark.gl
def test_the_issues_command_writes_an_mp4_of_12_frames(tmp_path):
    out = tmp_path / "a.mp4"
    assert main(["run", "dejong", "--particles", "65536", "--size", "256x256", "--frames", "12",
                 "--animate-to", "1.5,-2.3,2.4,-2.1", "--out", str(out)]) == 0
    frames, _ = imageio_ffmpeg.count_frames_and_secs(str(out))
    assert frames == 12
    reader = imageio_ffmpeg.read_frames(str(out))
    meta = next(reader)
    first = np.frombuffer(next(reader), np.uint8).reshape(256, 256, 3)
    assert meta["size"] == (256, 256) and 0.02 < (first.max(axis=2) > 40).mean() < 0.9
    assert [p.name for p in tmp_path.iterdir()] == ["a.mp4"]  # no frames folder left


@pytest.mark.parametrize("suffix", [".webp", ".gif", ".png"])
def test_spilled_frames_assemble_and_are_removed(tmp_path, suffix):
    from PIL import Image

    path = tmp_path / f"a{suffix}"
    with AnimationWriter(path, fps=10) as writer:
        for k in range(5):
            writer.add(np.full((16, 24, 3), 40 * k, np.uint8))
        writer.close()
    with Image.open(path) as image:
        assert image.n_frames == 5 and image.size == (24, 16)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


@pytest.mark.parametrize("suffix", [".webp", ".mp4"])
def test_a_failure_while_writing_leaves_nothing(tmp_path, suffix):
    with pytest.raises(RuntimeError):
        with AnimationWriter(tmp_path / f"a{suffix}") as writer:
            writer.add(np.zeros((16, 16, 3), np.uint8))
            raise RuntimeError("interrupted between frames")
    assert list(tmp_path.iterdir()) == []


def test_mp4_refuses_odd_sizes_before_any_work(tmp_path, capsys):
    assert main(["run", "dejong", "--particles", "256", "--size", "33x32", "--frames", "2",
                 "--animate-to", "1.5,-2.3,2.4,-2.1", "--out", str(tmp_path / "a.mp4")]) == 2
    assert "MP4 needs an even width and height, got 33x32" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_long_image_animations_are_refused_up_front_mp4_is_not(tmp_path, capsys):
    assert main(["run", "dejong", "--particles", "256", "--size", "16x16", "--frames", "5000",
                 "--out", str(tmp_path / "a.webp")]) == 2
    assert "write .mp4 for longer animations" in capsys.readouterr().err
