"""Writing results: PNG images, animations (WebP, GIF, APNG) and decoded state (.npz).

Paths are checked before any GL work starts, and every file is written to a temporary name in the
same folder and renamed at the end, so a failure never leaves a half-written file behind.
"""

import os
import tempfile
from pathlib import Path

import numpy as np

from .errors import ParameterError

IMAGE_SUFFIXES = {".png": "PNG"}
ANIMATION_SUFFIXES = {".webp": "WEBP", ".gif": "GIF", ".png": "PNG"}


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
    if not os.access(existing, os.W_OK):
        raise ParameterError(f"{parameter}: folder {str(existing)!r} is not writable")
    return folder


def write_atomic(path, write):
    """Public name of the atomic writer: the report writes through it too."""
    return _atomic(path, write)


def _atomic(path, write):
    """Run ``write(temporary_path)`` and rename the result onto ``path``; clean up on failure.
    Missing folders on the way are made first."""
    path = Path(path)
    (path.parent or Path(".")).mkdir(parents=True, exist_ok=True)
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
    return _atomic(path, lambda tmp: Path(tmp).write_bytes(data))


def save_animation(frames, path, fps=30):
    """Write a list of (h, w, 3) uint8 frames as an animated WebP, GIF or PNG (APNG)."""
    from PIL import Image

    frames = list(frames)
    if not frames:
        raise ParameterError("an animation needs at least one frame")
    images = [Image.fromarray(np.asarray(f, dtype=np.uint8), "RGB") for f in frames]
    fmt = ANIMATION_SUFFIXES[Path(path).suffix.lower()]
    options = {"save_all": True, "append_images": images[1:], "duration": int(round(1000 / fps)),
               "loop": 0}
    if fmt == "WEBP":
        options.update(quality=90, method=4)
    return _atomic(path, lambda tmp: images[0].save(tmp, format=fmt, **options))


def save_state(arrays, path):
    """Write named float64 arrays (world units) to an .npz file."""
    def write(tmp):
        with open(tmp, "wb") as handle:
            np.savez(handle, **{k: np.asarray(v, dtype=np.float64) for k, v in arrays.items()})

    return _atomic(path, write)
