"""Reading the files a user gives (a gradient ramp, a mask silhouette, a sprite texture, a mesh).

One opener for them all: the path must be a plain file (a FIFO would block forever; the file is
opened without waiting and checked again once open, so one swapped in meanwhile is not waited on
either). Images are PNG only, known by their signature, not their name: Pillow opens dozens of
formats, and some hand the file to other programs (an EPS named ``x.png`` goes to Ghostscript,
whose PostScript runs), so anything else is refused in one line naming what it really is. The
size a PNG's header claims is checked before any pixel is decoded (a 69-byte PNG can claim
100000 x 100000 pixels), and every failure is one ParameterError naming the parameter.
"""

import os
import stat
from pathlib import Path

from ..errors import ParameterError

MAX_PIXELS = 2 ** 26  # 8192 x 8192: far more than a ramp, a mask or a sprite needs
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# What a file that is not a PNG most likely is, by its first bytes: only to say so in the
# refusal. Nothing here is ever decoded.
SIGNATURES = (
    (b"%!PS", "PostScript (an EPS or PS file)"), (b"\xc5\xd0\xd3\xc6", "an EPS (DOS binary)"),
    (b"%PDF", "a PDF"), (b"II*\x00", "a TIFF"), (b"MM\x00*", "a TIFF"),
    (b"8BPS", "a Photoshop PSD"), (b"\x00\x00\x01\x00", "a Windows icon (ICO)"),
    (b"\x00\x00\x02\x00", "a Windows cursor (CUR)"), (b"\xff\xd8\xff", "a JPEG"),
    (b"GIF8", "a GIF"), (b"BM", "a BMP"), (b"\x8aMNG", "an MNG"),
    (b"\x00\x00\x00\x0cjP  ", "a JPEG 2000"), (b"\xffO\xffQ", "a JPEG 2000 codestream"),
    (b"qoif", "a QOI image"), (b"DDS ", "a DirectDraw surface (DDS)"),
    (b"\x76\x2f\x31\x01", "an OpenEXR image"), (b"#?RADIANCE", "a Radiance HDR image"),
    (b"\x1f\x8b", "gzip data"), (b"PK\x03\x04", "a zip archive"), (b"\x7fELF", "a program (ELF)"),
    (b"<?xml", "XML (an SVG?)"), (b"<svg", "an SVG"), (b"#!", "a script"),
)


def what_is(head):
    """A few words naming the kind of file whose first bytes are ``head``."""
    if head[:4] == b"RIFF" and head[8:12] == b"WEBP":
        return "a WebP"
    for signature, kind in SIGNATURES:
        if head.startswith(signature):
            return kind
    if not head:
        return "empty"
    shown = head[:8].hex(" ")
    return f"of no format read here (its first bytes: {shown})"


def file_fault(path):
    """What keeps ``path`` from being read as a file ("does not exist", "is a folder, not a
    file", "is not a plain file" for a FIFO, a socket or a device), or None for a plain file.
    Only its status is looked at: nothing is opened, so a FIFO is not waited on."""
    file = Path(path)
    try:
        if file.is_file():
            return None
        if file.is_dir():
            return "is a folder, not a file"
        if file.exists():
            return "is not a plain file (a FIFO, a socket or a device)"
    except OSError as error:  # a name too long, a loop of links: the path itself is at fault
        return f"cannot be looked up: {error.strerror or error}"
    return "does not exist"


def check_input(path, parameter, named=None):
    """``path`` as a Path if it is a plain file to read, else one line naming ``parameter``
    (see :func:`file_fault`); ``named`` replaces the line's start ("PARAMETER: 'PATH'")."""
    fault = file_fault(path)
    if fault:
        raise ParameterError(f"{named or f'{parameter}: {str(path)!r}'} {fault}")
    return Path(path)


def open_input(path, parameter, named=None):
    """``path`` opened for reading in binary, if it is a plain file, else one line as
    :func:`check_input` says it. It is opened without waiting (O_NONBLOCK: a FIFO put in its
    place after the check does not block) and its status is checked again on the open file."""
    file = check_input(path, parameter, named)
    named = named or f"{parameter}: {str(path)!r}"
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(file, flags)
    except OSError as error:
        raise ParameterError(f"{named} cannot be opened: {error.strerror}") from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise ParameterError(f"{named} is not a plain file (a FIFO, a socket or a device)")
    return os.fdopen(fd, "rb")


def open_png(path, parameter):
    """``path`` opened (see :func:`open_input`) if its first bytes are a PNG's signature, else one
    line naming ``parameter`` and what the file is: nothing but its first 16 bytes is read."""
    handle = open_input(path, parameter)
    head = handle.read(16)
    if not head.startswith(PNG_SIGNATURE):
        handle.close()
        raise ParameterError(f"{parameter}: {str(path)!r} is not a PNG image: it is "
                             f"{what_is(head)} (only PNG is read)")
    handle.seek(0)
    return handle


def check_png(path, parameter):
    """Refuse ``path`` in one line unless it is a PNG by its signature, before any work that
    reads it later (decodes nothing)."""
    open_png(path, parameter).close()


def read_image(path, parameter, mode="RGBA", max_pixels=MAX_PIXELS):
    """The PNG image at ``path`` converted to ``mode`` (None: as it is), fully read. A file that
    is not a PNG by its signature, whatever its name, is refused before any decoder sees it, and
    Pillow is allowed its PNG reader alone."""
    from PIL import Image

    with open_png(path, parameter) as handle:
        try:
            with Image.open(handle, formats=["PNG"]) as image:
                w, h = image.size
                if w * h > max_pixels:
                    raise ParameterError(f"{parameter}: {str(path)!r} is {w}x{h} pixels; at "
                                         f"most {max_pixels} pixels are read (8192x8192)")
                image.load()
                return image.convert(mode) if mode else image.copy()
        except ParameterError:
            raise
        except (OSError, ValueError, Image.DecompressionBombError, SyntaxError) as error:
            raise ParameterError(f"{parameter}: {str(path)!r} cannot be read as a PNG image: "
                                 f"{error}") from None
