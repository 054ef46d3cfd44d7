"""Writing results: PNG images, animations (WebP, GIF, APNG) and decoded state (.npz).

Paths are checked before any GL work starts, and every file is written to a temporary name in the
same folder and renamed at the end, so a failure never leaves a half-written file behind.
"""

import os
import tempfile
from pathlib import Path

import numpy as np

from ..errors import ParameterError

IMAGE_SUFFIXES = {".png": "PNG"}
NAME_MAX = 255  # bytes of a file name on the file systems this runs on
ANIMATION_SUFFIXES = {".webp": "WEBP", ".gif": "GIF", ".png": "PNG", ".mp4": "MP4"}
VIDEO_EXTRA = "MP4 needs the video extra: pip install 'es2particles[video]' (imageio-ffmpeg)"


def check_output(path, parameter, suffixes):
    """Return ``path`` as a Path if it can be written with one of ``suffixes``, else raise.

    Missing folders are fine: they are made when the file is written (after the work, so a
    failure before it leaves nothing behind); the nearest folder that exists must be writable,
    and nothing on the way may be a file."""
    if path is None:
        raise ParameterError(f"{parameter} is required")
    path = Path(path)
    if path.suffix.lower() not in suffixes:
        raise ParameterError(f"{parameter} must end in {', '.join(sorted(suffixes))}, got {str(path)!r}")
    check_folder(path.parent if str(path.parent) else Path("."), parameter)
    if len(path.name.encode()) > NAME_MAX - 24:  # room for the temporary name's decoration
        raise ParameterError(f"{parameter}: the file name is {len(path.name.encode())} bytes; at "
                             f"most {NAME_MAX - 24}")
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
    try:
        with tempfile.NamedTemporaryFile(dir=existing, prefix=".es2particles-probe-"):
            pass
    except OSError as error:
        raise ParameterError(f"{parameter}: cannot write in {str(existing)!r}: "
                             f"{error.strerror or error}") from None
    return folder


def remove_leftovers(path):
    """Remove what a killed earlier run left for ``path`` (its hidden temporary files and frame
    folders; a SIGKILL cannot be caught, so the next run cleans up)."""
    import shutil

    path = Path(path)
    for stale in (path.parent or Path(".")).glob(f".{glob_escape(path.name)}.*"):
        if stale.name.endswith(".part"):
            stale.unlink(missing_ok=True)
        elif stale.name.endswith(".frames") and stale.is_dir():
            shutil.rmtree(stale, ignore_errors=True)


def glob_escape(name):
    import glob

    return glob.escape(name)


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
        self.path.parent.mkdir(parents=True, exist_ok=True)
        remove_leftovers(self.path)
        self.folder = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.", suffix=".frames",
                                            dir=self.path.parent))
        self.count, self.video, self.size = 0, None, None

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
                os.replace(self.folder / "video.mp4", self.path)
            else:
                # Opening a PNG reads its header only: the pixels are read one frame at a time
                # as the encoder takes them (a list: pillow's APNG writer takes no generator).
                frames = sorted(self.folder.glob("*.png"))
                first, rest = Image.open(frames[0]), [Image.open(f) for f in frames[1:]]
                options = {"save_all": True, "append_images": rest,
                           "duration": int(round(1000 / self.fps)), "loop": 0}
                if self.format == "WEBP":
                    options.update(quality=90, method=4)
                write_atomic(self.path, lambda tmp: first.save(tmp, format=self.format, **options))
        finally:
            self.abort()
        return self.path

    def abort(self):
        """Remove everything written so far (the output itself is untouched)."""
        import shutil

        if self.video is not None:
            try:
                self.video.close()
            except Exception:  # ffmpeg may already have gone; its files go anyway
                pass
            self.video = None
        shutil.rmtree(self.folder, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, kind, value, traceback):
        if kind is not None:
            self.abort()


def write_atomic(path, write):
    """Run ``write(temporary_path)`` and rename the result onto ``path``; clean up on failure.
    Missing folders on the way are made first."""
    path = Path(path)
    (path.parent or Path(".")).mkdir(parents=True, exist_ok=True)
    remove_leftovers(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent or ".")
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual mode
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    return path


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def encode_png(pixels, compress_level=1):
    """PNG file bytes of an (h, w, 3) uint8 image: 8-bit RGB, rows unfiltered, deflated.

    Written here rather than through pillow for speed: pillow tries every row filter, which is
    most of its 43 ms for a 1024x1024 frame at level 1. Unfiltered rows deflate in ~17 ms, and
    for these pictures (large dark regions, smooth ramps) to smaller files too: 453 against
    639 KB for the de Jong frame. Tests decode the result with pillow.
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
            + chunk(b"IDAT", zlib.compress(rows.tobytes(), compress_level)) + chunk(b"IEND", b""))


def save_image(pixels, path, compress_level=1):
    """Write an (h, w, 3) uint8 image as PNG (see :func:`encode_png`).

    Deflate level 1 by default: ~17 ms at 1024x1024 against ~120 ms for pillow's default level 6;
    pass 9 for the smallest file.
    """
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
