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

import json
import os
import shutil
import sys
import threading
import zlib
from pathlib import Path

import numpy as np

from ..errors import ParameterError

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

def worker_context():
    """This worker thread's GL context, made at its first task and kept."""
    ctx = getattr(_local, "ctx", None)
    if ctx is None:
        from ..gl.egl import open_context

        device = None
        devices = int(os.environ.get("ES2PARTICLES_DEVICES", "0") or 0)
        if devices > 1:
            from distributed import get_worker

            name = get_worker().name  # 0, 1, ... in a LocalCluster; a string may be given
            device = (name if isinstance(name, int) else zlib.crc32(str(name).encode())) % devices
        ctx = _local.ctx = open_context(device=device)
    ctx.make_current()
    return ctx


def shares_task(run, sizes, shares):
    """The float64 sum of the counts of ``shares`` (see shares.py)."""
    from .shares import sum_counts

    return sum_counts(worker_context(), run, sizes, shares)


def tone_map_task(run, total, particles):
    """PNG bytes of summed counts, tone-mapped."""
    from ..io.output import encode_png
    from .shares import tone_map

    return encode_png(tone_map(worker_context(), run, total, particles))


def frames_task(run, wanted):
    """{frame: PNG bytes} of the frames ``wanted`` of ``run``: the pipeline's frame loop with
    those frames wanted (a stateful scene runs every step and frame before them, as one process
    does; a reseeded scene draws the wanted frames alone)."""
    from ..io.output import encode_png

    scene, pipeline = run.pipeline(worker_context())
    with pipeline:
        return {frame: encode_png(pipeline.image())
                for frame in pipeline.frames(run.frames, run.steps_per_frame, wanted)}


# -- on the client -----------------------------------------------------------------------------

def connect(workers=None, scheduler=None):
    """A Dask client: of a new LocalCluster of ``workers`` single-thread processes, or of the
    scheduler at address ``scheduler``. The caller closes it (and the LocalCluster with it)."""
    import logging

    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            return Client(scheduler, timeout="20s")
        except (OSError, TimeoutError, ValueError) as error:
            raise ParameterError(f"--scheduler {scheduler!r}: no Dask scheduler answered "
                                 f"({error})") from None
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(cluster)
    client.cluster_to_close = cluster
    return client


def close(client):
    cluster = getattr(client, "cluster_to_close", None)
    client.close()
    if cluster is not None:
        cluster.close()


def workers(client):
    return max(1, len(client.scheduler_info()["workers"]))


def still(client, run, out, sizes):
    """Write the still of ``run`` to ``out`` from the cluster; ``sizes``: its shares'
    particles (``shares.share_sizes``), None for one pipeline."""
    from distributed import as_completed

    from ..io.output import write_atomic
    from ..io.progress import progress

    if sizes is None:  # one pipeline: the frame task of a one-frame animation is the still
        data = client.submit(frames_task, run, [0], pure=False).result()[0]
    else:
        groups = np.array_split(np.arange(len(sizes)),
                                min(len(sizes), GROUPS_PER_WORKER * workers(client)))
        futures = [client.submit(shares_task, run, sizes, group.tolist(), pure=False)
                   for group in groups]
        total = None
        for future in progress(as_completed(futures), len(futures), "share groups", unit="task"):
            counts = future.result()
            total = counts if total is None else total + counts  # exact: whole numbers < 2^53
            future.release()
        data = client.submit(tone_map_task, run, client.scatter(total), sum(sizes),
                             pure=False).result()
    return write_atomic(out, lambda tmp: Path(tmp).write_bytes(data))


def manifest(run):
    """What the frames of a run depend on: the whole run description."""
    from dataclasses import asdict

    described = {"scene": run.scene, "options": dict(sorted(run.options.items())),
                 "settings": {k: repr(v) for k, v in asdict(run.settings).items()},
                 "frames": run.frames, "steps_per_frame": run.steps_per_frame, "fps": run.fps}
    return json.loads(json.dumps(described, default=str))  # as it reads back from the file


def animation(client, run, out):
    """Make the frames of ``run`` on the cluster (those not already in ``OUT.frames/``), then
    assemble them into ``out`` and remove the folder."""
    from distributed import as_completed
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
        # stateful run steps from the start, so one run a worker (each catches up alone).
        parts = GROUPS_PER_WORKER * workers(client) if scene.stateless else workers(client)
        parts = [r.tolist() for r in np.array_split(missing, min(len(missing), parts))]
        futures = [client.submit(frames_task, run, part, pure=False) for part in parts]
        done = progress(as_completed(futures), len(futures), "frame tasks", unit="task")
        for future in done:
            for frame, data in future.result().items():
                write_atomic(path[frame], lambda tmp, data=data: Path(tmp).write_bytes(data))
            future.release()
    if out.suffix.lower() != ".mp4":
        print(f"es2particles: assembling {frames} frames into {out}", file=sys.stderr)
    with AnimationWriter(out, run.fps) as writer:
        for frame in range(frames):
            with Image.open(path[frame]) as image:
                writer.add(np.asarray(image.convert("RGB")))
        writer.close()
    shutil.rmtree(folder)
    return out
