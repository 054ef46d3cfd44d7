"""Runs on a real Dask cluster (a 2-worker LocalCluster of processes, each with its own EGL
context): the same bytes as one process for stills drawn in shares and for animations, frames
kept and skipped on a second run, and clear errors. Shares are checked against numpy binning of
the float64 twin."""

import json
import logging

import numpy as np
import pytest
from PIL import Image

from conftest import missing
from es2particles.cluster import tasks as cluster
from es2particles.cluster import shares
from es2particles.cli import build_parser, main, run_of
from es2particles.scenes.attractor import jitter
from es2particles.scenes.dejong import DeJong

pytestmark = [pytest.mark.gl, pytest.mark.slow]

try:
    import distributed
except ImportError:
    missing("dask's distributed is not installed (the test extra: sh setup.sh test)")

SMALL = ["--size", "64x64"]
ANIMATION = ["run", "dejong", "--reseed", "--particles", "4096", *SMALL, "--frames", "5",
             "--animate-to", "1.5,-2.2,2.3,-2.0"]


@pytest.fixture(scope="module")
def scheduler():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None, silence_logs=logging.ERROR) as local:
        yield local.scheduler_address


def frames_of(path):
    with Image.open(path) as image:
        out = []
        for k in range(getattr(image, "n_frames", 1)):
            image.seek(k)
            out.append(np.asarray(image.convert("RGB")))
        return out


def test_a_still_in_shares_on_two_local_workers_has_one_process_s_bytes(tmp_path, capsys):
    """2^22 + 1 particles: two shares (2^22 and 1), each with its own seed; --workers 2 starts
    its own LocalCluster."""
    command = ["run", "dejong", "--particles", str(shares.SHARE + 1), *SMALL, "--steps", "2"]
    assert main([*command, "--out", str(tmp_path / "one.png")]) == 0
    assert "in 2 shares" in capsys.readouterr().out
    assert main([*command, "--workers", "2", "--out", str(tmp_path / "two.png")]) == 0
    assert "on 2 local worker(s)" in capsys.readouterr().out
    assert (tmp_path / "one.png").read_bytes() == (tmp_path / "two.png").read_bytes()


def test_a_reseeded_still_in_shares_has_one_process_s_bytes(scheduler, tmp_path):
    command = ["run", "dejong", "--reseed", "--particles", str(2 * shares.SHARE), *SMALL,
               "--accumulate", "2"]
    assert main([*command, "--out", str(tmp_path / "one.png")]) == 0
    assert main([*command, "--scheduler", scheduler, "--out", str(tmp_path / "two.png")]) == 0
    assert (tmp_path / "one.png").read_bytes() == (tmp_path / "two.png").read_bytes()


@pytest.mark.parametrize("command", [
    ANIMATION,  # reseeded: a task a frame
    ["run", "fountain", "--particles", "2048", "--size", "96x96", "--frames", "5"],  # stateful
], ids=["reseeded", "stateful"])
def test_an_animation_on_the_cluster_has_one_process_s_bytes(scheduler, tmp_path, command):
    assert main([*command, "--out", str(tmp_path / "one.gif")]) == 0
    assert main([*command, "--scheduler", scheduler, "--out", str(tmp_path / "two.gif")]) == 0
    assert (tmp_path / "one.gif").read_bytes() == (tmp_path / "two.gif").read_bytes()
    assert not (tmp_path / "two.gif.frames").exists()  # the kept frames go once assembled


def test_kept_frames_are_skipped_and_the_folder_must_match(scheduler, tmp_path, capsys):
    """A run cut short leaves OUT.frames/; the next run of the same command makes only the
    missing frames (a kept frame, here a grey one, goes into the animation as it is)."""
    out = tmp_path / "anim.png"
    main([*ANIMATION, "--out", str(tmp_path / "one.png")])
    reference = frames_of(tmp_path / "one.png")
    argv = [*ANIMATION, "--scheduler", scheduler, "--out", str(out)]
    folder = tmp_path / "anim.png.frames"
    folder.mkdir()
    run = run_of(build_parser(argv).parse_args(argv))
    (folder / "manifest.json").write_text(json.dumps(cluster.manifest(run), indent=1))
    grey = np.full((64, 64, 3), 128, np.uint8)
    Image.fromarray(grey).save(folder / "000002.png")
    assert main(argv) == 0
    got = frames_of(out)
    assert len(got) == 5 and np.array_equal(got[2], grey)
    for k in (0, 1, 3, 4):
        assert np.array_equal(got[k], reference[k]), k
    assert not folder.exists()

    folder.mkdir()  # frames of another command: refused, nothing written
    (folder / "manifest.json").write_text(json.dumps({"scene": "dejong", "seed": 7}))
    out.unlink()
    capsys.readouterr()
    assert main(argv) == 2
    assert "holds frames of another command" in capsys.readouterr().err
    assert not out.exists()


def test_shares_count_what_numpy_bins_from_the_float64_twin(gl, tmp_path):
    """Share 1 of a reseeded still draws the grid shifted by the R2 sequence's sample 1 (times
    --accumulate): its counts against numpy binning of the twin's positions of that grid."""
    argv = ["run", "dejong", "--reseed", "--particles", str(2 * 64 * 64), "--size", "128x128",
            "--out", str(tmp_path / "x.png")]
    run = run_of(build_parser(argv).parse_args(argv))
    counts = shares.share_counts(gl, run, share=1, count=64 * 64)
    scene = DeJong(reseed=True)
    x0, y0, x1, y1 = scene.range
    centres = (np.arange(64) + 0.5 + jitter(1)[:, None]) / 64
    gx, gy = np.meshgrid(x0 + centres[0] * (x1 - x0), y0 + centres[1] * (y1 - y0))
    p = scene.iterate(np.stack([gx.ravel(), gy.ravel()], axis=1))
    v0, w0, v1, w1 = scene.view
    expected, _, _ = np.histogram2d(p[:, 1], p[:, 0], bins=128, range=[[w0, w1], [v0, v1]])
    assert counts.sum() == 64 * 64 and counts.dtype == np.float32
    assert np.abs(counts - expected).sum() <= 0.02 * 64 * 64  # points on a pixel's edge may move


def test_share_sizes_reach_2_to_the_34_and_say_their_limits(tmp_path):
    def sizes(*extra):
        argv = ["run", "dejong", *extra, "--out", str(tmp_path / "x.png")]
        args = build_parser(argv).parse_args(argv)
        return shares.share_sizes(run_of(args), save_state=args.save_state is not None)

    assert sizes("--particles", str(shares.SHARE)) is None  # one pipeline
    big = sizes("--particles", str(2 ** 34 + 5))
    assert len(big) == 4097 and sum(big) == 2 ** 34 + 5 and big[-1] == 5
    assert sizes("--particles", str(2 ** 34), "--frames", "3") is None  # animations: one pipeline
    with pytest.raises(Exception, match=r"particles must be in \[1, 68719476736\]"):
        sizes("--particles", str(2 ** 36 + 1))
    with pytest.raises(Exception, match="--save-state writes one pipeline's state"):
        sizes("--particles", str(2 ** 23), "--save-state", str(tmp_path / "s.npz"))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("extra, message", [
    (["--workers", "0"], "workers must be in [1, 1024], got 0"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "not both"),
    (["--workers", "2", "--save-state", "{tmp}/s.npz"], "--save-state writes one process's state"),
])
def test_cluster_options_are_checked_before_any_work(tmp_path, capsys, extra, message):
    out = tmp_path / "x.png"
    extra = [a.format(tmp=tmp_path) for a in extra]
    assert main(["run", "dejong", *SMALL, *extra, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
