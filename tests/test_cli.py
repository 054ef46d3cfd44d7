"""The command line: images, animations, saved state, plans, and clear errors with no partial file."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from conftest import missing
from es2particles.cli import main

SMALL = ["--particles", "4096", "--size", "64x64"]


@pytest.mark.gl
def test_run_writes_png_and_state(tmp_path, capsys):
    out, state = tmp_path / "a.png", tmp_path / "s.npz"
    assert main(["run", "dejong", *SMALL, "--steps", "3", "--out", str(out),
                 "--save-state", str(state)]) == 0
    with Image.open(out) as image:
        assert image.size == (64, 64)
    saved = np.load(state)
    assert saved["position"].shape == (4096, 2) and saved["position"].dtype == np.float64
    assert np.abs(saved["position"]).max() <= 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "s.npz"]


@pytest.mark.gl
@pytest.mark.parametrize("suffix", [".webp", ".gif", ".png"])
def test_run_writes_an_animation(tmp_path, suffix):
    out = tmp_path / f"anim{suffix}"
    assert main(["run", "dejong", *SMALL, "--reseed", "--frames", "3", "--animate-to",
                 "1.5,-2.2,2.3,-2.0", "--out", str(out)]) == 0
    with Image.open(out) as image:
        assert getattr(image, "n_frames", 1) == 3


@pytest.mark.gl
def test_plan_shows_only_what_the_scene_needs(capsys):
    assert main(["plan", "dejong", *SMALL, "--reseed", "--no-bloom"]) == 0
    text = capsys.readouterr().out
    assert "1. dejong: attractors/dejong.frag writes position; reads nothing" in text
    assert "position (2 components): 1 (single" in text
    assert "writes velocity" not in text and "velocity: " not in text
    assert "writes acceleration" not in text and "acceleration: " not in text
    assert "dejong needs no velocity or acceleration" in text
    assert "points: points.vert + points.frag -> density" in text
    assert "4096 points of 1 pixel, vertex texture fetch of position" in text
    assert "tone map: post/tonemap.frag -> tone map" in text and "gradient map 'inferno'" in text
    assert "left out: bloom (switched off)" in text
    assert "bloom:" not in text


@pytest.mark.parametrize("arguments, message", [
    (["--particles", "0"], "particles must be in [1, "),
    (["--particles", "-3"], "particles must be in [1, "),
    (["--particles", str(2 ** 40)], "particles must be in [1, "),
    (["--size", "99999x64"], "size width must be in [1, "),
    (["--size", "64"], "size must be WxH"),
    (["--a", "nan"], "a must be finite"),
    (["--d", "inf"], "d must be finite"),
    (["--gradient", "rainbowish"], "gradient 'rainbowish' is unknown"),
    (["--bloom-radius", "40"], "--bloom-radius must be in [0.5, 4], got 40"),
    (["--point-size", "0"], "--point-size must be in [1, "),
])
def test_bad_input_is_a_clear_error_and_leaves_no_file(tmp_path, capsys, arguments, message):
    out = tmp_path / "x.png"
    assert main(["run", "dejong", *SMALL, *arguments, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err, err
    assert list(tmp_path.iterdir()) == []


def test_a_point_size_beyond_what_the_driver_draws_is_one_line(gl, tmp_path, capsys):
    """Past the top of the point sizes the driver draws (255 on llvmpipe, 2048 on NVIDIA's)
    and within --point-size's own range: refused by the driver's top, naming it."""
    from es2particles.frame.settings import MAX_POINT_SIZE

    top = gl.caps.drawn_point_size_range[1]
    if top + 1 > MAX_POINT_SIZE:
        pytest.skip(f"this driver draws points up to {top:g}: beyond --point-size's own top")
    out = tmp_path / "x.png"
    assert main(["run", "dejong", *SMALL, "--point-size", f"{top + 1:g}", "--out",
                 str(out)]) == 2
    err = capsys.readouterr().err
    assert f"point_size must be in [1, {top:g}]" in err and "Traceback" not in err, err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.gl
def test_unwritable_or_wrong_output_paths(tmp_path, capsys):
    # a missing folder is made, when the image is written
    assert main(["run", "dejong", *SMALL, "--out", str(tmp_path / "new" / "deeper" / "x.png")]) == 0
    assert (tmp_path / "new" / "deeper" / "x.png").is_file()
    (tmp_path / "plain").write_text("a file")
    assert main(["run", "dejong", *SMALL, "--out", str(tmp_path / "plain" / "x.png")]) == 2
    assert "is a file, not a folder" in capsys.readouterr().err
    assert main(["run", "dejong", *SMALL, "--out", str(tmp_path / "x.jpg")]) == 2
    assert "--out must end in .png" in capsys.readouterr().err


def without_capabilities():
    """The command prefix that runs a command as root without its capabilities (util-linux's
    setpriv empties the bounding set, so the command's exec gains none): file permissions then
    bind root as its owner bits say, so a mode-555 folder is read-only to it, while every file
    root owns (the clone, the virtual environment, wherever they lie) stays readable. A failure
    under CI, else a skip, when setpriv is missing or may not drop them (no CAP_SETPCAP)."""
    tool = shutil.which("setpriv")
    if tool is None:
        missing("setpriv (util-linux) is not installed: as root, the read-only folder test "
                "needs it to run the command without root's capabilities")
    prefix = [tool, "--bounding-set=-all", "--inh-caps=-all"]
    probe = subprocess.run([*prefix, "true"], capture_output=True, text=True, timeout=60)
    if probe.returncode != 0:
        missing(f"setpriv may not drop root's capabilities here ({probe.stderr.strip()})")
    return prefix


def test_a_folder_the_user_cannot_write_in_is_refused_in_one_line(tmp_path, capsys):
    """Refused before any GL work: one line naming the folder, exit status 2, nothing written.
    Root may write in any folder, so as root (as CI is) the command runs without root's
    capabilities, for which a read-only folder is read-only."""
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        if os.geteuid() != 0:
            assert os.access(locked, os.W_OK) is False, "a read-only folder is writable here"
            code = main(["run", "dejong", *SMALL, "--out", str(locked / "x.png")])
            err = capsys.readouterr().err
        else:
            result = subprocess.run([*without_capabilities(), sys.executable, "-m", "es2particles",
                                     "run", "dejong", *SMALL, "--out", str(locked / "x.png")],
                                    cwd=tmp_path, capture_output=True, text=True, timeout=120)
            code, err = result.returncode, result.stderr
        written = list(locked.iterdir())
    finally:
        locked.chmod(0o700)
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and str(locked) in lines[0] and "Traceback" not in err, err
    assert written == []


def test_a_failed_write_leaves_no_partial_file(tmp_path, monkeypatch):
    from es2particles.io import output

    def explode(self, data):
        with open(self, "wb") as handle:  # half a file, then the failure
            handle.write(data[: len(data) // 2])
        raise OSError("disk full")

    monkeypatch.setattr(Path, "write_bytes", explode)
    with pytest.raises(OSError):
        output.save_image(np.zeros((4, 4, 3), np.uint8), tmp_path / "x.png")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("shape", [(1, 1), (3, 5), (64, 96)])
def test_png_decodes_to_the_same_pixels(tmp_path, shape):
    from es2particles.io import output

    pixels = np.random.default_rng(1).integers(0, 256, (*shape, 3), dtype=np.uint8)
    path = output.save_image(pixels, tmp_path / "x.png")
    with Image.open(path) as image:
        assert image.mode == "RGB" and image.size == (shape[1], shape[0])
        assert np.array_equal(np.asarray(image), pixels)
    with pytest.raises(output.ParameterError, match=r"\(h, w, 3\) uint8"):
        output.encode_png(pixels.astype(np.float32))


@pytest.mark.gl
def test_collision_run_saves_all_quantities_and_plan_lists_its_passes(tmp_path, capsys):
    out, state = tmp_path / "c.png", tmp_path / "c.npz"
    assert main(["run", "collision", "--particles", "2048", "--size", "64x64", "--steps", "20",
                 "--shape", "circle+box", "--out", str(out), "--save-state", str(state)]) == 0
    saved = np.load(state)
    decoded = sorted(k for k in saved.files if k != "meta" and not k.startswith("texels."))
    assert decoded == ["life", "position", "velocity"]
    assert all(saved[k].shape == (2048, 2) for k in decoded)
    assert main(["plan", "collision", "--particles", "2048", "--shape", "capsule"]) == 0
    text = capsys.readouterr().out
    for line in ("1. velocity: collision.frag writes velocity",
                 "2. position: collision.frag writes position",
                 "3. life: collision.frag writes life; reads position (last step)",
                 "collision field: 256x256 cells", "field memory by format"):
        assert line in text, text


@pytest.mark.parametrize("arguments, message", [
    (["--shape", "hexagon"], "shape must be circle, box, capsule"),
    (["--lifetime", "-1,2"], "--lifetime MIN must be in [1e-06, inf], got -1"),
    (["--field-resolution", "4"], "--field-resolution must be in [8, 4096]"),
    (["--dt", "0"], "dt must be in"),
])
def test_collision_bad_input(tmp_path, capsys, arguments, message):
    out = tmp_path / "x.png"
    assert main(["run", "collision", "--particles", "64", "--size", "32x32", *arguments,
                 "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.gl
def test_the_program_exits_with_main_s_status_and_says_everything(tmp_path):
    """`python -m es2particles` leaves without the interpreter's teardown: its exit status, its
    last line and its file must still all be there, through pipes."""
    out = tmp_path / "a.png"
    ran = subprocess.run([sys.executable, "-m", "es2particles", "run", "dejong", *SMALL,
                          "--out", str(out)], capture_output=True, text=True)
    assert ran.returncode == 0 and ran.stdout.startswith(f"wrote {out}") and out.is_file()
    bad = subprocess.run([sys.executable, "-m", "es2particles", "run", "dejong", "--particles",
                          "0", "--out", str(tmp_path / "b.png")], capture_output=True, text=True)
    assert bad.returncode == 2
    assert bad.stderr.startswith("es2particles: error: --particles must be in [1, ")
    assert bad.stderr.endswith("], got 0\n") and bad.stderr.count("\n") == 1


def test_a_signal_inside_a_finalizer_interrupts_once_out_of_it():
    """SIGTERM landing while a finalizer runs (a GL object's __del__ in a collection) interrupts
    the command just after it: raised inside it, the KeyboardInterrupt was printed and swallowed,
    and a run went on to exit 0 under a traceback (the interrupt test, once in a suite)."""
    import os
    import signal
    import time

    from es2particles.cli import _terminate_as_interrupt

    class Dying:
        def __del__(self):
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(10000):  # the handler runs here, inside __del__
                pass

    restore = _terminate_as_interrupt()
    try:
        with pytest.raises(KeyboardInterrupt):
            dying = Dying()
            del dying
            time.sleep(1.0)
    finally:
        restore()


@pytest.mark.gl
def test_a_long_phase_is_said_once_it_takes_long(tmp_path, capsys, monkeypatch):
    """Issue 44: a 16M-particle run was silent for minutes outside its warm-up. A phase of a
    run still going after LONG_PHASE_SECONDS is said on one line (here writing the picture,
    made to take a second, against a bound lowered to 0.3 s); a phase that ends sooner, or a
    run refused, says nothing more than its own lines."""
    import time

    import es2particles.cli as cli
    import es2particles.io.output as output

    out, state = tmp_path / "a.png", tmp_path / "a.npz"
    args = ["run", "dejong", "--particles", "1024", "--size", "64x64"]
    assert main([*args, "--out", str(tmp_path / "b.png")]) == 0
    assert "es2particles:" not in capsys.readouterr().err
    write = output.save_image

    def slow_write(*a, **k):
        time.sleep(1.0)
        return write(*a, **k)
    monkeypatch.setattr(output, "save_image", slow_write)
    monkeypatch.setattr(cli, "LONG_PHASE_SECONDS", 0.3)
    assert main([*args, "--save-state", str(state), "--out", str(out)]) == 0
    said = [line.split(" (")[0] for line in capsys.readouterr().err.splitlines()]
    assert said.count(f"es2particles: writing {out}") == 1, said
    assert all(line.startswith("es2particles: ") for line in said), said
