"""Reading the images a user gives (a gradient ramp, a mask silhouette, a sprite texture).

One reader for all three: the path must be a plain file (a FIFO would block forever), the size
its header claims is checked before any pixel is decoded (a 69-byte PNG can claim 100000 x 100000
pixels), and every failure is one ParameterError naming the parameter.
"""

from pathlib import Path

from ..errors import ParameterError

MAX_PIXELS = 2 ** 26  # 8192 x 8192: far more than a ramp, a mask or a sprite needs


def file_fault(path):
    """What keeps ``path`` from being read as a file ("does not exist", "is a folder, not a
    file", "is not a plain file" for a FIFO, a socket or a device), or None for a plain file.
    Only its status is looked at: nothing is opened, so a FIFO is not waited on."""
    file = Path(path)
    if file.is_file():
        return None
    if file.is_dir():
        return "is a folder, not a file"
    if file.exists():
        return "is not a plain file (a FIFO, a socket or a device)"
    return "does not exist"


def check_input(path, parameter):
    """``path`` as a Path if it is a plain file to read, else one line naming ``parameter``
    (see :func:`file_fault`)."""
    fault = file_fault(path)
    if fault:
        raise ParameterError(f"{parameter}: {str(path)!r} {fault}")
    return Path(path)


def read_image(path, parameter, mode="RGBA", max_pixels=MAX_PIXELS):
    """The image at ``path`` converted to ``mode`` (None: as it is), fully read."""
    from PIL import Image

    file = check_input(path, parameter)
    try:
        with Image.open(file) as image:
            w, h = image.size
            if w * h > max_pixels:
                raise ParameterError(f"{parameter}: {str(path)!r} is {w}x{h} pixels; at most "
                                     f"{max_pixels} pixels are read (8192x8192)")
            image.load()
            return image.convert(mode) if mode else image.copy()
    except ParameterError:
        raise
    except (OSError, ValueError, Image.DecompressionBombError, SyntaxError) as error:
        raise ParameterError(f"{parameter}: {str(path)!r} cannot be read as an image: "
                             f"{error}") from None
