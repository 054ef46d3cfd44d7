"""`es2particles run` on a Dask cluster: ``--workers N`` starts a LocalCluster of N processes,
``--scheduler ADDRESS`` joins a running one (``pip install "es2particles[distributed]"``).

Every task gets the run description (``run.py``: the scene, its options, the frame
settings), so a worker builds exactly the pipeline one process would; nothing here reads argv.
Each worker process holds one EGL context for its life (made at its first task; the EGL device
``worker number mod ES2PARTICLES_DEVICES`` where that is set on a machine with several GPUs);
start remote workers with one thread each (``dask worker ADDRESS --nthreads 1``): a GL context
is current in one thread.

- **A still** of a counted scene with more than ``shares.SHARE`` particles: tasks each sum the
  counts of a group of consecutive shares (float64, exact) and return them; the client adds the
  groups as they come (exact, so in any order) and one last task tone-maps the sum. Any other still
  is one task. Either way the PNG has the bytes one process writes.
- **An animation**: a reseeded scene's frames need nothing before them, so they are cut into a
  few runs a worker, each task drawing its own frames alone; a stateful scene's frames need the
  steps (and frames) before them, so they are cut into one contiguous run per worker, each task
  stepping and drawing from the start and handing back only its own frames. Tasks
  return PNG bytes; the client keeps each frame in ``OUT.frames/`` as it arrives, so a run cut
  short and started again skips the frames it has, then assembles the animation from the folder
  and removes it.
"""

import asyncio
import json
import logging
import os
import shutil
import sys
import threading
import zlib
from pathlib import Path

import numpy as np

from ..errors import Es2ParticlesError, ParameterError
from ..frame.settings import frames_independent

_local = threading.local()
GROUPS_PER_WORKER = 4  # tasks a worker (share groups, runs of frames): the load evens out, and
# each task's set-up (~25 ms) and return are paid a few times, not once a frame or share


def available():
    """None, or the sentence saying how to get the extra."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        return ('--workers and --scheduler need Dask\'s distributed: pip install '
                '"es2particles[distributed]"')
    return None


# -- on the workers ----------------------------------------------------------------------------

def worker_context(backend=None):
    """This worker thread's GL context on ``backend`` (see open_context), made at its first
    task and kept."""
    contexts = _local.__dict__.setdefault("contexts", {})
    ctx = contexts.get(backend)
    if ctx is None:
        from ..gl.egl import open_context

        device = None
        devices = int(os.environ.get("ES2PARTICLES_DEVICES", "0") or 0)
        if devices > 1:
            from distributed import get_worker

            name = get_worker().name  # 0, 1, ... in a LocalCluster; a string may be given
            device = (name if isinstance(name, int) else zlib.crc32(str(name).encode())) % devices
        ctx = contexts[backend] = open_context(device=device, backend=backend)
    ctx.make_current()
    return ctx


def shares_task(run, sizes, shares):
    """The float64 sum of the counts of ``shares`` (see shares.py)."""
    from .shares import sum_counts

    return sum_counts(worker_context(run.backend), run, sizes, shares)


def tone_map_task(run, total, particles):
    """PNG bytes of summed counts, tone-mapped."""
    from ..io.output import encode_png
    from .shares import tone_map

    return encode_png(tone_map(worker_context(run.backend), run, total, particles))


def frames_task(run, wanted):
    """{frame: PNG bytes} of the frames ``wanted`` of ``run``: the pipeline's frame loop with
    those frames wanted (a stateful scene runs every step and frame before them, as one process
    does; a reseeded scene draws the wanted frames alone)."""
    from ..io.output import encode_png

    scene, pipeline = run.pipeline(worker_context(run.backend))
    with pipeline:
        return {frame: encode_png(pipeline.image())
                for frame in pipeline.frames(run.frames, run.steps_per_frame, wanted)}


# -- on the client -----------------------------------------------------------------------------

HOST_PORT_SCHEMES = ("tcp", "tls", "ws", "wss")  # Dask's schemes whose addresses are host:port
HANDSHAKE_MARGIN = 5.0  # s past Dask's connect timeout for the handshake (see ask_identity)
WORKER_TIMEOUT = 60.0  # s a cluster may have no worker while tasks wait (--worker-timeout)
MAX_WORKER_TIMEOUT = 86400  # s: a day
WATCH = 0.5  # s between looks at the cluster's workers while no task finishes


class ClusterError(Es2ParticlesError):
    """The cluster stopped serving the run: it had no worker for --worker-timeout seconds, or
    workers kept dying on a task."""


class OneLineRecords(logging.Filter):
    """Dask's client logs a lost scheduler as records with tracebacks, some with no message at
    all, before the run's own last line says what happened: each record keeps its first line
    and loses its traceback, and one with no words goes."""

    def filter(self, record):
        lines = record.getMessage().strip().splitlines()
        record.msg, record.args = (lines[0] if lines else ""), ()
        record.exc_info = record.exc_text = record.stack_info = None
        return bool(lines)


ONE_LINE_RECORDS = OneLineRecords()


def connect(workers=None, scheduler=None):
    """A Dask client: of a new LocalCluster of ``workers`` single-thread processes, or of the
    scheduler at address ``scheduler`` (``join``). The caller closes it (``close``: the
    LocalCluster with it). While it is open, Dask's client logs one line a record."""
    from distributed import Client, LocalCluster

    logging.getLogger("distributed.client").addFilter(ONE_LINE_RECORDS)
    if scheduler is not None:
        return join(scheduler)
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(cluster)
    client.cluster_to_close = cluster
    return client


def join(address):
    """A client of the running scheduler at ``address``. The address is checked first
    (``check_address``), then whatever answers there is asked who it is (``ask_identity``),
    within Dask's connect timeout (``distributed.comm.timeouts.connect``: 30 s unless configured);
    whatever stops it is a ParameterError naming the address and what happened."""
    import dask
    from dask.utils import parse_timedelta
    from distributed import Client
    from distributed.security import Security

    timeout = parse_timedelta(dask.config.get("distributed.comm.timeouts.connect"), "s")
    security = Security()  # Dask's configuration: the certificates tls:// needs
    scheme = check_address(address)
    try:
        connection = security.get_connection_args("client")
    except OSError as error:  # a certificate file named there is missing or unreadable
        raise _refused(address, f"Dask's TLS configuration cannot be read ({error})") from None
    if scheme == "tls" and connection["ssl_context"] is None:
        raise _refused(address, "tls:// needs the client's certificates in Dask's configuration: "
                                "distributed.comm.tls.ca-file, distributed.comm.tls.client.cert "
                                "and distributed.comm.tls.client.key (or the variables "
                                "DASK_DISTRIBUTED__COMM__TLS__CA_FILE, ...)")
    ask_identity(address, connection, timeout)
    try:
        return Client(address, timeout=timeout, security=security)
    except (OSError, TimeoutError, ValueError, TypeError) as error:  # gone since it answered
        raise _refused(address, f"the scheduler answered, then Dask could not connect"
                                f"{_because(error)}") from None


def _refused(address, why):
    return ParameterError(f"--scheduler {address!r}: {why}")


def check_address(address):
    """The scheme of scheduler address ``address``, once it is one Dask can try: a known scheme
    whose connections Dask can make here, and for tcp, tls, ws and wss a host that resolves and a
    port in 1..65535. Else a ParameterError saying what is wrong, before any waiting."""
    import socket

    from distributed.comm import parse_address, parse_host_port
    from distributed.comm.registry import backends, get_backend

    if not address.strip():
        raise _refused(address, "no address: give the scheduler's, e.g. tcp://host:8786")
    scheme, location = parse_address(address)  # no scheme: tcp, as Dask reads it
    try:
        backend = get_backend(scheme)
    except ValueError:
        raise _refused(address, f"unknown scheme {scheme!r}: Dask knows "
                                f"{', '.join(s + '://' for s in sorted(backends))}") from None
    if scheme == "inproc":
        raise _refused(address, "inproc:// reaches a scheduler in the same process only: give "
                                "the scheduler's tcp:// address")
    try:
        backend.get_connector()
    except (TypeError, ImportError) as error:  # a backend without its package (ucx)
        hint = (": Dask's ucx:// needs the distributed-ucxx package" if scheme == "ucx" else "")
        raise _refused(address, f"Dask cannot make {scheme}:// connections here"
                                f"{_because(error)}{hint}") from None
    if scheme not in HOST_PORT_SCHEMES:
        return scheme
    try:
        host, port = parse_host_port(location)
    except ValueError as error:
        raise _refused(address, f"not host:port ({error})") from None
    if not 1 <= port <= 65535:
        raise _refused(address, f"port {port} is out of range: a port is 1 to 65535")
    if not host:
        raise _refused(address, "no host: give the scheduler's, e.g. tcp://host:8786")
    try:
        socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError) as error:
        raise _refused(address, f"host {host!r} is not known{_because(error)}") from None
    return scheme


def ask_identity(address, connection, timeout):
    """Connect to ``address`` and ask what answers there who it is; a ParameterError saying what
    happened unless it is a Dask scheduler. ``connection``: Dask's connection arguments (TLS);
    ``timeout``: Dask's connect timeout, s."""
    from distributed.comm import connect
    from distributed.comm.core import CommClosedError
    from tornado.websocket import WebSocketError

    async def identity():
        comm = await connect(address, timeout=timeout, **connection)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    # Dask's connect retries for ``timeout`` and then says why; its handshake has no limit of its
    # own (an HTTP server takes the connection and waits for a request line forever): the margin
    # bounds that alone.
    limit = timeout + HANDSHAKE_MARGIN
    not_dask = ("not a Dask scheduler (a scheduler listens on 8786 unless told otherwise; 8787 "
                "is its dashboard's web page)")
    try:
        answer = asyncio.run(asyncio.wait_for(identity(), limit))
    except (asyncio.TimeoutError, TimeoutError):
        raise _refused(address, f"it took the connection but gave no Dask handshake in "
                                f"{limit:g} s: {not_dask}") from None
    except CommClosedError as error:  # connected, then closed at the handshake
        raise _refused(address, f"it closed the connection at Dask's handshake"
                                f"{_because(error)}: {not_dask}") from None
    except OSError as error:
        raise _refused(address, f"no Dask scheduler answered in {timeout:g} s"
                                f"{_because(error)}") from None
    except WebSocketError as error:
        raise _refused(address, f"no Dask websocket there{_because(error)}: {not_dask}") from None
    except (ValueError, TypeError, ImportError) as error:
        raise _refused(address, f"Dask could not connect{_because(error)}") from None
    kind = answer.get("type") if isinstance(answer, dict) else None
    if kind in ("Worker", "Nanny"):
        raise _refused(address, f"that is a Dask {kind.lower()}, not the scheduler: give the "
                                "address the scheduler prints at its start")
    if not isinstance(answer, dict):
        raise _refused(address, f"it answered, but not as a Dask scheduler: {not_dask}")


def _because(error):
    """What stopped a connection, in the words of its innermost cause: ' (Connection refused)';
    '' where the last try ran out of time."""
    while error.__cause__ is not None and not isinstance(error.__cause__, asyncio.CancelledError):
        error = error.__cause__
    if isinstance(error, (TimeoutError, asyncio.TimeoutError)):
        return ""
    text = error.strerror if isinstance(error, OSError) and error.strerror else str(error)
    return f" ({' '.join(text.split()) or type(error).__name__})"


def close(client):
    cluster = getattr(client, "cluster_to_close", None)
    client.close()
    if cluster is not None:
        cluster.close()
    logging.getLogger("distributed.client").removeFilter(ONE_LINE_RECORDS)


def workers(client):
    return max(1, len(client.scheduler_info()["workers"]))


def finished(client, futures, what, kept, worker_timeout=WORKER_TIMEOUT):
    """Yield each of ``futures`` (``what`` they are: "frame tasks") as it finishes, watching the
    cluster while none does. Where it has had no worker for ``worker_timeout`` s while some are
    left (its last worker died, or none ever came), workers kept dying on one of them, or Dask
    cancelled them (the scheduler lost), raise a ClusterError saying so and what was kept
    (``kept()``, a sentence)."""
    import time

    from distributed import KilledWorker, TimeoutError, wait
    from distributed import client as dask_client

    cancelled = getattr(dask_client, "FuturesCancelledError", ())  # raised by newer Dask
    address = client.scheduler.address
    left = list(futures)
    alone_since = None  # when the cluster was first seen with no worker
    while left:
        try:
            done, left = wait(left, timeout=WATCH, return_when="FIRST_COMPLETED")
        except TimeoutError:
            done = ()
        except cancelled as error:
            reasons = sorted({str(g.reason) for g in getattr(error, "error_groups", ())})
            raise ClusterError(f"Dask cancelled the {what} ({', '.join(reasons) or 'no reason'}"
                               f"): the scheduler at {address} is gone or was restarted; "
                               f"{kept()}") from None
        for future in done:
            if future.cancelled():  # how older Dask says it
                raise ClusterError(f"Dask cancelled the {what}: the scheduler at {address} is "
                                   f"gone or was restarted; {kept()}")
            if future.status == "error" and isinstance(future.exception(), KilledWorker):
                raise ClusterError(f"workers kept dying on one of the {what} (Dask gave it up "
                                   f"after distributed.scheduler.allowed-failures deaths; their "
                                   f"logs say why); {kept()}")
            yield future
        if done or not left:
            alone_since = None
            continue
        if client.nthreads():
            alone_since = None
        elif alone_since is None:
            alone_since = time.monotonic()
        elif time.monotonic() - alone_since >= worker_timeout:
            raise ClusterError(f"no worker on the cluster at {address} for {worker_timeout:g} s "
                               f"(--worker-timeout) with {len(left)} of {len(futures)} {what} "
                               f"left; {kept()}")


def still(client, run, out, sizes, worker_timeout=WORKER_TIMEOUT):
    """Write the still of ``run`` to ``out`` from the cluster; ``sizes``: its shares'
    particles (``shares.share_sizes``), None for one pipeline. ``worker_timeout``: see
    ``finished``."""
    from distributed import TimeoutError

    from ..io.output import write_atomic
    from ..io.progress import progress

    def result(future, what):
        return next(finished(client, [future], what, nothing, worker_timeout)).result()

    def nothing():
        return f"nothing was written to {out}"

    if sizes is None:  # one pipeline: the frame task of a one-frame animation is the still
        data = result(client.submit(frames_task, run, [0], pure=False), "tasks")[0]
    else:
        groups = np.array_split(np.arange(len(sizes)),
                                min(len(sizes), GROUPS_PER_WORKER * workers(client)))
        futures = [client.submit(shares_task, run, sizes, group.tolist(), pure=False)
                   for group in groups]
        total = None
        done = finished(client, futures, "share groups", nothing, worker_timeout)
        for future in progress(done, len(futures), "share groups", unit="task"):
            counts = future.result()
            total = counts if total is None else total + counts  # exact: whole numbers < 2^53
            future.release()
        try:  # scatter waits for a worker to hold the sum
            total = client.scatter(total, timeout=worker_timeout)
        except TimeoutError:
            raise ClusterError(f"no worker on the cluster at {client.scheduler.address} for "
                               f"{worker_timeout:g} s (--worker-timeout) to take the summed "
                               f"shares; {nothing()}") from None
        data = result(client.submit(tone_map_task, run, total, sum(sizes), pure=False),
                      "tasks")
    return write_atomic(out, lambda tmp: Path(tmp).write_bytes(data))


def manifest(run):
    """What the frames of a run depend on: the whole run description."""
    from dataclasses import asdict

    described = {"scene": run.scene, "options": dict(sorted(run.options.items())),
                 "settings": {k: repr(v) for k, v in asdict(run.settings).items()},
                 "frames": run.frames, "steps_per_frame": run.steps_per_frame, "fps": run.fps,
                 "backend": run.backend}
    return json.loads(json.dumps(described, default=str))  # as it reads back from the file


def animation(client, run, out, worker_timeout=WORKER_TIMEOUT):
    """Make the frames of ``run`` on the cluster (those not already in ``OUT.frames/``), then
    assemble them into ``out`` and remove the folder. ``worker_timeout``: see ``finished``; the
    frames made stay in the folder for the next run of the same command."""
    from PIL import Image

    from ..io.output import AnimationWriter, check_folder, write_atomic
    from ..io.progress import progress

    folder = out.with_name(out.name + ".frames")
    if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
        raise ParameterError(f"{folder} (where the frames are kept) must be a folder, not a link "
                             "or a file")
    check_folder(folder.parent, "--out")
    record = folder / "manifest.json"
    wanted = manifest(run)
    if folder.is_dir():
        kept = json.loads(record.read_text()) if record.is_file() else None
        if kept != wanted:
            raise ParameterError(f"{folder} holds frames of another command (its manifest.json "
                                 "differs from this one's options): remove it, or run that command "
                                 "again to finish it")
    else:
        folder.mkdir()
        write_atomic(record, lambda tmp: Path(tmp).write_text(json.dumps(wanted, indent=1)))
    frames = run.frames
    path = [folder / f"{frame:06d}.png" for frame in range(frames)]
    missing = [frame for frame in range(frames) if not path[frame].is_file()]
    if missing:
        scene = run.make_scene()
        # Reseeded frames need nothing before them: a few runs a worker even out the load. A
        # stateful run (or one with trails) steps from the start, so one run a worker (each
        # catches up alone).
        parts = (GROUPS_PER_WORKER * workers(client) if frames_independent(scene, run.settings)
                 else workers(client))
        parts = [r.tolist() for r in np.array_split(missing, min(len(missing), parts))]
        futures = [client.submit(frames_task, run, part, pure=False) for part in parts]

        def kept():
            made = sum(p.is_file() for p in path)
            return (f"{made} of {frames} frames are kept in {folder}: the same command again "
                    "makes only the others")

        done = finished(client, futures, "frame tasks", kept, worker_timeout)
        try:
            for future in progress(done, len(futures), "frame tasks", unit="task"):
                for frame, data in future.result().items():
                    write_atomic(path[frame], lambda tmp, data=data: Path(tmp).write_bytes(data))
                future.release()
        except KeyboardInterrupt:  # the frames made stay for the next run: say so, and where
            print(f"es2particles: {kept()}", file=sys.stderr)
            raise
    if out.suffix.lower() != ".mp4":
        print(f"es2particles: assembling {frames} frames into {out}", file=sys.stderr)
    with AnimationWriter(out, run.fps) as writer:
        for frame in range(frames):
            with Image.open(path[frame], formats=["PNG"]) as image:  # our frames: PNG only
                writer.add(np.asarray(image.convert("RGB")))
        writer.close()
    shutil.rmtree(folder)
    return out
