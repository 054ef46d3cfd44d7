"""Writing results: PNG images, animations (WebP, GIF, APNG) and decoded state (.npz).

Paths are checked before any GL work starts, and every file is written to a temporary name in the
same folder and renamed at the end, so a failure never leaves a half-written file behind.

Temporaries carry their owner. A temporary file is ``.NAME.MARK.XXXXXXXX.part`` and an
animation's frames folder ``.NAME.MARK.XXXXXXXX.frames``, where MARK (:func:`owner_mark`) names
the process that made it: ``es2particles.MACHINE.PID.START``, MACHINE a hash of the host name,
the boot and the PID namespace, START the process's start time (``/proc/PID/stat``), which a
later process given the same PID does not share. A SIGKILL cannot be caught, so each write first
removes what killed runs left for its output (:func:`remove_leftovers`): only names with a mark
of this machine whose owner is checked dead (no such PID, or another start time, or a zombie).
A name without a mark, or with another machine's, or an owner that cannot be checked, is left
alone: a user's ``.o.png.backup.part`` is never touched, nor a live run's temporaries.

Two runs to one output: each writes under its own temporary names, and the last to finish wins.
The final rename is atomic, so the output is always a whole file of one run, never a mixture.
The files of one run that must agree (the picture or video, its ``--save-state`` file and its
``--save-config`` file; the report's REPORT.md and charts) form an :class:`OutputGroup`: they are
written to temporaries, then renamed together, with SIGINT and SIGTERM held back and the folders
locked (``flock``) across the renames, so two runs' renames do not interleave. Either every file
of the group lands, or none does.
"""

import contextlib
import contextvars
import functools
import os
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from .signals import signals_deferred

IMAGE_SUFFIXES = {".png": "PNG"}
NAME_MAX = 255  # bytes of a file name on the file systems this runs on
# Bytes a temporary's name adds to the output's: ".", ".es2particles.MACHINE.PID.START.", mkstemp's
# 8 characters and ".frames" (a PID of 7 digits, a start time of 20).
TEMPORARY_DECORATION = 1 + len(".es2particles.") + 8 + 1 + 7 + 1 + 20 + 1 + 8 + len(".frames")
ANIMATION_SUFFIXES = {".webp": "WEBP", ".gif": "GIF", ".png": "PNG", ".mp4": "MP4"}
VIDEO_EXTRA = "MP4 needs the video extra: pip install 'es2particles[video]' (imageio-ffmpeg)"


def check_output(path, parameter, suffixes):
    """Return ``path`` as a Path if it can be written with one of ``suffixes``, else raise.

    Missing folders are fine: they are made when the file is written (after the work, so a
    failure before it leaves nothing behind); the nearest folder that exists must be writable,
    and nothing on the way may be a file."""
    if path is None:
        raise ParameterError(f"{parameter} is required")
    try:
        str(path).encode("utf-8")
    except UnicodeEncodeError:  # bytes no encoding names: printing it would fail after the work
        shown = str(path).encode("utf-8", "backslashreplace").decode("ascii", "replace")
        raise ParameterError(f"{parameter}: the path must be UTF-8 text; got {shown[:200]}") \
            from None
    path = Path(path)
    if path.suffix.lower() not in suffixes:
        raise ParameterError(f"{parameter} must end in {', '.join(sorted(suffixes))}, got {str(path)!r}")
    check_folder(path.parent if str(path.parent) else Path("."), parameter)
    longest = NAME_MAX - TEMPORARY_DECORATION  # room for the temporary name's decoration
    if len(path.name.encode()) > longest:
        raise ParameterError(f"{parameter}: the file name is {len(path.name.encode())} bytes; at "
                             f"most {longest}")
    if path.exists() and not os.access(path, os.W_OK):
        raise ParameterError(f"{parameter}: {str(path)!r} is not writable")
    if path.is_dir():
        raise ParameterError(f"{parameter}: {str(path)!r} is a folder, not a file")
    return path


def check_folder(folder, parameter):
    """Raise unless ``folder`` exists as a writable folder, or can be made in its nearest
    existing ancestor (which must be a writable folder)."""
    folder = Path(folder)
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise ParameterError(f"{parameter}: {str(existing)!r} is a file, not a folder")
    # Try it: permissions say nothing of a read-only file system, /proc, or root's rights.
    # SIGINT and SIGTERM are held off meanwhile: one landing between the probe's creation and
    # its removal left it behind (a fresh clone's CI, once each). Held by Python's handlers, not
    # by this thread's signal mask: with another thread running (a phase's timer) the kernel
    # hands the signal to that thread, and Python still raises it here, inside the block.
    try:
        with signals_deferred(), tempfile.NamedTemporaryFile(dir=existing,
                                                             prefix=".es2particles-probe-"):
            pass
    except OSError as error:
        raise ParameterError(f"{parameter}: cannot write in {str(existing)!r}: "
                             f"{error.strerror or error}") from None
    return folder


# --- temporaries and their owners -----------------------------------------------------------

PART, FRAMES = ".part", ".frames"  # a temporary file; an animation's frames folder
_MARK = r"es2particles\.([0-9a-f]{8})\.([1-9][0-9]{0,6})\.([0-9]{1,20})"
_OWN_MARK = {}  # pid -> this process's mark, made once (a fork has another pid, and its own)


def owner_mark(pid=None):
    """The mark a temporary of process ``pid`` (default: this one) carries in its name:
    ``es2particles.MACHINE.PID.START``, MACHINE this machine's (:func:`machine_hash`), START
    the process's start time in clock ticks since boot (0 where there is no ``/proc``)."""
    if pid is None:
        pid = os.getpid()
        if pid not in _OWN_MARK:
            _OWN_MARK[pid] = owner_mark(pid)
        return _OWN_MARK[pid]
    stat = _process_stat(pid)
    return f"es2particles.{machine_hash()}.{pid}.{0 if stat is None else stat[1]}"


def temporary_prefix(path, pid=None):
    """The start of the name of a temporary for ``path`` made by process ``pid`` (default: this
    one): ``.NAME.MARK.``, to which mkstemp adds its random characters and the suffix,
    :data:`PART` or :data:`FRAMES`."""
    return f".{Path(path).name}.{owner_mark(pid)}."


@functools.cache
def machine_hash():
    """8 hex digits naming this host, this boot and this PID namespace: a PID is checked only
    where it means the same process (another machine on a shared folder, an earlier boot, or a
    container with its own PIDs gives another hash, and its temporaries are left alone)."""
    parts = [os.uname().nodename]
    for source in ("/proc/sys/kernel/random/boot_id", "/proc/self/ns/pid"):
        try:
            parts.append(os.readlink(source) if "/ns/" in source else
                         Path(source).read_text().strip())
        except OSError:
            parts.append("")
    # crc32, not a cryptographic hash: 32 bits tell hosts apart as well, and zlib is loaded for
    # the PNG anyway where hashlib cost every run 3.5 ms of start-up.
    import zlib

    return f"{zlib.crc32(chr(0).join(parts).encode()):08x}"


def _process_stat(pid):
    """(state letter, start time in clock ticks since boot) of process ``pid`` from
    ``/proc/PID/stat``, or None where it cannot be read."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except (OSError, ValueError):
        return None
    # After "pid (command) ", the command being any text (spaces and brackets too).
    fields = text[text.rindex(")") + 2:].split()
    return fields[0], int(fields[19])


def owner_alive(pid, start):
    """False only where process ``pid`` started at ``start`` is certainly gone: no process has
    that PID, or the one that has it started at another time (the PID was reused), or it is a
    zombie. A process that exists but cannot be read (another user's, under hidepid) counts as
    alive."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it exists, and is another user's
        pass
    stat = _process_stat(pid)
    if stat is None or start == 0:  # nothing to compare: it may be the owner
        return True
    state, started = stat
    return started == start and state not in ("Z", "X")


def leftover_owner(name, path):
    """(pid, start) of the process that made ``name`` as a temporary for ``path`` on this
    machine, or None where ``name`` is not one (no mark, another output's, another machine's)."""
    match = re.fullmatch(re.escape(f".{Path(path).name}.") + _MARK
                         + r"\.[a-z0-9_]+(\.part|\.frames)", name)
    if match is None or match.group(1) != machine_hash():
        return None
    return int(match.group(2)), int(match.group(3))


def remove_leftovers(path):
    """Remove what killed runs left for ``path`` (a SIGKILL cannot be caught, so the next run
    cleans up): temporaries whose mark names a process of this machine that is gone. Anything
    else is left alone (see the module's docstring); returns the names removed."""
    path = Path(path)
    folder = path.parent  # Path("o.png").parent is Path(".")
    removed = []
    try:
        names = os.listdir(folder)
    except OSError:
        return removed
    for name in names:
        owner = leftover_owner(name, path)
        if owner is None or owner_alive(*owner):
            continue
        stale = folder / name
        if name.endswith(PART) and stale.is_file() and not stale.is_symlink():
            stale.unlink(missing_ok=True)
        elif name.endswith(FRAMES) and stale.is_dir() and not stale.is_symlink():
            shutil.rmtree(stale, ignore_errors=True)
        else:
            continue
        removed.append(name)
    return removed


def make_folders(folder):
    """Make ``folder`` and any missing parents; returns those made here, outermost first, so
    that :func:`remove_made_folders` can take them away again."""
    folder = Path(folder)
    missing = []
    while not folder.exists() and folder != folder.parent:
        missing.append(folder)
        folder = folder.parent
    made = []
    for folder in reversed(missing):
        try:
            folder.mkdir()
        except FileExistsError:  # another run made it meanwhile: it is not ours to remove
            continue
        made.append(folder)
    return made


def remove_made_folders(made):
    """Remove the folders :func:`make_folders` made, innermost first, where they are empty (a
    file in one, anyone's, keeps it and those around it)."""
    for folder in reversed(made):
        with contextlib.suppress(OSError):
            folder.rmdir()


def _temporary(path, make, suffix):
    """``make(prefix=, suffix=, dir=)`` (mkstemp or mkdtemp) for ``path``, in its folder, made
    first where missing; returns (what make returned, the folders made). A folder removed by a
    failed run between the two (see :func:`remove_made_folders`) is made again."""
    path = Path(path)
    folder = path.parent
    made = []
    for attempt in range(3):
        made += make_folders(folder)
        try:
            return make(prefix=temporary_prefix(path), suffix=suffix, dir=folder), made
        except FileNotFoundError:
            if attempt == 2:
                raise


def check_video(path, size):
    """Raise before any work if ``path`` is an MP4 that cannot be written: the extra missing, or
    an odd side (H.264 in yuv420p halves the colour resolution)."""
    if Path(path).suffix.lower() != ".mp4":
        return
    try:
        import imageio_ffmpeg  # noqa: F401
    except ImportError:
        raise ParameterError(VIDEO_EXTRA) from None
    if size[0] % 2 or size[1] % 2:
        raise ParameterError(f"MP4 needs an even width and height, got {size[0]}x{size[1]}")


class AnimationWriter:
    """Writes an animation frame by frame in bounded memory, atomically.

    MP4 (H.264) frames stream to ffmpeg (imageio-ffmpeg, the ``video`` extra); WebP, GIF and APNG
    frames are kept as PNG files in a hidden folder beside the output and assembled at the end
    (pillow reads them one at a time). The result appears under ``path`` only when complete; any
    failure (or Ctrl-C, or SIGTERM through the command line) removes what was written.
    """

    def __init__(self, path, fps=30):
        self.path, self.fps = Path(path), fps
        self.format = ANIMATION_SUFFIXES[self.path.suffix.lower()]
        self.count, self.video, self.size = 0, None, None
        self.folder, self.made = None, []
        remove_leftovers(self.path)
        try:
            with signals_deferred():  # an interrupt comes once self.folder names the folder
                folder, self.made = _temporary(self.path, tempfile.mkdtemp, FRAMES)
                self.folder = Path(folder)
        except BaseException:
            self.abort()
            raise
        OutputGroup.adopt_folders(self.made)

    def add(self, frame):
        frame = np.ascontiguousarray(frame, dtype=np.uint8)
        if frame.ndim != 3 or frame.shape[2] != 3 or 0 in frame.shape:
            raise ParameterError(f"a frame must be an (h, w, 3) array, got {frame.shape}")
        if self.size is None:
            self.size = frame.shape[1], frame.shape[0]
        elif (frame.shape[1], frame.shape[0]) != self.size:
            raise ParameterError(f"frames must all be {self.size[0]}x{self.size[1]}")
        if self.format == "MP4":
            if self.video is None:
                self.video = self._open_video()
            self.video.send(frame.tobytes())
        else:
            (self.folder / f"{self.count:06d}.png").write_bytes(encode_png(frame))
        self.count += 1

    def _open_video(self):
        check_video(self.path, self.size)
        import imageio_ffmpeg

        video = imageio_ffmpeg.write_frames(
            str(self.folder / "video.mp4"), self.size, fps=self.fps, codec="libx264",
            pix_fmt_in="rgb24", pix_fmt_out="yuv420p", quality=8, macro_block_size=1,
            ffmpeg_log_level="error")
        video.send(None)  # start ffmpeg
        return video

    def close(self):
        """Finish the file and move it onto ``path``; returns the path."""
        from PIL import Image

        if self.count == 0:
            raise ParameterError("an animation needs at least one frame")
        try:
            if self.format == "MP4":
                self.video.close()
                write_atomic(self.path, lambda tmp: os.replace(self.folder / "video.mp4", tmp))
            else:
                # Opening a PNG reads its header only: the pixels are read one frame at a time
                # as the encoder takes them (a list: pillow's APNG writer takes no generator).
                # Only PNG is opened: these are our own frames, and nothing else is decoded.
                frames = sorted(self.folder.glob("*.png"))
                first, *rest = (Image.open(f, formats=["PNG"]) for f in frames)
                options = {"save_all": True, "append_images": rest,
                           "duration": int(round(1000 / self.fps)), "loop": 0}
                if self.format == "WEBP":
                    options.update(quality=90, method=4)
                write_atomic(self.path, lambda tmp: first.save(tmp, format=self.format, **options))
        finally:
            self.abort()
        return self.path

    def abort(self):
        """Remove everything written so far, and the folders made for it where they are empty
        (the output itself is untouched)."""
        if self.video is not None:
            try:
                self.video.close()
            except Exception:  # ffmpeg may already have gone; its files go anyway
                pass
            self.video = None
        if self.folder is not None:
            shutil.rmtree(self.folder, ignore_errors=True)
        remove_made_folders(self.made)

    def __enter__(self):
        return self

    def __exit__(self, kind, value, traceback):
        if kind is not None:
            self.abort()


def write_atomic(path, write):
    """Run ``write(temporary_path)`` and rename the result onto ``path``; clean up on failure.
    Missing folders on the way are made first (and removed again on failure, where empty).
    Inside an :class:`OutputGroup` that holds ``path``, the rename waits for the group's."""
    path = Path(path)
    group = OutputGroup.holding(path)
    remove_leftovers(path)
    tmp, made = None, []
    try:
        with signals_deferred():  # an interrupt comes once tmp names what is to be removed
            (fd, tmp), made = _temporary(path, tempfile.mkstemp, PART)
            os.close(fd)
        write(tmp)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual mode
        if group is not None:
            group.stage(tmp, path, made)
        else:
            os.replace(tmp, path)
    except BaseException:
        if tmp is not None and os.path.exists(tmp):
            os.remove(tmp)
        remove_made_folders(made)
        raise
    return path


class OutputGroup:
    """Files that land together or not at all: inside ``with OutputGroup(a, b, c):``, each
    :func:`write_atomic` (and so :func:`save_image`, :func:`save_arrays`, an
    :class:`AnimationWriter`'s result) to one of ``files``, or with ``folder`` to any file
    directly in that folder, writes its temporary and stops there. When the block ends without
    an exception the temporaries are renamed onto their paths, those written in ``folder``
    first, then ``files`` in the order given: put last the file whose arrival says the work is
    done (a run's picture, the report's REPORT.md): a SIGKILL between two renames, which nothing
    holds back, leaves that file as it was, so the work shows as not done. SIGINT and SIGTERM
    are held back across the renames (and delivered after them), and each folder is locked
    (``flock``) so that two runs' renames do not interleave: the last run to finish wins with
    all of its files. When the block ends with an exception, or an interrupt, the temporaries
    are removed, and the folders made for them where empty. A path of ``files`` may be None (not
    asked for)."""

    _active = contextvars.ContextVar("es2particles_output_group", default=None)

    def __init__(self, *files, folder=None):
        self.files = [os.path.abspath(f) for f in files if f is not None]
        self.folder = None if folder is None else os.path.abspath(folder)
        self.staged = {}  # absolute path -> its temporary, in the order written
        self.made = []  # folders made for the group's files, outermost first
        self._token = None

    @classmethod
    def holding(cls, path):
        """The group of this context that holds ``path``, or None."""
        group = cls._active.get()
        if group is None:
            return None
        path = os.path.abspath(path)
        if path in group.files or (group.folder is not None
                                   and os.path.dirname(path) == group.folder):
            return group
        return None

    @classmethod
    def adopt_folders(cls, made):
        """Folders made by a writer inside the group: removed with its temporaries if it is
        given up."""
        group = cls._active.get()
        if group is not None:
            group.made += made

    def stage(self, tmp, path, made=()):
        path = os.path.abspath(path)
        earlier = self.staged.pop(path, None)
        if earlier is not None:  # written twice: the later one stands
            with contextlib.suppress(FileNotFoundError):
                os.remove(earlier)
        self.staged[path] = tmp
        self.made += made

    def __enter__(self):
        if self._active.get() is not None:
            raise RuntimeError("an OutputGroup is already open in this context")
        self._token = self._active.set(self)
        return self

    def __exit__(self, kind, value, traceback):
        # An interrupt landing before the commit's renames begin (here, between this method's
        # first lines) left every temporary behind with exit 130 (a fresh clone's CI, SIGTERM
        # as the run file's temporary appeared): whatever ends this method early, the
        # temporaries not yet renamed are removed.
        try:
            self._active.reset(self._token)
            if kind is None:
                self.commit()
        finally:
            if kind is not None or self.staged:
                self.abort()

    def commit(self):
        """Rename every staged temporary onto its path (see the class's docstring)."""
        order = ([p for p in self.staged if p not in self.files]
                 + [p for p in self.files if p in self.staged])
        try:
            # The locks first: waiting for another run's renames can still be interrupted.
            with folders_locked({os.path.dirname(p) for p in order}), signals_deferred():
                for path in order:
                    os.replace(self.staged[path], path)
                    del self.staged[path]
        except BaseException:
            self.abort()
            raise

    def abort(self):
        """Remove the staged temporaries, and the folders made for them where empty."""
        with signals_deferred():
            for tmp in self.staged.values():
                with contextlib.suppress(FileNotFoundError):
                    os.remove(tmp)
            self.staged = {}
            remove_made_folders(self.made)


@contextlib.contextmanager
def folders_locked(folders):
    """An exclusive ``flock`` on each folder, taken in one order (so two runs never wait for
    each other in a circle) and released when the block ends. Where a folder cannot be locked
    (no ``fcntl``, a file system without locks) it goes on without."""
    try:
        import fcntl
    except ImportError:
        yield
        return
    opened = {}  # (device, inode) -> descriptor: one folder by two names is locked once
    try:
        for folder in set(folders):
            try:
                fd = os.open(folder or ".", os.O_RDONLY)
            except OSError:
                continue
            identity = os.fstat(fd)
            key = (identity.st_dev, identity.st_ino)
            if key in opened:
                os.close(fd)
            else:
                opened[key] = fd
        for key in sorted(opened):
            with contextlib.suppress(OSError):
                fcntl.flock(opened[key], fcntl.LOCK_EX)
        yield
    finally:
        for fd in opened.values():
            os.close(fd)  # closing releases the lock


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def encode_png(pixels, compress_level=1):
    """PNG file bytes of an (h, w, 3) uint8 image: 8-bit RGB, rows unfiltered, deflated.

    Written here rather than through pillow for speed: pillow tries every row filter, which is
    most of its 43 ms for a 1024x1024 frame at level 1. Unfiltered rows deflate in ~26 ms on one
    thread (15-20 on two, :func:`deflate`), and for these pictures (large dark regions, smooth
    ramps) to smaller files too: 453 against 639 KB for the de Jong frame. Tests decode the result
    with pillow.
    """
    import struct
    import zlib

    pixels = np.asarray(pixels)
    if pixels.dtype != np.uint8 or pixels.ndim != 3 or pixels.shape[2] != 3:
        raise ParameterError(f"an image must be (h, w, 3) uint8, got {pixels.shape} {pixels.dtype}")
    h, w, _ = pixels.shape
    rows = np.zeros((h, 1 + 3 * w), dtype=np.uint8)  # each row: filter type 0 (none), pixels
    rows[:, 1:] = pixels.reshape(h, 3 * w)

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)  # 8 bits, truecolour, no interlace
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", deflate(memoryview(rows).cast("B"), compress_level))
            + chunk(b"IEND", b""))


# Below this many bytes one thread deflates faster than several start.
PARALLEL_DEFLATE_BYTES = 2 ** 20


def deflate(data, level):
    """zlib-wrapped deflate of ``data``, pigz's way where it is large and the machine has cores:
    pieces deflated on threads (zlib lets go of the GIL), each but the last ended by a sync flush
    so that the raw streams join into one, under one header and the whole data's adler32. The
    stream inflates to the same bytes; each piece restarts its window, so it is a little larger
    (+0.14% for a 1024x1024 de Jong frame, deflated in 15 ms on two cores instead of 26)."""
    import threading
    import zlib

    pieces = min(os.cpu_count() or 1, 4, max(1, len(data) // PARALLEL_DEFLATE_BYTES))
    if pieces == 1:
        return zlib.compress(data, level)
    size = -(-len(data) // pieces)
    view = memoryview(data)
    out = [None] * pieces

    def piece(i):
        stream = zlib.compressobj(level, zlib.DEFLATED, -15)
        last = i == pieces - 1
        out[i] = (stream.compress(view[i * size:(i + 1) * size])
                  + stream.flush(zlib.Z_FINISH if last else zlib.Z_SYNC_FLUSH))

    threads = [threading.Thread(target=piece, args=(i,)) for i in range(1, pieces)]
    for thread in threads:
        thread.start()
    piece(0)
    for thread in threads:
        thread.join()
    header = zlib.compress(b"", level)[:2]  # the zlib header for this level (CMF, FLG)
    return header + b"".join(out) + zlib.adler32(data).to_bytes(4, "big")


def save_image(pixels, path, compress_level=1):
    """Write an (h, w, 3) uint8 image as PNG (see :func:`encode_png`).

    Deflate level 1 by default, in pieces on threads (:func:`deflate`): ~17 ms at 1024x1024 on
    two cores against ~120 ms for pillow's default level 6; pass 9 for the smallest file.
    """
    if Path(path).suffix.lower() != ".png":  # PNG bytes under another name mislead
        raise ParameterError(f"save_image writes PNG: name the file .png, got {str(path)!r} "
                             "(save_animation writes .webp, .gif, .png and .mp4)")
    pixels = np.asarray(pixels)
    if pixels.ndim != 3 or pixels.shape[2] != 3 or 0 in pixels.shape:
        raise ParameterError(f"an image must be an (h, w, 3) array with h, w >= 1, got shape "
                             f"{pixels.shape}")
    data = encode_png(pixels, compress_level)
    return write_atomic(path, lambda tmp: Path(tmp).write_bytes(data))


def save_animation(frames, path, fps=30):
    """Write (h, w, 3) uint8 frames (any iterable) as an animated WebP, GIF, PNG (APNG) or MP4,
    through :class:`AnimationWriter`."""
    with AnimationWriter(path, fps) as writer:
        for frame in frames:
            writer.add(frame)
        return writer.close()


def save_arrays(arrays, path):
    """Write named arrays to an .npz file, atomically."""
    def write(tmp):
        with open(tmp, "wb") as handle:
            np.savez(handle, **{k: np.asarray(v) for k, v in arrays.items()})

    return write_atomic(path, write)
