"""Runs on a real Dask cluster (a 2-worker LocalCluster of processes, each with its own EGL
context): the same bytes as one process for stills drawn in shares and for animations, frames
kept and skipped on a second run, and clear errors. Shares are checked against numpy binning of
the float64 twin. A --scheduler address that fails, in each of its forms, and a cluster left
without a worker (a real scheduler, a real `dask worker` process killed mid-run) each end in one
line; the frames made are kept and the same command resumes."""

import json
import logging
import re
import signal
import subprocess
import sys
import time
from contextlib import contextmanager, nullcontext

import numpy as np
import pytest
from PIL import Image

from conftest import missing
from es2particles.cluster import tasks as cluster
from es2particles.cluster import shares
from es2particles.cli import build_parser, main, run_of
from es2particles.scenes.attractor import jitter
from es2particles.scenes.dejong import DeJong

try:
    import dask
    import distributed
except ImportError:
    missing("dask's distributed is not installed (the test extra: sh setup.sh test)")


def drawn_on_workers(test):
    """A test whose workers draw: each opens an EGL context (gl), and it takes seconds (slow).
    The others here need no GL: they fail before any task, or have no worker to run one."""
    return pytest.mark.slow(pytest.mark.gl(test))


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


@drawn_on_workers
def test_a_still_in_shares_on_two_local_workers_has_one_process_s_bytes(tmp_path, capsys):
    """2^22 + 1 particles: two shares (2^22 and 1), each with its own seed; --workers 2 starts
    its own LocalCluster."""
    command = ["run", "dejong", "--particles", str(shares.SHARE + 1), *SMALL, "--steps", "2"]
    assert main([*command, "--out", str(tmp_path / "one.png")]) == 0
    assert "in 2 shares" in capsys.readouterr().out
    assert main([*command, "--workers", "2", "--out", str(tmp_path / "two.png")]) == 0
    assert "on 2 local worker(s)" in capsys.readouterr().out
    assert (tmp_path / "one.png").read_bytes() == (tmp_path / "two.png").read_bytes()


@drawn_on_workers
def test_a_reseeded_still_in_shares_has_one_process_s_bytes(scheduler, tmp_path):
    command = ["run", "dejong", "--reseed", "--particles", str(2 * shares.SHARE), *SMALL,
               "--accumulate", "2"]
    assert main([*command, "--out", str(tmp_path / "one.png")]) == 0
    assert main([*command, "--scheduler", scheduler, "--out", str(tmp_path / "two.png")]) == 0
    assert (tmp_path / "one.png").read_bytes() == (tmp_path / "two.png").read_bytes()


@drawn_on_workers
@pytest.mark.parametrize("command", [
    ANIMATION,  # reseeded: a task a frame
    ["run", "fountain", "--particles", "2048", "--size", "96x96", "--frames", "5"],  # stateful
], ids=["reseeded", "stateful"])
def test_an_animation_on_the_cluster_has_one_process_s_bytes(scheduler, tmp_path, command):
    assert main([*command, "--out", str(tmp_path / "one.gif")]) == 0
    assert main([*command, "--scheduler", scheduler, "--out", str(tmp_path / "two.gif")]) == 0
    assert (tmp_path / "one.gif").read_bytes() == (tmp_path / "two.gif").read_bytes()
    assert not (tmp_path / "two.gif.frames").exists()  # the kept frames go once assembled


@drawn_on_workers
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
    (["--workers", "2", "--worker-timeout", "0"], "--worker-timeout must be in [1, 86400], got 0"),
    (["--workers", "2", "--worker-timeout", "soon"],
     "--worker-timeout must be a number, got 'soon'"),
    (["--worker-timeout", "5"], "--worker-timeout is for a run on a cluster: give --workers or "),
])
def test_cluster_options_are_checked_before_any_work(tmp_path, capsys, extra, message):
    out = tmp_path / "x.png"
    extra = [a.format(tmp=tmp_path) for a in extra]
    assert main(["run", "dejong", *SMALL, *extra, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


# -- a --scheduler that fails, and a cluster without workers -----------------------------------

STILL = ["run", "dejong", *SMALL, "--particles", "1024"]
CONNECT_TIMEOUT = 2  # s: Dask's connect timeout in these tests (distributed.comm.timeouts.connect)


def one_error_line(err):
    """The one line of stderr that says the error (progress lines may come before it): no
    traceback, and nothing after it."""
    lines = err.strip().splitlines()
    assert "Traceback" not in err and lines and lines[-1].startswith("es2particles: error: "), err
    assert sum(line.startswith("es2particles: error") for line in lines) == 1, err
    assert all(line.startswith("frame tasks: ") for line in lines[:-1]), err  # only progress
    return lines[-1]


@contextmanager
def http_server(folder):
    """A real web server (python -m http.server) on a free port: not a Dask scheduler."""
    server = subprocess.Popen([sys.executable, "-u", "-m", "http.server", "0", "--bind",
                               "127.0.0.1", "--directory", str(folder)],
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        port = re.search(r"port (\d+)", server.stdout.readline()).group(1)
        yield f"127.0.0.1:{port}"
    finally:
        server.kill()
        server.wait()


NO_ANSWER = f"no Dask scheduler answered in {CONNECT_TIMEOUT} s"


@pytest.mark.slow
@pytest.mark.parametrize("address, says", [
    # Nothing listens on port 1: '(Connection refused)' follows where Dask's last try said so
    # (one cut short by the timeout says nothing).
    ("tcp://127.0.0.1:1", NO_ANSWER),
    ("127.0.0.1:1", NO_ANSWER),  # no scheme: tcp
    ("ws://127.0.0.1:1", NO_ANSWER),
    ("wss://127.0.0.1:1", NO_ANSWER),
    ("tls://127.0.0.1:1", "tls:// needs the client's certificates in Dask's configuration"),
    ("inproc://x", "inproc:// reaches a scheduler in the same process only"),
    ("ucx://127.0.0.1:1", "Dask cannot make ucx:// connections here"),
    ("tcp://no-such-host.invalid:8786", "host 'no-such-host.invalid' is not known"),
    ("tcp://127.0.0.1:99999", "port 99999 is out of range: a port is 1 to 65535"),
    ("tcp://:8786", "no host: give the scheduler's, e.g. tcp://host:8786"),
    ("tcp://127.0.0.1", "not host:port (missing port number"),
    ("::::", "not host:port (invalid address '::::'"),
    ("", "no address: give the scheduler's, e.g. tcp://host:8786"),
    ("http://127.0.0.1:8786", "unknown scheme 'http': Dask knows inproc://, tcp://"),
    ("tcp://{web}", "it took the connection but gave no Dask handshake in"),
    ("ws://{web}", "no Dask websocket there (Non-websocket response): not a Dask scheduler"),
])
def test_every_scheduler_address_that_fails_is_one_line(tmp_path, capfd, address, says):
    """Each form of a --scheduler address that fails: exit status 2 and one line of stderr
    naming the address and what happened, within Dask's connect timeout (plus the handshake's
    margin for a web server, which Dask alone would wait on forever); nothing written."""
    out = tmp_path / "out" / "x.webp"
    out.parent.mkdir()
    with http_server(tmp_path / "out") if "{web}" in address else nullcontext() as web:
        address = address.format(web=web)
        start = time.monotonic()
        with dask.config.set({"distributed.comm.timeouts.connect": f"{CONNECT_TIMEOUT}s"}):
            assert main([*ANIMATION, "--scheduler", address, "--out", str(out)]) == 2
        elapsed = time.monotonic() - start
    err = capfd.readouterr().err
    assert one_error_line(err) == err.strip()
    assert err.startswith(f"es2particles: error: --scheduler {address!r}: {says}"), err
    assert elapsed < CONNECT_TIMEOUT + cluster.HANDSHAKE_MARGIN + 5, elapsed
    assert list(out.parent.iterdir()) == []


@pytest.mark.slow
def test_a_scheduler_address_that_fails_is_one_line_from_the_command(tmp_path):
    """The installed command, as a user runs it: tls:// without certificates ended in a
    51-line traceback."""
    done = subprocess.run([sys.executable, "-m", "es2particles", *STILL, "--scheduler",
                           "tls://127.0.0.1:1", "--out", str(tmp_path / "x.png")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and done.stderr.startswith(
        "es2particles: error: --scheduler 'tls://127.0.0.1:1': tls:// needs"), done.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.fixture
def bare_scheduler():
    """A real Dask scheduler with no worker (a LocalCluster of none), its dashboard on a free
    port (None is Dask's default, 8787, which the module's cluster may hold)."""
    with distributed.LocalCluster(n_workers=0, scheduler_port=0, dashboard_address=":0",
                                  silence_logs=logging.ERROR) as local:
        yield local


@pytest.mark.slow
@pytest.mark.parametrize("command, what", [
    (STILL, "1 of 1 tasks"),
    ([*STILL, "--particles", str(shares.SHARE + 1)], "2 of 2 share groups"),
    (ANIMATION, "4 of 4 frame tasks"),  # 5 frames in 4 runs (a few a worker)
], ids=["still", "shares", "animation"])
def test_a_cluster_with_no_worker_ends_the_run_in_one_line(bare_scheduler, tmp_path, capfd,
                                                           command, what):
    suffix = ".gif" if "--frames" in command else ".png"
    out = tmp_path / f"x{suffix}"
    start = time.monotonic()
    assert main([*command, "--scheduler", bare_scheduler.scheduler_address,
                 "--worker-timeout", "1", "--out", str(out)]) == 2
    elapsed = time.monotonic() - start
    line = one_error_line(capfd.readouterr().err)
    assert (f"no worker on the cluster at {bare_scheduler.scheduler_address} for 1 s "
            f"(--worker-timeout) with ") in line and what in line, line
    assert 1 <= elapsed < 10, elapsed
    assert not out.exists()
    if suffix == ".gif":  # the folder for the frames stays, for the same command to resume
        assert line.endswith(f"0 of 5 frames are kept in {out}.frames: the same command again "
                             "makes only the others"), line
        assert [p.name for p in (tmp_path / "x.gif.frames").iterdir()] == ["manifest.json"]
    else:
        assert line.endswith(f"nothing was written to {out}"), line
        assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_an_interrupt_under_a_cluster_says_which_frames_are_kept(bare_scheduler, tmp_path):
    """Issue 44, item 6: Ctrl-C while an animation's frames are made on a cluster keeps the
    frames folder for the same command to resume, and says so: how many frames and where, then
    the one line of any interrupt, exit 130, and no output file."""
    out = tmp_path / "x.gif"
    run = subprocess.Popen([sys.executable, "-m", "es2particles", *ANIMATION, "--scheduler",
                            bare_scheduler.scheduler_address, "--worker-timeout", "60",
                            "--out", str(out)], stdout=subprocess.DEVNULL,
                           stderr=subprocess.PIPE, text=True)
    manifest = tmp_path / "x.gif.frames" / "manifest.json"
    deadline = time.monotonic() + 60
    while not manifest.exists() and run.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)  # waiting for a worker now
    run.send_signal(signal.SIGINT)
    err = run.communicate(timeout=60)[1]
    assert run.returncode == 130, (run.returncode, err)
    assert err.splitlines()[-2:] == [
        f"es2particles: 0 of 5 frames are kept in {out}.frames: the same command again makes "
        "only the others", "es2particles: interrupted"], err
    assert not out.exists() and manifest.exists()


@contextmanager
def dask_worker(address, folder):
    """A real worker process, as the docs start one (`dask worker ADDRESS --nthreads 1`), with
    no nanny to bring it back when it is killed; its files under ``folder``."""
    worker = subprocess.Popen([sys.executable, "-m", "dask", "worker", address, "--nthreads",
                               "1", "--no-nanny", "--no-dashboard", "--host", "127.0.0.1",
                               "--local-directory", str(folder)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=folder)
    try:
        yield worker
    finally:
        worker.kill()
        worker.wait()


def wait_for(condition, what, seconds=60):
    end = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < end, f"no {what} in {seconds} s"
        time.sleep(0.01)


@drawn_on_workers
def test_a_worker_killed_mid_run_ends_it_in_one_line_and_the_same_command_resumes(
        bare_scheduler, tmp_path):
    """An external cluster whose only worker dies after the first frames land: the run says so
    in one line once --worker-timeout (3 s) has passed with no worker, exit status 2, the frames
    made kept in OUT.frames/; run again with a new worker, the same command makes the others and
    writes one process's bytes. The worker's own address is refused as such."""
    address = bare_scheduler.scheduler_address
    scheduler = bare_scheduler.scheduler
    # Frames heavy enough on llvmpipe (~0.1 s each, 4 tasks of 6) that the worker is still busy
    # when it is killed, 10 ms after the first frames land.
    command = ["run", "dejong", "--reseed", "--particles", str(2 ** 17), "--size", "128x128",
               "--frames", "24", "--animate-to", "1.5,-2.2,2.3,-2.0"]
    out = tmp_path / "anim.gif"
    folder = tmp_path / "anim.gif.frames"
    argv = [sys.executable, "-m", "es2particles", *command, "--scheduler", address,
            "--worker-timeout", "3", "--out", str(out)]
    (tmp_path / "dask").mkdir()
    with dask_worker(address, tmp_path / "dask") as worker:
        wait_for(lambda: scheduler.workers, "worker on the scheduler")
        refused = subprocess.run([sys.executable, "-m", "es2particles", *command, "--scheduler",
                                  next(iter(scheduler.workers)), "--out", str(out)],
                                 capture_output=True, text=True, timeout=120)
        assert refused.returncode == 2 and "that is a Dask worker, not the scheduler" in \
            one_error_line(refused.stderr)
        run = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        wait_for(lambda: any(folder.glob("*.png")) or run.poll() is not None, "frame")
        worker.send_signal(signal.SIGKILL)
        killed = time.monotonic()
        _, err = run.communicate(timeout=120)
        ended = time.monotonic() - killed
    assert run.returncode == 2, err
    line = one_error_line(err)
    kept = sorted(p.name for p in folder.glob("*.png"))
    assert 1 <= len(kept) < 24, (kept, line)
    assert line == (f"es2particles: error: no worker on the cluster at {address} for 3 s "
                    f"(--worker-timeout) with {line.split(' with ')[1].split(' of ')[0]} of 4 "
                    f"frame tasks left; {len(kept)} of 24 frames are kept in {folder}: the same "
                    "command again makes only the others"), line
    assert 3 <= ended < 15, ended  # the timeout, a look every 0.5 s, the process's end
    assert not out.exists() and (folder / "manifest.json").is_file()

    (tmp_path / "dask2").mkdir()
    with dask_worker(address, tmp_path / "dask2"):
        wait_for(lambda: scheduler.workers, "worker on the scheduler")
        resumed = subprocess.run(argv, capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    assert not folder.exists()
    assert main([*command, "--out", str(tmp_path / "one.gif")]) == 0
    assert out.read_bytes() == (tmp_path / "one.gif").read_bytes()
