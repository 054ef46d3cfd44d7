"""ASTC LDR compression of RGBA8 images, for read-only textures such as a collision field atlas.

Encoding and decoding go through the ``astcenc`` command (Debian package ``astcenc``); the GL upload
is :meth:`Context.compressed_texture <es2particles.gl.context.Context.compressed_texture>`. Rows keep
the order of the rest of the package: row 0 of an image is texture row t = 0, the first one a plain
``ctx.texture(data=image.tobytes())`` uploads (the tests check this on the GPU).
"""

import math
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import CapabilityError, ParameterError

EXTENSION = "GL_KHR_texture_compression_astc_ldr"
# The 2D block footprints (width, height) and their GL_COMPRESSED_RGBA_ASTC_*_KHR formats.
BLOCKS = {block: 0x93B0 + i for i, block in enumerate(
    [(4, 4), (5, 4), (5, 5), (6, 5), (6, 6), (8, 5), (8, 6), (8, 8),
     (10, 5), (10, 6), (10, 8), (10, 10), (12, 10), (12, 12)])}
PRESETS = ("fastest", "fast", "medium", "thorough", "verythorough", "exhaustive")
ENCODERS = ("astcenc", "astcenc-native", "astcenc-avx2", "astcenc-sse4.1", "astcenc-sse2")
INSTALL_HINT = "apt install astcenc"
MAGIC = 0x5CA1AB13
BLOCK_BYTES = 16  # every ASTC block is 128 bits, whatever its footprint


def encoder():
    """Path of the astcenc binary (any of its builds), or None."""
    return next(filter(None, map(shutil.which, ENCODERS)), None)


def unavailable(ctx, encode=True):
    """None when ASTC textures can be used on ``ctx`` (a context or its capabilities), else the
    reason in one line.

    ``encode=False`` asks about the upload alone (blocks made elsewhere need no encoder).
    """
    caps = getattr(ctx, "caps", ctx)  # a context, or its Capabilities
    if EXTENSION not in caps.extensions:
        return f"{caps.renderer} does not list {EXTENSION}"
    if encode and encoder() is None:
        return f"no ASTC encoder found ({', '.join(ENCODERS)}): {INSTALL_HINT}"
    return None


def _check_block(block):
    try:
        block = tuple(int(n) for n in block)
    except (TypeError, ValueError):
        block = None
    if block not in BLOCKS:
        allowed = ", ".join(f"{w}x{h}" for w, h in BLOCKS)
        raise ParameterError(f"ASTC block must be one of {allowed}, got {block!r}")
    return block


@dataclass(frozen=True)
class Compressed:
    """An ASTC image: its size in texels, its block footprint and its blocks (row 0 first)."""

    width: int
    height: int
    block: tuple
    data: bytes

    def __post_init__(self):
        object.__setattr__(self, "block", _check_block(self.block))  # a list becomes a tuple
        if len(self.data) != self.blocks * BLOCK_BYTES:
            raise ParameterError(f"ASTC data of {self.width}x{self.height} in {self.block} blocks "
                                 f"must be {self.blocks * BLOCK_BYTES} bytes, got {len(self.data)}")

    @property
    def blocks(self):
        bw, bh = self.block
        return math.ceil(self.width / bw) * math.ceil(self.height / bh)

    @property
    def internal_format(self):
        return BLOCKS[self.block]

    @property
    def bits_per_texel(self):
        bw, bh = self.block
        return BLOCK_BYTES * 8 / (bw * bh)

    @property
    def nbytes(self):
        return len(self.data)


def compress(image, block=(6, 6), preset="medium"):
    """Encode an (h, w, 4) uint8 image as ASTC LDR (linear, not sRGB).

    The channels are weighted as unrelated data (astcenc ``-mask``): a field atlas holds a distance
    and an encoded normal, not a colour, and error leaking between them is what matters.

    Parameters
    ----------
    image : numpy.ndarray
        (h, w, 4) uint8; row 0 is texture row t = 0.
    block : tuple of int
        The footprint (bw, bh), one of :data:`BLOCKS`: 128 bits per block.
    preset : str
        astcenc's quality preset, one of :data:`PRESETS`.
    """
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] != 4 or image.dtype != np.uint8 or 0 in image.shape:
        raise ParameterError(f"image must be (h, w, 4) uint8, got {image.shape} {image.dtype}")
    block = _check_block(block)
    if preset not in PRESETS:
        raise ParameterError(f"preset must be one of {', '.join(PRESETS)}, got {preset!r}")
    from PIL import Image

    with tempfile.TemporaryDirectory() as folder:
        source, out = Path(folder) / "in.png", Path(folder) / "out.astc"
        # PNG rows go top first and astcenc keeps them in that order (no -yflip): row 0 of the
        # image is the first block row, which GL takes as t = 0.
        Image.fromarray(image, "RGBA").save(source, compress_level=0)
        _run("-cl", source, out, "%dx%d" % block, f"-{preset}", "-mask")
        raw = out.read_bytes()
    magic, size = int.from_bytes(raw[:4], "little"), tuple(raw[4:7])
    dims = tuple(int.from_bytes(raw[i:i + 3], "little") for i in (7, 10, 13))
    h, w = image.shape[:2]
    if magic != MAGIC or size != (*block, 1) or dims != (w, h, 1):
        raise CapabilityError(f"astcenc wrote an unexpected header: {raw[:16].hex()}")
    return Compressed(w, h, block, raw[16:])


def decompress(compressed):
    """The (h, w, 4) uint8 image the GPU decodes from ``compressed``, in :func:`compress`'s row
    order (a numpy twin for tests and reference)."""
    if not isinstance(compressed, Compressed):
        raise ParameterError(f"compressed must be an astc.Compressed, got "
                             f"{type(compressed).__name__}")
    from PIL import Image

    c = compressed
    header = (MAGIC.to_bytes(4, "little") + bytes((*c.block, 1))
              + b"".join(n.to_bytes(3, "little") for n in (c.width, c.height, 1)))
    with tempfile.TemporaryDirectory() as folder:
        source, out = Path(folder) / "in.astc", Path(folder) / "out.png"
        source.write_bytes(header + c.data)
        _run("-dl", source, out)
        with Image.open(out, formats=["PNG"]) as decoded:
            return np.asarray(decoded.convert("RGBA")).copy()


def _run(*args):
    """Run astcenc; its failure is a one-line CapabilityError with its last word."""
    tool = encoder()
    if tool is None:
        raise CapabilityError(f"no ASTC encoder found ({', '.join(ENCODERS)}): {INSTALL_HINT}")
    done = subprocess.run([tool, *map(str, args), "-silent"], capture_output=True, text=True)
    if done.returncode != 0:
        lines = (done.stderr or done.stdout).strip().splitlines() or [f"exit {done.returncode}"]
        raise CapabilityError(f"astcenc {args[0]} failed: {lines[-1].strip()}")
