"""State in textures: named quantities of 1 to 4 components, their layout, ping-pong.

One quantity (position, velocity, colour, ...) is 1 to 4 numbers per element, one texel per
element. An element is a particle (the default domain) or a cell of a :class:`Grid` (a W x H
grid of its own size: a fluid's velocity, a pressure), whose texture is the grid itself, cell
(i, j) at texel (i, j), row 0 at the bottom. In the default ``rgba8`` format each number is 16-bit fixed point over the quantity's
declared world range [lo, hi] (see ``twins/pack.py``), two numbers to a texel, so a quantity of three
or four components spans two textures (its *parts*); ``rgba16f``/``rgba32f`` store the values
themselves, clamped into the range, up to four in one texture. A quantity declared ``bits=32``
keeps float32's precision: in rgba8 and rgba16f simulations it is stored ``rgba8_32``, one value
a texel as two 16-bit codes (the second the rest of the first), so one texture a component.
Particle i lives at texel
(i mod width, i div width); texels past the particle count are spare: they are computed like the
others but never drawn or downloaded.
"""

import math
from dataclasses import dataclass

import numpy as np

from ..twins import pack as packing
from ..gl.context import bytes_per_texel, numpy_dtype
from ..errors import ParameterError, check_range

FORMATS = ("rgba8", "rgba16f", "rgba32f")  # a simulation's
STORAGE = FORMATS + ("rgba8_32",)  # a quantity's: the simulation's, or 32-bit packed RGBA8
BITS = (16, 32)
SAMPLING = ("hand", "hardware")
CLAMPS = ("both", "lo", "hi", "none")  # which edges of a range mean a clamped write
AXES = "xyzw"


@dataclass(frozen=True)
class Grid:
    """A domain of W x H cells, or W x H x D: quantities declared on it have one texel per cell.
    A 2D grid's texture is exactly W x H texels (cell (i, j) at texel (i, j)); a 3D grid's is a
    2D atlas of its D slices of constant k (ES 2.0 has no 3D textures), :attr:`tiles` (columns,
    rows) of W x H tiles, slice k at column k mod columns, row k div columns (the last row's
    spare tiles are computed like the others, never read or saved). ``box``: the world box
    ((x0, y0), (x1, y1)) (3D: ((x0, y0, z0), (x1, y1, z1))) the grid covers, cell (i, j)
    centred at x0 + (i + 0.5) (x1 - x0) / W; by default the cells themselves, 0 to the shape.
    Its shaders see ``u_<name>_size`` (W, H) and ``u_<name>_box`` (x0, y0, x1, y1); a 3D grid's
    ``u_<name>_size`` (W, H, D), ``u_<name>_lo`` and ``u_<name>_hi`` (its box's corners) and
    ``u_<name>_tiles`` (columns, rows)."""

    name: str
    shape: tuple
    box: tuple = None

    def __post_init__(self):
        if not (isinstance(self.name, str) and self.name.isidentifier()):
            raise ParameterError(f"grid name must be a GLSL identifier, got {self.name!r}")
        shape = tuple(self.shape) if np.ndim(self.shape) == 1 else ()
        if len(shape) not in (2, 3):
            raise ParameterError(f"grid {self.name!r}: shape must be (W, H) or (W, H, D), got "
                                 f"{self.shape!r}")
        shape = tuple(int(check_range(f"grid {self.name!r} {axis}", n, 1, 2 ** 15, integer=True))
                      for axis, n in zip("WHD", shape))
        d = len(shape)
        box = ((0.0,) * d, tuple(map(float, shape))) if self.box is None else self.box
        corners = "((x0, y0), (x1, y1))" if d == 2 else "((x0, y0, z0), (x1, y1, z1))"
        try:
            lo, hi = box
            if len(lo) != d or len(hi) != d:
                raise ValueError
            box = tuple(tuple(check_range(f"grid {self.name!r} box {a}{end}", v)
                              for a, v in zip("xyz", corner))
                        for end, corner in ((0, lo), (1, hi)))
        except (TypeError, ValueError):
            raise ParameterError(f"grid {self.name!r}: box must be {corners}, got "
                                 f"{self.box!r}") from None
        if not all(b > a for a, b in zip(*box)):
            raise ParameterError(f"grid {self.name!r}: box must have "
                                 f"{', '.join(f'{a}1 > {a}0' for a in 'xyz'[:d])}, got {box}")
        object.__setattr__(self, "shape", shape)
        object.__setattr__(self, "box", box)

    @property
    def dimensions(self):
        return len(self.shape)

    @property
    def cells(self):
        """How many cells: W H (D)."""
        return math.prod(self.shape)

    @property
    def cell(self):
        """The world size (dx, dy) (3D: (dx, dy, dz)) of a cell."""
        return tuple((b - a) / n for a, b, n in zip(*self.box, self.shape))

    @property
    def tiles(self):
        """(columns, rows) of slices in a 3D grid's atlas, as square as the slices allow; (1, 1)
        for a 2D grid."""
        if self.dimensions == 2:
            return (1, 1)
        w, h, d = self.shape
        columns = max(1, min(d, math.ceil(math.sqrt(d * h / w))))
        return (columns, -(-d // columns))

    @property
    def size(self):
        """The texture's size in texels: W x H, or the atlas's."""
        return (self.shape[0] * self.tiles[0], self.shape[1] * self.tiles[1])

    def describe(self):
        """'8x4 cells over (0, 0)-(2, 1)', and a 3D grid's atlas."""
        lo, hi = (", ".join(f"{v:g}" for v in corner) for corner in self.box)
        text = f"{'x'.join(map(str, self.shape))} cells over ({lo})-({hi})"
        if self.dimensions == 3:
            text += (f", slices in an atlas of {self.tiles[0]}x{self.tiles[1]} tiles "
                     f"({self.size[0]}x{self.size[1]} texels)")
        return text

    def layout(self, max_texture_size):
        """The grid's texture layout: one texel per cell (a 3D grid's atlas, spare tiles
        included); checks it fits the context."""
        w, h = self.size
        if max(w, h) > max_texture_size:
            cells = "x".join(map(str, self.shape))
            atlas = f" in an atlas of {w}x{h} texels" if self.dimensions == 3 else ""
            raise ParameterError(f"grid {self.name!r} is {cells} cells{atlas}; this context's "
                                 f"textures are at most {max_texture_size} texels a side")
        return Layout(w * h, w, h)

    def uniforms(self):
        """``u_<name>_size`` and ``u_<name>_box`` (3D: ``_size``, ``_lo``, ``_hi``,
        ``_tiles``)."""
        size = tuple(map(float, self.shape))
        if self.dimensions == 2:
            (x0, y0), (x1, y1) = self.box
            return {f"u_{self.name}_size": size,
                    f"u_{self.name}_box": (float(x0), float(y0), float(x1), float(y1))}
        return {f"u_{self.name}_size": size, f"u_{self.name}_lo": tuple(map(float, self.box[0])),
                f"u_{self.name}_hi": tuple(map(float, self.box[1])),
                f"u_{self.name}_tiles": tuple(map(float, self.tiles))}

    def centres(self):
        """World coordinates of the cell centres, float64: (H, W, 2), row 0 at the bottom; a 3D
        grid's (D, H, W, 3)."""
        axes = [a + (np.arange(n) + 0.5) * (b - a) / n for a, b, n in zip(*self.box, self.shape)]
        return np.stack([g.T for g in np.meshgrid(*axes, indexing="ij")], axis=-1)

    def texel_rows(self, values):
        """Values (H, W, C) (3D: (D, H, W, C), or flat, one row a cell in that order) as one row a
        texel of the grid's texture, row by row (a 3D grid's spare tiles zero); anything else as
        it is, for the caller's shape check."""
        values = np.asarray(values)
        if self.dimensions == 2:
            if values.ndim >= 2 and values.shape[:2] == self.shape[::-1]:
                return values.reshape(self.cells, -1)
            return values
        w, h, d = self.shape
        if values.ndim == 1 and values.shape[0] == self.cells:
            values = values[:, None]
        if values.ndim == 2 and values.shape[0] == self.cells:
            values = values.reshape(d, h, w, -1)
        if values.ndim != 4 or values.shape[:3] != (d, h, w):
            return values
        columns, rows = self.tiles
        atlas = np.zeros((rows * columns, h, w, values.shape[3]), values.dtype)
        atlas[:d] = values
        atlas = atlas.reshape(rows, columns, h, w, -1).transpose(0, 2, 1, 3, 4)
        return atlas.reshape(rows * h * columns * w, -1)

    def image(self, values):
        """Values (H, W[, C]) (3D: (D, H, W[, C])) as an image laid out as the grid's texture,
        (rows, columns, C) with row 0 the texture's first: a scene texture whose texel
        ``G_uv(cell)`` holds that cell's value (a 3D grid's atlas, its spare tiles zero)."""
        values = np.asarray(values)
        if values.ndim == self.dimensions:  # one value a cell
            values = values[..., None]
        w, h = self.size
        return self.texel_rows(values).reshape(h, w, -1)

    def arranged(self, rows):
        """One row a texel (the texture's order) as the grid's array: (H, W, C), or a 3D grid's
        (D, H, W, C) (spare tiles dropped)."""
        if self.dimensions == 2:
            return rows.reshape(self.shape[1], self.shape[0], -1)
        (w, h, d), (columns, tiles) = self.shape, self.tiles
        atlas = rows.reshape(tiles, h, columns, w, -1).transpose(0, 2, 1, 3, 4)
        return atlas.reshape(tiles * columns, h, w, -1)[:d]


@dataclass(frozen=True)
class Quantity:
    """A named per-particle quantity of 1 to 4 components with a world range [lo, hi] each.

    ``lo`` and ``hi`` are numbers (the same for every component) or sequences of one number per
    component; ``components`` defaults to their length, or 2 where both are numbers. ``storage``
    pins the quantity to one format in every simulation (a step counter that must stay exact in
    16-bit codes, say); by default it takes the simulation's. ``sampling`` (a grid quantity's):
    how ``sample_q`` interpolates: ``"hand"`` from decoded cells, exact to float32 in every
    format; ``"hardware"``, one LINEAR-filtered fetch a slice where it is stored as floats and
    the context filters them (by hand otherwise), faster, its weights at the hardware's
    sub-texel precision (8 bits on many GPUs: up to 2^-8 of a cell-to-cell difference, as
    measured on an H200). ``clamps``: which edges of the range mean that a value written beyond was clamped there, for the report
    at a run's end: ``"both"`` (the default), ``"lo"`` or ``"hi"`` where the other edge is a
    value the physics holds (a density's 0), ``"none"`` where both are (walls, a unit vector,
    a map bounded by its range).
    """

    name: str
    lo: tuple
    hi: tuple
    components: int = None
    storage: str = None  # a format this quantity keeps whatever the simulation's (None: that)
    domain: Grid = None  # the grid it lives on; None: the particles
    bits: int = 16  # 32: at least float32's precision in every simulation (see format_in)
    sampling: str = "hand"  # a grid quantity's samples: "hand" or "hardware" (filtered LINEAR)
    clamps: str = "both"  # the edges where a value means a clamped write (see CLAMPS)

    def __post_init__(self):
        if not (isinstance(self.name, str) and self.name.isidentifier()):
            raise ParameterError(f"quantity name must be a GLSL identifier, got {self.name!r}")
        given = [len(v) for v in (self.lo, self.hi) if np.ndim(v) == 1]
        components = self.components if self.components is not None else (given[0] if given else 2)
        components = int(check_range(f"quantity {self.name!r} components", components, 1, 4,
                                     integer=True))
        lo = per_component(f"{self.name}.lo", self.lo, components)
        hi = per_component(f"{self.name}.hi", self.hi, components)
        for axis in range(components):
            if not hi[axis] > lo[axis]:
                raise ParameterError(f"quantity {self.name!r}: hi must be greater than lo on each "
                                     f"component, got lo={lo} hi={hi}")
            with np.errstate(over="ignore"):  # an overflow is what is being checked for
                lo32, span = np.float32(lo[axis]), np.float32(hi[axis]) - np.float32(lo[axis])
            if not (np.isfinite(span) and np.isfinite(lo32)):
                raise ParameterError(f"quantity {self.name!r}: the range [{lo[axis]:g}, "
                                     f"{hi[axis]:g}] overflows float32; each bound and the span "
                                     "must be within +-3.4e38")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)
        object.__setattr__(self, "components", components)
        _warn_of_zero(self)
        if self.domain is not None and not isinstance(self.domain, Grid):
            raise ParameterError(f"quantity {self.name!r}: domain must be a Grid (PassGraph.grid) "
                                 f"or None for the particles, got {self.domain!r}")
        if self.storage is not None and self.storage not in STORAGE:
            raise ParameterError(f"quantity {self.name!r}: storage must be one of {list(STORAGE)} "
                                 f"or None, got {self.storage!r}")
        if self.bits not in BITS:
            raise ParameterError(f"quantity {self.name!r}: bits must be 16 or 32, got "
                                 f"{self.bits!r}")
        if self.clamps not in CLAMPS:
            raise ParameterError(f"quantity {self.name!r}: clamps must be one of "
                                 f"{', '.join(CLAMPS)}, got {self.clamps!r}")
        if self.sampling not in SAMPLING:
            raise ParameterError(f"quantity {self.name!r}: sampling must be 'hand' or "
                                 f"'hardware', got {self.sampling!r}")
        if self.sampling == "hardware" and self.domain is None:
            raise ParameterError(f"quantity {self.name!r}: sampling='hardware' is for a grid's "
                                 "quantities (sample_q); particles are read a texel each")

    @property
    def domain_name(self):
        """The name of the domain it lives on: its grid's, or "particles"."""
        return "particles" if self.domain is None else self.domain.name

    def format_in(self, fmt):
        """The format this quantity is stored in within a simulation of format ``fmt``: its
        ``storage`` if pinned; with ``bits=32``, ``rgba8_32`` where the simulation's format holds
        fewer bits than float32 (rgba8's 16-bit codes, rgba16f's 11-bit significands: state that
        accumulates, an attractor's orbit, would keep their error as a floor); else ``fmt``."""
        if self.storage:
            return self.storage
        return "rgba8_32" if self.bits == 32 and fmt in ("rgba8", "rgba16f") else fmt

    @property
    def lo32(self):
        """lo per component as float32 (what the shader's ``u_<name>_lo`` holds)."""
        return np.array(self.lo, dtype=np.float32)

    @property
    def span32(self):
        """hi - lo per component as float32 (``u_<name>_span``)."""
        return (np.array(self.hi) - np.array(self.lo)).astype(np.float32)

    def uniforms(self):
        """The range uniforms of this quantity, padded to vec4: {u_<name>_lo, u_<name>_span}."""
        # Unused components get lo 0 and span 1 (never a division by zero in the shader).
        lo, span = np.zeros(4), np.ones(4)
        lo[: self.components], span[: self.components] = self.lo32, self.span32
        return {f"u_{self.name}_lo": tuple(map(float, lo)),
                f"u_{self.name}_span": tuple(map(float, span))}

    def parts(self, fmt):
        """Textures the quantity spans in a simulation of format ``fmt``."""
        return packing.parts(self.components, self.format_in(fmt))

    def part_axes(self, fmt, part):
        """The component names (``xy``, ``z``, ...) that part ``part`` holds in ``fmt``."""
        per = packing.PACKED.get(self.format_in(fmt), 4)
        return AXES[per * part: min(per * part + per, self.components)]

    def bytes_per_particle(self, fmt):
        return self.parts(fmt) * bytes_per_texel(self.format_in(fmt))


def _warn_of_zero(quantity):
    """A :class:`RangeWarning` where 0 lies inside a component's range but on no RGBA8 code of
    it: a clock written as 0.0 in [-6, 60] read back as -0.00028, and 0.8% of a user's
    particles never came alive. Said with the nearest range (the same lo) that holds 0."""
    import warnings

    from ..errors import RangeWarning

    for axis, (lo, hi) in enumerate(zip(quantity.lo, quantity.hi)):
        if not lo < 0 < hi:
            continue
        lo32, span32 = np.float32([lo]), np.float32([hi]) - np.float32([lo])
        back = float(packing.state_decode(packing.state_encode(np.zeros((1, 1)), lo32, span32,
                                                               "rgba8"), lo32, span32,
                                          "rgba8")[0, 0])
        if back == 0.0:
            continue
        codes = int(np.floor(-lo / (hi - lo) * packing.CODES_PER_UNIT))
        wider = lo + -lo * packing.CODES_PER_UNIT / max(codes, 1)
        warnings.warn(f"quantity {quantity.name!r}: 0 lies on no 16-bit code of [{lo:g}, {hi:g}]"
                      f"{f' (component {AXES[axis]})' if quantity.components > 1 else ''}: "
                      f"stored in rgba8 it reads back as {back:.3g}; a range with lo = 0, or "
                      f"symmetric about 0, holds it exactly (or [{lo:g}, {wider:.12g}])",
                      RangeWarning, stacklevel=4)


def per_component(name, value, components):
    """``value`` (a number, or one per component) as ``components`` finite floats, checked."""
    values = [value] * components if np.ndim(value) == 0 else list(value)
    if len(values) != components:
        raise ParameterError(f"{name} must be a number or {components} numbers, got {value!r}")
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
        count = int(check_range("--particles", count, 1, limit, integer=True))
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


HALF_MAX = 65504.0  # the largest finite half float


class Textures:
    """A resource's textures: one per part, each twice for ping-pong, and a framebuffer each.

    ``fronts`` hold the latest value; a draw writes part k into ``framebuffer(k)`` (the back
    texture) and ``swap()`` makes the backs the fronts, so no draw ever reads and writes one
    texture. A target with ``depth`` has one depth buffer, shared by its framebuffers (with
    ``depth="texture"``, a depth texture that later draws may sample).
    """

    def __init__(self, group, size, fmt, parts=1, buffers=1, depth=False, linear=False):
        self.ctx, self.size, self.fmt = group.ctx, tuple(size), fmt
        self.textures = [[group.texture(self.size, fmt, filter_nearest=not linear)
                          for _ in range(buffers)] for _ in range(parts)]
        self.depth = group.depth(self.size, texture=depth == "texture") if depth else None
        self.framebuffers = [[group.framebuffer(t, self.depth) for t in pair]
                             for pair in self.textures]

    @property
    def parts(self):
        return len(self.textures)

    @property
    def fronts(self):
        """The texture of each part holding the latest value."""
        return [pair[0] for pair in self.textures]

    @property
    def written(self):
        """The texture of each part holding this step's value once its pass has run."""
        return [pair[-1] for pair in self.textures]

    @property
    def ping_pong(self):
        return len(self.textures[0]) == 2

    def framebuffer(self, part=0):
        """The framebuffer a draw writes part ``part`` into (the back of a pair)."""
        return self.framebuffers[part][-1]

    def swap(self):
        if self.ping_pong:
            for pair in self.textures + self.framebuffers:
                pair.reverse()


class StateBuffer(Textures):
    """One quantity's textures (see :class:`Textures`), with its values' encoding: uploads,
    uniform fills and downloads in world units. ``linear``: its textures are filtered LINEAR
    (a float grid quantity the hardware samples; never packed state)."""

    def __init__(self, group, quantity, layout, fmt="rgba8", buffers=2, linear=False):
        if fmt not in STORAGE:
            raise ParameterError(f"format must be one of {list(STORAGE)}, got {fmt!r}")
        if fmt == "rgba16f":
            reach = float(np.max(np.abs(np.concatenate([quantity.lo, quantity.hi]))))
            if reach > HALF_MAX:
                raise ParameterError(f"quantity {quantity.name!r} reaches {reach:.3g}, beyond "
                                     f"rgba16f's largest value {HALF_MAX:g}: store it in rgba8 "
                                     "or rgba32f")
        if linear and fmt not in ("rgba16f", "rgba32f"):
            raise ParameterError(f"quantity {quantity.name!r} is stored {fmt}: packed state "
                                 "cannot be filtered LINEAR (it would mix its bytes)")
        super().__init__(group, layout.size, fmt, quantity.parts(fmt), buffers, linear=linear)
        self.quantity, self.layout = quantity, layout
        # Start at world zero (clamped into the range): a GPU clear to that texel, cheaper than
        # encoding and uploading a zero array.
        texels = zero_texels(quantity, fmt)
        for part, pair in enumerate(self.framebuffers):
            colour = texels[part] / 255.0 if fmt in packing.PACKED else texels[part]
            for framebuffer in pair:
                self.ctx.clear(framebuffer, colour)

    def upload(self, values):
        """Write world values (count, components) into the fronts (clamped to the range); a
        grid quantity's may be (H, W, components)."""
        values = as_rows(self.quantity, self.layout, values)
        self.write_texels(encode_values(self.quantity, self.layout, values, self.fmt))

    def fill_uniform(self, lo, span, rng):
        """Set the fronts to points drawn uniformly from the box [lo, lo + span] (per component,
        clamped to the range): see :func:`fill_texels`."""
        self.write_texels(fill_texels(self.quantity, self.layout, lo, span, rng, self.fmt))

    def write_texels(self, texels):
        """Write texel contents (count, parts, 4) into the fronts as they are: the encoded values
        of ``upload`` and ``fill_uniform``, or raw ones (how the stability suite injects NaN and
        Inf into float state). Spare texels get zeros."""
        texels = np.asarray(texels).reshape(self.layout.count, self.parts, 4)
        if self.fmt in packing.PACKED and (texels.dtype != np.uint8):
            raise ParameterError(f"{self.quantity.name} is stored in {self.fmt}: texels must be "
                                 f"uint8 bytes, got {texels.dtype}")
        for texture, full in zip(self.fronts, part_textures(texels, self.layout, self.fmt)):
            self.ctx.write(texture, full.tobytes())

    def read_texels(self):
        """Raw texel contents (count, parts, 4) of the fronts."""
        raw = [np.frombuffer(self.ctx.read(t), dtype=numpy_dtype(self.fmt)).reshape(-1, 4)
               [: self.layout.count] for t in self.fronts]
        return np.stack(raw, axis=1)

    def download(self):
        """World values (count, components) of the fronts, float64."""
        q = self.quantity
        return packing.state_decode(self.read_texels(), q.lo32, q.span32,
                                    self.fmt).astype(np.float64)


PACKED_TOP = 254 * 257  # both bytes 254: the top code 65024 (255 H + L), whatever the order


def edge_counts(quantity, texels, fmt):
    """(on lo, on hi), per component: how many of ``texels`` (n, parts, 4), stored in ``fmt``
    (the quantity's storage), hold a value on each edge of the quantity's range, counted on the
    codes: a 16-bit code 0 or 65024, a 32-bit value's first code so (its second 0 at lo), a
    float at or beyond lo or lo + span (float32, as a decode gives them)."""
    q, c = quantity, quantity.components
    texels = np.ascontiguousarray(texels)
    if fmt == "rgba8":
        codes = texels.view(np.uint16).reshape(len(texels), -1)[:, :c]
        return ((codes == 0).sum(axis=0), (codes == PACKED_TOP).sum(axis=0))
    if fmt == "rgba8_32":
        pairs = texels.view(np.uint16).reshape(len(texels), -1, 2)[:, :c]
        return (((pairs[..., 0] == 0) & (pairs[..., 1] == 0)).sum(axis=0),
                (pairs[..., 0] == PACKED_TOP).sum(axis=0))
    values = texels[:, 0, :c].astype(np.float32)
    return ((values <= q.lo32).sum(axis=0), (values >= q.lo32 + q.span32).sum(axis=0))


def zero_texels(quantity, fmt):
    """(parts, 4) texels of world zero clamped into the quantity's range: a state's start where
    the scene sets none."""
    return packing.state_encode(np.zeros((1, quantity.components)), quantity.lo32,
                                quantity.span32, quantity.format_in(fmt))[0]


def part_textures(texels, layout, fmt):
    """Each part's whole texture (width * height, 4) of texels (count, parts, 4), the spare
    texels zero."""
    for part in range(texels.shape[1]):
        full = np.zeros((layout.width * layout.height, 4), dtype=numpy_dtype(fmt))
        full[: layout.count] = texels[:, part]
        yield full


def as_rows(quantity, layout, values):
    """``values`` one row an element: a grid quantity's (H, W, components) (3D: (D, H, W,
    components)) as its texels are ordered (:meth:`Grid.texel_rows`); anything else as it is
    (``encode_values`` checks it)."""
    grid = quantity.domain
    return values if grid is None else grid.texel_rows(values)


def encode_values(quantity, layout, values, fmt):
    """The texels (count, parts, 4) of world values (count, components) of ``quantity`` in
    ``fmt`` (clamped to its range): what an upload writes, on EGL or into a WebGL page."""
    q = quantity
    try:
        values = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"{q.name}: values must be numbers, shape ({layout.count}, "
                             f"{q.components}); got {type(values).__name__}") from None
    if values.ndim == 1 and q.components == 1:
        values = values[:, None]
    if values.shape != (layout.count, q.components):
        raise ParameterError(f"{q.name}: values must have shape ({layout.count}, "
                             f"{q.components}), got {values.shape}")
    fmt = q.format_in(fmt)
    if len(values) <= ENCODE_ROWS:
        return packing.state_encode(values, q.lo32, q.span32, fmt)
    first = packing.state_encode(values[:ENCODE_ROWS], q.lo32, q.span32, fmt)
    texels = np.empty((len(values),) + first.shape[1:], first.dtype)
    texels[:ENCODE_ROWS] = first
    for start in range(ENCODE_ROWS, len(values), ENCODE_ROWS):
        rows = slice(start, start + ENCODE_ROWS)
        texels[rows] = packing.state_encode(values[rows], q.lo32, q.span32, fmt)
    return texels


# Rows encoded at a time: packing's float32 temporaries (~30 bytes a value) stay ~100 MB for any
# count, where at 2^26 particles they were 7.5 GiB of a fountain's start (each row is encoded
# on its own, so the texels are the same bytes).
ENCODE_ROWS = 2 ** 20


def fill_texels(quantity, layout, lo, span, rng, fmt):
    """The texels (count, parts, 4) of points drawn uniformly from the box [lo, lo + span] (per
    component, clamped to the range) by numpy generator ``rng``. They are drawn in float32
    straight in the range's unit box and packed from there: for 2^20 two-component particles
    ~25 ms, against ~45-90 ms for drawing float64 world points and encoding those. (float32
    draws have 24 random bits, more than the 16 a packed value keeps.)"""
    q, fmt = quantity, quantity.format_in(fmt)
    offset = ((lo - q.lo32) / q.span32).astype(np.float32)
    scale = (span / q.span32).astype(np.float32)
    unit = packing.clamp_unit(rng.random((layout.count, q.components), dtype=np.float32)
                              * scale + offset)
    if fmt == "rgba8" and q.components % 2 == 0:
        return packing.pack16(unit).reshape(layout.count, q.parts(fmt), 4)
    world = q.lo32 + unit * q.span32
    return packing.state_encode(world, q.lo32, q.span32, fmt)
