"""Outputs that are safe against concurrent runs and interruptions (issue #28): the start-up
clean-up removes only temporaries whose owner is checked dead, two runs to one output both finish
with a whole file of one of them, an interrupted report leaves nothing, and a run's picture,
state and run file land together or not at all. Real processes throughout; no GL is mocked."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

from es2particles.io.output import FRAMES, PART, remove_leftovers, temporary_prefix

COMMAND = [sys.executable, "-m", "es2particles"]
SMALL = ["--particles", "1024", "--size", "64x64"]


def start(*args):
    """The command started with ``args``, its output and errors piped."""
    return subprocess.Popen([*COMMAND, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def finish(process, timeout=120):
    """(exit status, standard error) of ``process`` once it ends."""
    _, err = process.communicate(timeout=timeout)
    return process.returncode, err


def names(folder):
    return sorted(p.name for p in folder.iterdir())


def leftover(folder, out, pid, kind, mark=None):
    """A temporary of ``out`` in ``folder`` as process ``pid`` names one (``mark``: its mark
    changed into this), with a file inside where it is a frames folder; returns its path."""
    name = temporary_prefix(out, pid) + "abcd1234" + kind
    if mark is not None:
        name = mark(name)
    path = folder / name
    if kind == FRAMES:
        path.mkdir()
        (path / "000000.png").write_bytes(b"frame")
    else:
        path.write_bytes(b"half")
    return path


def test_the_clean_up_removes_only_temporaries_whose_owner_is_dead(tmp_path):
    """Owners are real processes: this test, a live child, a killed and reaped one (its mark
    taken while it lived, as a run's is), a killed one not yet reaped (a zombie)."""
    out = tmp_path / "o.png"
    alive = subprocess.Popen(["sleep", "30"])
    killed = subprocess.Popen(["sleep", "30"])
    zombie = subprocess.Popen(["sleep", "30"])
    try:
        kept = [leftover(tmp_path, out, os.getpid(), PART),  # this test's own
                leftover(tmp_path, out, alive.pid, PART),
                leftover(tmp_path, out, alive.pid, FRAMES)]
        dead = [leftover(tmp_path, out, killed.pid, PART),
                leftover(tmp_path, out, killed.pid, FRAMES),
                leftover(tmp_path, out, zombie.pid, PART)]
        # Another machine's run (another host, boot or PID namespace) cannot be checked: kept,
        # even with this dead PID. A live PID with another start time was reused: its owner is
        # dead.
        elsewhere = leftover(tmp_path, out, killed.pid, PART,
                             lambda n: n.replace(n.split(".")[4], "00000000"))
        start_time = temporary_prefix(out, alive.pid).split(".")[-2]
        reused = leftover(tmp_path, out, alive.pid, PART,
                          lambda n: n.replace(f".{start_time}.", f".{int(start_time) + 1}."))
        user = [tmp_path / ".o.png.backup.part", tmp_path / ".o.png.abc12345.part"]
        for path in user:
            path.write_bytes(b"mine")
        (tmp_path / ".o.png.x.frames").mkdir()
        killed.kill()
        killed.wait()
        zombie.kill()  # killed, not reaped: a zombie
        while open(f"/proc/{zombie.pid}/stat").read().rsplit(")", 1)[1].split()[0] != "Z":
            time.sleep(0.01)
        removed = remove_leftovers(out)
        assert sorted(removed) == sorted(p.name for p in dead + [reused])
        assert names(tmp_path) == sorted(p.name for p in kept + user + [elsewhere]
                                         + [tmp_path / ".o.png.x.frames"])
        assert (kept[2] / "000000.png").read_bytes() == b"frame"
    finally:
        for child in (alive, killed, zombie):
            child.kill()
            child.wait()


@pytest.mark.gl
def test_a_run_leaves_the_user_s_files_and_removes_a_dead_run_s(tmp_path):
    """A user's ``.o.png.backup.part`` and a ``.o.png.x.frames`` folder without a mark survive
    a still and an animation to o.png; a dead run's temporaries of o.png go."""
    out = tmp_path / "o.png"
    (tmp_path / ".o.png.backup.part").write_bytes(b"mine")
    (tmp_path / ".o.png.x.frames").mkdir()
    (tmp_path / ".o.png.x.frames" / "notes.txt").write_text("mine")
    killed = subprocess.Popen(["sleep", "30"])
    for kind in (PART, FRAMES):
        leftover(tmp_path, out, killed.pid, kind)
    killed.kill()
    killed.wait()
    status, err = finish(start("run", "dejong", *SMALL, "--out", str(out)))
    assert status == 0, err
    assert names(tmp_path) == [".o.png.backup.part", ".o.png.x.frames", "o.png"]
    leftover(tmp_path, out, killed.pid, FRAMES)  # an animation's writer cleans up too
    status, err = finish(start("run", "dejong", *SMALL, "--frames", "2", "--out", str(out)))
    assert status == 0, err
    assert names(tmp_path) == [".o.png.backup.part", ".o.png.x.frames", "o.png"]
    assert (tmp_path / ".o.png.backup.part").read_bytes() == b"mine"
    assert (tmp_path / ".o.png.x.frames" / "notes.txt").read_text() == "mine"


@pytest.mark.gl
@pytest.mark.slow
def test_two_runs_to_one_output_both_finish_and_one_of_them_wins(tmp_path):
    """The second run starts while the first one's frames folder is there (it once removed it,
    and the first run failed); both finish, and the output is a whole animation of one of them."""
    out = tmp_path / "o.webp"
    run = ["run", "dejong", "--particles", "65536", "--size", "128x128", "--out", str(out)]
    first = start(*run, "--frames", "150")
    deadline = time.monotonic() + 60
    while not any(n.endswith(FRAMES) for n in os.listdir(tmp_path)):
        assert first.poll() is None and time.monotonic() < deadline, finish(first)
        time.sleep(0.02)
    second = start(*run, "--frames", "20")
    second_status, second_err = finish(second)
    first_running = first.poll() is None  # the second ran wholly inside the first
    first_status, first_err = finish(first)
    assert (first_status, second_status) == (0, 0), first_err + second_err
    assert names(tmp_path) == ["o.webp"]
    with Image.open(out) as animation:
        frames = animation.n_frames
        for index in range(frames):
            animation.seek(index)
            animation.convert("RGB").load()  # every frame decodes: a whole file
    assert frames in (150, 20)
    if first_running:  # the last to finish wins
        assert frames == 150


@pytest.mark.gl
@pytest.mark.parametrize("case", ["new folder, SIGTERM", "the user's folder, SIGINT"])
def test_an_interrupted_report_leaves_nothing(tmp_path, case):
    out = tmp_path / "new" / "report"
    mine = tmp_path / "mine.txt"
    if "user" in case:
        out = tmp_path
        mine.write_text("mine")
    report = start("report", "--quick", "--out", str(out))
    deadline = time.monotonic() + 60
    while not out.is_dir():
        assert report.poll() is None and time.monotonic() < deadline, finish(report)
        time.sleep(0.02)
    time.sleep(0.5)
    report.send_signal(signal.SIGTERM if "SIGTERM" in case else signal.SIGINT)
    status, err = finish(report)
    assert status == 130 and err.endswith("es2particles: interrupted\n"), err
    assert names(tmp_path) == (["mine.txt"] if "user" in case else [])


def state_steps(path):
    with np.load(path) as state:
        return json.loads(str(state["meta"]))["steps_done"]


@pytest.mark.gl
@pytest.mark.slow
def test_a_run_s_picture_state_and_run_file_land_together_or_not_at_all(tmp_path):
    """SIGINT or SIGTERM at moments through a run with --save-state and --save-config: after
    it, the picture, the state and the run file are all this run's, or all as they were before
    (an earlier run's, or absent); the state loads and draws the picture."""
    run = ["run", "dejong", "--particles", "65536", "--size", "256x256"]

    def outputs(folder):
        return ["--out", str(folder / "p.png"), "--save-state", str(folder / "s.npz"),
                "--save-config", str(folder / "c.toml")]

    # The files of an earlier run (3 steps) and of the whole run (7 steps), to compare with.
    reference = {}
    for steps in (3, 7):
        folder = tmp_path / f"ref{steps}"
        began = time.monotonic()
        status, err = finish(start(*run, "--steps", str(steps), *outputs(folder)))
        took = time.monotonic() - began
        assert status == 0, err
        reference[steps] = {name: (folder / name).read_bytes() for name in ("p.png", "c.toml")}
    # The moments: halfway through the whole run's time (simulating), when each file's
    # temporary appears (writing; the picture's is there until the renames), and about when
    # it ends; each with and without an earlier run's files there, by SIGINT or SIGTERM.
    moments = [0.5, ".p.png.", ".s.npz.", ".c.toml.", 1.0]
    landed = tmp_path / "ref7"
    for trial, (moment, earlier) in enumerate((m, e) for m in moments for e in (False, True)):
        folder = tmp_path / f"trial{trial}"
        if earlier:
            status, err = finish(start(*run, "--steps", "3", *outputs(folder)))
            assert status == 0, err
        process = start(*run, "--steps", "7", *outputs(folder))
        if isinstance(moment, str):
            while process.poll() is None and not any(
                    n.startswith(moment) and n.endswith(PART)
                    for n in (os.listdir(folder) if folder.exists() else ())):
                time.sleep(0.0005)
        else:
            time.sleep(took * moment)
        process.send_signal(signal.SIGTERM if earlier else signal.SIGINT)
        status, err = finish(process)
        where = f"signal at {moment!r}, earlier files {earlier}: status {status}, {err!r}"
        # 130: the command's interrupt; a negative status: the signal came before its handlers
        assert status in (0, 130, -signal.SIGINT, -signal.SIGTERM), where
        present = names(folder) if folder.exists() else []
        if not present:
            assert not earlier, f"{where}: the earlier run's files were removed"
            continue
        assert present == ["c.toml", "p.png", "s.npz"], f"{where}: {present}"
        steps = state_steps(folder / "s.npz")
        assert steps in ((3, 7) if earlier else (7,)), f"{where}: the state of {steps} steps"
        for name, data in reference[steps].items():
            assert (folder / name).read_bytes() == data, f"{where}: {name} is not the {steps} " \
                                                         "steps run's, as the state is"
        if steps == 7:
            landed = folder
    # A state that landed beside its picture (a trial's, or else the whole run's) loads and
    # draws that picture.
    status, err = finish(start(*run, "--steps", "0", "--load-state", str(landed / "s.npz"),
                               "--out", str(tmp_path / "drawn.png")))
    assert status == 0, err
    assert (tmp_path / "drawn.png").read_bytes() == (landed / "p.png").read_bytes()
