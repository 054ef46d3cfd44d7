"""Particle state in textures: named two-component quantities, their layout, double buffering.

One quantity (position, velocity, ...) is two numbers per particle in one texture, one texel per
particle. In the default ``rgba8`` format each number is 16-bit fixed point over the quantity's
declared world range [lo, hi] (see ``packing.py``); ``rgba16f``/``rgba32f`` store world values as
they are. Particle i lives at texel (i mod width, i div width); texels past the particle count are
spare: they are computed like the others but never drawn or downloaded.
"""

import math
from dataclasses import dataclass

import numpy as np

from . import packing
from .context import FORMAT_DTYPES, numpy_dtype
from .errors import ParameterError, check_range


@dataclass(frozen=True)
class Quantity:
    """A named per-particle quantity of two components with a world range [lo, hi] per component."""

    name: str
    lo: tuple
    hi: tuple

    def __post_init__(self):
        if not (isinstance(self.name, str) and self.name.isidentifier()):
            raise ParameterError(f"quantity name must be a GLSL identifier, got {self.name!r}")
        lo, hi = _pair(f"{self.name}.lo", self.lo), _pair(f"{self.name}.hi", self.hi)
        for axis in range(2):
            if not hi[axis] > lo[axis]:
                raise ParameterError(f"quantity {self.name!r}: hi must be greater than lo on each "
                                     f"component, got lo={lo} hi={hi}")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)

    @property
    def range_vec4(self):
        """vec4(lo.x, lo.y, span.x, span.y): the range uniform of ``lib/state.glsl``."""
        return packing.range_vec4(self.lo, self.hi)


def _pair(name, value):
    values = [value, value] if np.ndim(value) == 0 else list(value)
    if len(values) != 2:
        raise ParameterError(f"{name} must be a number or a pair of numbers, got {value!r}")
    return tuple(check_range(name, v) for v in values)


@dataclass(frozen=True)
class Layout:
    """Where N particles sit in a texture: width x height texels, N of them used."""

    count: int
    width: int
    height: int

    @classmethod
    def for_count(cls, count, max_texture_size):
        """The near-square layout for ``count`` particles; checks it fits the context."""
        limit = max_texture_size ** 2
        count = int(check_range("particles", count, 1, limit, integer=True))
        width = math.isqrt(count - 1) + 1  # ceil(sqrt(count))
        height = -(-count // width)
        return cls(count, width, height)

    @property
    def size(self):
        return (self.width, self.height)

    @property
    def spare(self):
        return self.width * self.height - self.count

    def texel_uv(self):
        """Texture coordinates (count, 2) of each particle's texel centre, float32."""
        # Row by row, as the particles are numbered; built by broadcasting one row and one
        # column (~1 ms at 2^20, where index arithmetic on the whole array took ~20).
        uv = np.empty((self.height, self.width, 2), dtype=np.float32)
        uv[..., 0] = (np.arange(self.width) + 0.5) / self.width
        uv[..., 1] = ((np.arange(self.height) + 0.5) / self.height)[:, None]
        return uv.reshape(-1, 2)[: self.count]


class StateBuffer:
    """One quantity's texture(s): two for ping-pong when last step's value is read, else one.

    ``front`` holds the latest value; a pass writes into ``back`` (``target``) and ``swap()`` makes it
    the front, so no pass ever reads and writes one texture.
    """

    def __init__(self, ctx, quantity, layout, fmt="rgba8", buffers=2):
        if fmt not in FORMAT_DTYPES:
            raise ParameterError(f"format must be one of {sorted(FORMAT_DTYPES)}, got {fmt!r}")
        self.ctx, self.quantity, self.layout, self.fmt = ctx, quantity, layout, fmt
        self.textures = [ctx.texture(layout.size, fmt) for _ in range(buffers)]
        self.framebuffers = [ctx.framebuffer(t) for t in self.textures]
        # Start at world (0, 0) (clamped into the range): a GPU clear to that texel, cheaper
        # than encoding and uploading a zero array.
        texel = packing.state_encode(np.zeros((1, 2)), quantity.range_vec4, fmt)[0]
        colour = texel / 255.0 if fmt == "rgba8" else texel
        for framebuffer in self.framebuffers:
            framebuffer.clear(*(float(c) for c in colour))

    @property
    def front(self):
        return self.textures[0]

    @property
    def target(self):
        """The framebuffer a pass writes this quantity into."""
        return self.framebuffers[-1]

    @property
    def written(self):
        """The texture holding this step's value once its pass has run."""
        return self.textures[-1]

    def swap(self):
        if len(self.textures) == 2:
            self.textures.reverse()
            self.framebuffers.reverse()

    def upload(self, values):
        """Write world values (count, 2) into the front texture (clamped to the range)."""
        values = np.asarray(values, dtype=np.float64)
        if values.shape != (self.layout.count, 2):
            raise ParameterError(f"{self.quantity.name}: values must have shape "
                                 f"({self.layout.count}, 2), got {values.shape}")
        self.write_texels(packing.state_encode(values, self.quantity.range_vec4, self.fmt))

    def fill_uniform(self, box, rng):
        """Set the front texture to points drawn uniformly from ``box`` = (lo.x, lo.y, span.x,
        span.y), clamped to the range. They are drawn in float32 straight in the range's unit
        square and packed from there: for 2^20 particles ~25 ms, against ~45-90 ms for drawing
        float64 world points and passing them through ``upload``. (float32 draws have 24 random
        bits, more than the 16 a packed value keeps.)"""
        q = self.quantity.range_vec4
        offset = ((box[:2] - q[:2]) / q[2:]).astype(np.float32)
        scale = (box[2:] / q[2:]).astype(np.float32)
        unit = packing.clamp_unit(rng.random((self.layout.count, 2), dtype=np.float32) * scale
                                  + offset)
        if self.fmt == "rgba8":
            self.write_texels(packing.pack2x16(unit))
        else:
            self.write_texels(packing.state_encode(q[:2] + unit * q[2:], q, self.fmt))

    def write_texels(self, texels):
        """Write texel contents (count, 4) into the front texture as they are: the encoded values
        of ``upload`` and ``fill_uniform``, or raw ones (how the stability suite injects NaN and
        Inf into float state). Spare texels get zeros."""
        full = np.zeros((self.layout.width * self.layout.height, 4), dtype=numpy_dtype(self.fmt))
        full[: self.layout.count] = texels
        self.front.write(full.tobytes())

    def read_texels(self):
        """Raw texel contents (count, 4) of the front texture."""
        raw = np.frombuffer(self.front.read(), dtype=numpy_dtype(self.fmt))
        return raw.reshape(-1, 4)[: self.layout.count]

    def download(self):
        """World values (count, 2) of the front texture, float64."""
        texels = self.read_texels()
        return packing.state_decode(texels, self.quantity.range_vec4, self.fmt).astype(np.float64)

    def release(self):
        self.ctx.free(*self.framebuffers, *self.textures)
        self.textures, self.framebuffers = [], []
