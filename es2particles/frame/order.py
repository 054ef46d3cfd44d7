"""A sort order: slots of (key, particle index) sorted by Batcher's odd-even merge network in
full-screen fragment passes, pure numbers and the two plan helpers that add it to a frame plan.

Depth sorting (``render/sort.py``) keys it by view depth for the renderers; a neighbour grid
(``frame/neighbours.py``) keys it by cell inside the simulation step. The layout of the slots,
the word encoding of the keys and the network are described in ``render/sort.py``'s docstring.
"""

import math

import numpy as np

from ..errors import CapabilityError, ParameterError, check_range
from .parts import Ref, Resource, Stage
from .state import Layout

FORMATS = ("rgba8", "rgba32f")
MAX_COUNT = 2 ** 24  # every slot number and index must be an integer float32 holds exactly
MIN_INDEX_BITS = 8  # so the key has at most 24 bits: float32 quantises no more exactly
FLOAT_KEY_MAX = 1.0e38  # ORDER_FLOAT_MAX of lib/order.glsl: the key of padding in rgba32f


# --- the network, pure numpy ------------------------------------------------------------------

def levels(count):
    """L: the slots are 2^L, the smallest power of two >= ``count``."""
    return max(int(count) - 1, 0).bit_length()


def schedule(slots):
    """The (p, k) of each pass of odd-even merge sort over ``slots`` (a power of two), in order:
    p = 1, 2, 4, ..., slots / 2 and, for each, k = p, p / 2, ..., 1; L(L+1)/2 passes."""
    out, p = [], 1
    while p < slots:
        k = p
        while k >= 1:
            out.append((p, k))
            k //= 2
        p *= 2
    return out


def comparators(slots, p, k):
    """The lower slots a of the comparators (a, a + k) of pass (p, k), and the role of every slot:
    (lower, upper) boolean masks over the ``slots``. The same arithmetic as sort/merge.frag."""
    x = np.arange(slots)
    c = 0 if k == p else k  # k mod p
    r = x - c
    phase = np.maximum(r, 0) % (2 * k)
    block = x % (2 * p)
    lower = (r >= 0) & (phase < k) & (block + k < 2 * p)
    upper = (r >= k) & (phase >= k) & (block >= k)
    return lower, upper


def network_pass(values, p, k):
    """The numpy twin of one pass of sort/merge.frag over ``values`` (a power-of-two length of
    anything numpy compares): each comparator (a, a + k) puts the smaller value at a."""
    values = np.asarray(values)
    lower, _ = comparators(len(values), p, k)
    a = np.flatnonzero(lower)
    b = a + k
    swap = values[b] < values[a]
    out = values.copy()
    out[a[swap]], out[b[swap]] = values[b[swap]], values[a[swap]]
    return out


def network_sort(values, passes=None):
    """``values`` (a power-of-two length) after the first ``passes`` passes of the network (all
    of them when None)."""
    out = np.asarray(values).copy()
    for p, k in schedule(len(out))[:passes]:
        out = network_pass(out, p, k)
    return out


def index_bits(count):
    """rgba8: the bits of a word that hold the index (the rest, 32 - this, hold the key)."""
    return max(levels(count), MIN_INDEX_BITS)


def order_defines(fmt, count):
    """The defines of ``lib/order.glsl`` for an order of ``fmt`` over ``count`` particles: the
    split of the rgba8 word (see the module's docstring), or ORDER_FLOAT."""
    if fmt == "rgba32f":
        return {"ORDER_FLOAT": None}
    bits = index_bits(count)
    return {"ORDER_HIGH_MOD": float(2 ** max(bits - 16, 0)),
            "ORDER_LOW_MOD": float(2 ** min(bits, 16)),
            "ORDER_KEY_MAX": float(2 ** (32 - bits) - 1)}


# --- the order: layout and encoding ----------------------------------------------------------

class Order:
    """The slots of an order over ``count`` particles in ``fmt`` (``rgba8`` or ``rgba32f``): pure
    numbers, no GL.

    Attributes
    ----------
    levels, width, height, slots : int
        2^levels slots in a width x height texture (powers of two, near square).
    index_bits, key_bits, key_max : int
        rgba8 only: the word's split, index_bits = max(L, 8), key_bits = 32 - index_bits.
    schedule : list of (p, k)
        Each pass's merge size and comparator distance, in order; ``passes`` of them.
    """

    def __init__(self, count, fmt="rgba8", max_texture_size=None):
        if fmt not in FORMATS:
            raise ParameterError(f"fmt must be one of {list(FORMATS)}, got {fmt!r}")
        self.count = int(check_range("--particles (the sort order's count)", count, 1, MAX_COUNT,
                                     integer=True))
        self.fmt = fmt
        self.levels = levels(self.count)
        self.width, self.height = 2 ** ((self.levels + 1) // 2), 2 ** (self.levels // 2)
        self.slots = self.width * self.height
        if max_texture_size is not None and self.width > max_texture_size:
            raise CapabilityError(f"an order of {self.slots} slots is {self.width} texels wide; "
                                  f"the context's largest texture is {max_texture_size}")
        self.index_bits = index_bits(self.count)
        self.key_bits = 32 - self.index_bits
        self.key_max = 2 ** self.key_bits - 1
        self.schedule = schedule(self.slots)
        self.passes = len(self.schedule)

    @property
    def layout(self):
        """(width, height) of the order texture."""
        return (self.width, self.height)

    def defines(self):
        """The defines ``lib/order.glsl`` needs to decode these slots in any program."""
        return order_defines(self.fmt, self.count)

    def slot_uv(self):
        """Texel centres (count, 2) float32 of the first ``count`` slots, in slot order (row by
        row, as a state Layout numbers particles): the vertex data of a draw in sorted order
        (vertex i decodes slot i)."""
        return Layout(self.count, self.width, self.height).texel_uv()

    def describe_keys(self):
        return f"{self.fmt}: " + (f"{self.key_bits} key bits" if self.fmt == "rgba8"
                                  else "float keys")

    def quantise(self, keys):
        """rgba8 key codes (int64) of float keys in [0, 1] (clamped): round(key * key_max)."""
        keys = np.clip(np.asarray(keys, dtype=np.float64), 0.0, 1.0)
        return np.floor(keys * self.key_max + 0.5).astype(np.int64)

    def encode(self, keys, indices):
        """Texel contents (slots, 4) of (key, index) pairs: the numpy twin of order_encode."""
        if self.fmt == "rgba32f":
            texels = np.zeros((len(keys), 4), dtype=np.float32)
            texels[:, 0], texels[:, 1] = keys, indices
            return texels
        word = (np.asarray(keys, np.uint64) << np.uint64(self.index_bits)) | np.asarray(
            indices, np.uint64)
        # The 32-bit word's bytes, most significant first: its big-endian form, read as bytes
        # (four shifted uint64 copies stacked peaked at 96 bytes a slot; this, at ~36).
        return word.astype(">u4").view(np.uint8).reshape(-1, 4)

    def decode(self, texels):
        """(keys, indices) of texel contents (slots, 4): rgba8 keys as int64 codes."""
        if self.fmt == "rgba32f":
            return texels[:, 0].copy(), texels[:, 1].astype(np.int64)
        b = texels.astype(np.int64)
        word = (b[:, 0] << 24) | (b[:, 1] << 16) | (b[:, 2] << 8) | b[:, 3]
        return word >> self.index_bits, word & ((1 << self.index_bits) - 1)

    def texels(self, keys):
        """The texels (slots, 4) of ``count`` keys, slot i holding (keys[i], i), the rest padding.

        rgba8: floats in [0, 1] (clamped) are quantised onto the key bits (``quantise``); an
        integer array is taken as the codes themselves, 0 .. 2^key_bits - 1. rgba32f: finite
        floats within +-1e38, stored as float32.
        """
        keys = np.asarray(keys)
        if keys.shape != (self.count,):
            raise ParameterError(f"keys must have shape ({self.count},), got {keys.shape}")
        full = np.empty(self.slots, dtype=np.float32 if self.fmt == "rgba32f" else np.int64)
        if self.fmt == "rgba32f":
            keys = keys.astype(np.float64)
            if not np.all(np.abs(keys) <= FLOAT_KEY_MAX):  # NaN fails too
                raise ParameterError("keys must be finite and within +-1e38 in rgba32f")
            full[self.count:] = FLOAT_KEY_MAX
        elif np.issubdtype(keys.dtype, np.integer):
            if keys.size and (keys.min() < 0 or keys.max() > self.key_max):
                raise ParameterError(f"integer keys are codes: they must be in [0, "
                                     f"{self.key_max}] ({self.key_bits} key bits), got "
                                     f"[{keys.min()}, {keys.max()}]")
            full[self.count:] = self.key_max
        else:
            keys = keys.astype(np.float64)
            if not np.all(np.isfinite(keys)):
                raise ParameterError("keys must be finite (rgba8 keys are clamped to [0, 1])")
            keys = self.quantise(keys)
            full[self.count:] = self.key_max
        full[: self.count] = keys
        return self.encode(full, np.arange(self.slots))

    def describe(self, passes_per_frame=None):
        if passes_per_frame is None or passes_per_frame >= self.passes:
            passes = f"{self.passes} odd-even merge passes per frame"
        else:
            frames = math.ceil(self.passes / passes_per_frame)
            passes = (f"{passes_per_frame} of {self.passes} odd-even merge passes per frame "
                      f"(the whole network every {frames} frames)")
        return (f"sort: key pass + {passes} over {self.slots} slots ({self.describe_keys()}), "
                f"back to front")


def order_format(caps, position, state_format, fmt=None):
    """The order's format: ``fmt`` if given, else ``rgba8`` with rgba8 positions (the ES 2.0 path
    throughout) and ``rgba32f`` (no quantisation of the depth) where the positions already are
    float and the context renders rgba32f. (ES 1.00 declares gl_FragColor mediump: bytes survive
    that on any driver, float keys and indices only where the driver writes highp values through
    it, as desktop drivers and Mesa do for the way the sort shaders write it.) A context whose
    fragment shaders have no highp float (the article's Tegra row) is refused in one line:
    the comparators decode 16-bit keys and carry particle indices past mediump's 10 bits, in
    either format."""
    if not caps.fragment_highp:
        bits = caps.precision["fragment"]["medium float"][2]
        raise CapabilityError(f"a sort order (the depth sort, a neighbour grid) compares 16-bit "
                              f"keys and carries particle indices in fragment shaders, which "
                              f"need highp float: this context's best is mediump, {bits} bits "
                              "(a depth sort can be switched off where the scene offers it, "
                              "--sort off; a neighbour grid cannot do without)")
    if fmt is not None:
        if fmt not in FORMATS:
            raise ParameterError(f"fmt must be one of {list(FORMATS)}, got {fmt!r}")
        if fmt != "rgba8" and not caps.renderable.get(fmt):
            raise CapabilityError(f"format {fmt!r} cannot be rendered to on {caps.renderer}")
        return fmt
    return ("rgba32f" if position.format_in(state_format) in ("rgba16f", "rgba32f")
            and caps.renderable.get("rgba32f") else "rgba8")


# --- the stages -------------------------------------------------------------------------------

def plan_order(b, order, name="order", what="sort order"):
    """Add resource ``name``, the slots of ``order``, to plan builder ``b``: two textures,
    swapped after each draw into them, the first holding slot i = (key 0, particle i) and
    padding."""
    # The first contents are made when the texture is, after the run's memory is checked (at
    # 2^24 slots they take ~0.6 GB to make).
    b.resource(Resource(name, "target", order.layout, order.fmt, buffers=2, swap="draw",
                        data=lambda: order.texels(np.zeros(order.count)),
                        what=f"{what}, {order.slots} slots ({order.describe_keys()})"))


def plan_merge(b, order, passes_per_frame=None, name="order", stage="sort merge", step=False):
    """Add the merge stage to plan builder ``b``: one draw per pass of the network over resource
    ``name``, or the next ``passes_per_frame`` of its cycle each frame; ``step``: a stage of the
    simulation step (a neighbour grid's sort) rather than of the frame."""
    b.stage(Stage(stage, "sort merge", "sort/merge.frag", defines=order.defines(),
                  inputs={"u_order": Ref(name)}, target=Ref(name),
                  uniforms={"u_order_size": (float(order.width), float(order.height))},
                  repeat=tuple({"u_p": float(p), "u_k": float(k)} for p, k in order.schedule),
                  per_frame=passes_per_frame, step=step,
                  what="Batcher's odd-even merge sort, the smaller at the lower slot"))
