"""Sorting particles back to front on the GPU, in full-screen fragment passes (ES 2.0 has no
compute shaders, no integers worth the name and one render target).

An *order* is a texture of one texel per *slot*, a power-of-two number of slots n = 2^L >= count
(near square: 2^ceil(L/2) x 2^floor(L/2)), each slot holding a sort key and a particle index
(``shaders/glsl100/lib/order.glsl`` encodes, decodes and compares them). Slots past the count hold
*padding*: the largest key and the slot's own number as index, so they sort after every particle
and never appear among the first ``count`` slots, the ones a renderer draws.

The network sorts the slots with Batcher's odd-even merge sort, L(L+1)/2 passes of
``sort/merge.frag``: one stage of the frame plan drawn once per pass with its (p, k) uniforms,
ping-ponging between the two textures of the ``order`` resource. Odd-even merge, not bitonic: each of its comparators puts the smaller value at the lower
slot, so every pass leaves a sorted order as it is, and the passes can be spread over frames while
the keys change (bitonic stages sort halves in opposite directions and would unsort it).

The key pass (``sort/key.frag``) comes first each frame: each slot keeps the particle it held
last frame and gets its new key, the view depth for the frame's camera, far first; then all passes
of the network run, or only the next few of its cycle (Latta 2004, "Building a Million Particle
System": the order converges over frames and, with coherent motion, stays nearly sorted).
:func:`plan_sort` adds both stages to a frame plan; :class:`SortingNetwork` and
:class:`DepthSorter` run them alone (tests, tools).

Key formats:

- ``rgba8`` (the ES 2.0 baseline): one 32-bit word = key * 2^B + index over the four bytes (RG the
  high 16 bits, BA the low 16), B = max(L, 8) index bits and 32 - B key bits: 2^18 particles leave
  14 key bits, 2^24 (the largest count) 8; fewer than 257 particles get 24 (float32 computes no
  more exactly, hence B >= 8). Words compare as (high16, low16) pairs, by key and then by index:
  the result is numpy's stable argsort of the quantised keys, exactly.
- ``rgba32f``: R = key (float), G = index; the same comparison. No quantisation of the depth.

The numpy twin of the network (:func:`network_pass`, :func:`schedule`) is what the tests check the
GPU against, pass by pass; :func:`sortedness` measures how far an order is from back to front.
"""

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import CapabilityError, ParameterError, check_range
from ..frame.plan import PlanBuilder, Ref, Resource, Stage, depth_range
from ..frame.settings import FrameSettings
from ..frame.state import FORMATS as STATE_FORMATS, Layout
from ..gl.bindings import generated_values, stage_interface
from ..gl.context import numpy_dtype

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


# --- how sorted an order is ------------------------------------------------------------------

@dataclass(frozen=True)
class Sortedness:
    """How far a drawing order is from back to front (0 everywhere: sorted).

    ``adjacent``: the share of neighbouring pairs drawn near before far (the strictest measure:
    particles a few places apart at nearly one depth count as much as far ones). ``displacement``:
    the mean distance, over the particles, from a particle's place in the order to the places it
    could have in a sorted one (ties may go either way), divided by the count. ``discordant``: the
    share of all pairs drawn near before far (Kendall's tau distance). ``depth_error``: the mean,
    over the places of the order, of the difference between the depth drawn there and the depth
    that belongs there, divided by the particles' depth extent (what a wrong blend is made of).
    """

    adjacent: float
    displacement: float
    discordant: float
    depth_error: float

    def __str__(self):
        return (f"{100 * self.adjacent:.2f}% of neighbours and {100 * self.discordant:.3f}% of all "
                f"pairs out of order, mean displacement {100 * self.displacement:.3f}% of the "
                f"count, mean depth error {100 * self.depth_error:.3f}% of the depth extent")


def sortedness(order, depth):
    """:class:`Sortedness` of drawing particles in ``order`` (indices, first drawn first) when
    particle i is at view depth ``depth[i]``: back to front means depth never increases."""
    order = np.asarray(order, dtype=np.int64)
    depth = np.asarray(depth, dtype=np.float64)
    n = len(order)
    if n < 2:
        return Sortedness(0.0, 0.0, 0.0, 0.0)
    drawn = -depth[order]  # must never decrease
    adjacent = float(np.mean(drawn[1:] < drawn[:-1]))
    ranked = np.sort(drawn)
    first = np.searchsorted(ranked, drawn, side="left")  # the places this value may take
    last = np.searchsorted(ranked, drawn, side="right") - 1
    place = np.arange(n)
    miss = np.maximum(first - place, 0) + np.maximum(place - last, 0)
    _, dense = np.unique(drawn, return_inverse=True)
    discordant = _inversions(dense.reshape(-1)) / (n * (n - 1) / 2)
    extent = ranked[-1] - ranked[0]
    error = float(np.abs(drawn - ranked).mean() / extent) if extent > 0 else 0.0
    return Sortedness(adjacent, float(miss.mean() / n), float(discordant), error)


def _inversions(values):
    """Pairs i < j with values[i] > values[j], for non-negative integers: a bottom-up merge sort
    whose levels are counted with one searchsorted each (O(n log^2 n) in numpy, no Python loop
    over elements)."""
    n = len(values)
    size = 1 << max(n - 1, 0).bit_length()
    top = int(values.max()) + 1
    merged = np.full(size, top, dtype=np.int64)  # padding at the end, largest: no inversions
    merged[:n] = values
    total, width = 0, 1
    while width < size:
        pairs = merged.reshape(-1, 2, width)
        offset = (np.arange(len(pairs), dtype=np.int64) * (top + 1))[:, None]
        left = (pairs[:, 0] + offset).ravel()  # sorted as a whole: each row sorted, rows apart
        right = (pairs[:, 1] + offset).ravel()
        not_greater = np.searchsorted(left, right, side="right") - np.repeat(
            np.arange(len(pairs)) * width, width)
        total += int((width - not_greater).sum())
        merged = np.sort(pairs.reshape(len(pairs), 2 * width), axis=1).ravel()
        width *= 2
    return total


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
    it, as desktop drivers and Mesa do for the way the sort shaders write it.)"""
    if fmt is not None:
        if fmt not in FORMATS:
            raise ParameterError(f"fmt must be one of {list(FORMATS)}, got {fmt!r}")
        if fmt != "rgba8" and not caps.renderable.get(fmt):
            raise CapabilityError(f"format {fmt!r} cannot be rendered to on {caps.renderer}")
        return fmt
    return ("rgba32f" if position.format_in(state_format) != "rgba8"
            and caps.renderable.get("rgba32f") else "rgba8")


# --- the stages -------------------------------------------------------------------------------

def plan_order(b, order):
    """Add the ``order`` resource to plan builder ``b``: two textures, swapped after each draw
    into them, the first holding slot i = (key 0, particle i) and padding."""
    # The first contents are made when the texture is, after the run's memory is checked (at
    # 2^24 slots they take ~0.6 GB to make).
    b.resource(Resource("order", "target", order.layout, order.fmt, buffers=2, swap="draw",
                        data=lambda: order.texels(np.zeros(order.count)),
                        what=f"sort order, {order.slots} slots ({order.describe_keys()})"))


def plan_merge(b, order, passes_per_frame=None):
    """Add the merge stage to plan builder ``b``: one draw per pass of the network, or the next
    ``passes_per_frame`` of its cycle each frame."""
    b.stage(Stage("sort merge", "sort merge", "sort/merge.frag", defines=order.defines(),
                  inputs={"u_order": Ref("order")}, target=Ref("order"),
                  uniforms={"u_order_size": (float(order.width), float(order.height))},
                  repeat=tuple({"u_p": float(p), "u_k": float(k)} for p, k in order.schedule),
                  per_frame=passes_per_frame,
                  what="Batcher's odd-even merge sort, the smaller at the lower slot"))


def plan_key(b, order, position):
    """Add the key pass to plan builder ``b``: each slot keeps its particle and gets the
    particle's view depth, far first, read from quantity ``position`` (3 components)."""
    # key.frag calls read_position whatever the quantity's name: its interface is written for a
    # copy named `position`, fed from the quantity's own textures.
    renamed = replace(position, name="position")
    interface = stage_interface(("position",), {"position": renamed}, b.format)
    inputs = {sampler: Ref(position.name, part) for sampler, (_, _, part, _) in
              interface.samplers.items()}
    b.stage(Stage("sort key", "sort key", "sort/key.frag", defines=order.defines(),
                  interface=interface, inputs={**inputs, "u_order": Ref("order")},
                  target=Ref("order"), generated=generated_values(interface, b.layout),
                  frame_uniforms={"u_eye": ("eye",), "u_forward": ("forward",),
                                  "u_depth": ("depth_range", position.lo, position.hi)},
                  what="the view depth of each slot's particle"))


def plan_sort(b, position, passes_per_frame=None, fmt=None):
    """Add depth sorting of the particles to plan builder ``b``, before whatever draws in sorted
    order: the key pass, then the network's passes (all, or ``passes_per_frame`` of its cycle
    each frame; at least the whole network means all). Returns the :class:`Order`."""
    if passes_per_frame is not None:
        passes_per_frame = int(check_range("passes_per_frame", passes_per_frame, 1, None,
                                           integer=True))
    order = Order(b.layout.count, order_format(b.caps, position, b.format, fmt),
                  b.caps.max_texture_size)
    if passes_per_frame is not None and passes_per_frame >= order.passes:
        passes_per_frame = None  # a whole network each frame
    plan_order(b, order)
    plan_key(b, order, position)
    plan_merge(b, order, passes_per_frame)
    b.notes.append(order.describe(passes_per_frame))
    return order


# --- the network on its own (tests and tools) --------------------------------------------------

class SortingNetwork:
    """Batcher's odd-even merge sort of ``count`` (key, index) slots on the GPU, alone: an
    executor of a plan holding the ``order`` resource and the merge stage (and, given a
    ``position`` quantity and its ``state_layout``, the key pass, as :class:`DepthSorter` uses
    it). Attributes are the :class:`Order`'s; ``texture`` is the front order."""

    def __init__(self, ctx, count, fmt="rgba8", position=None, state_layout=None,
                 state_format="rgba8"):
        from ..frame.executor import Executor

        self.executor = None
        self.order = Order(count, fmt, ctx.caps.max_texture_size)
        if fmt != "rgba8":
            ctx.require_format(fmt)
        ctx.make_current()
        b = PlanBuilder("sort", FrameSettings(), ctx.caps)
        b.layout, b.format = state_layout or Layout(count, self.order.width,
                                                     self.order.height), state_format
        external = {}
        plan_order(b, self.order)
        if position is not None:
            b.resource(Resource(position.name, "state", b.layout.size, position.format_in(
                state_format), parts=position.parts(state_format), quantity=position))
            external[position.name] = None
            plan_key(b, self.order, position)
        plan_merge(b, self.order)
        self.plan = b.finish(present="order")
        self.ctx, self.cursor = ctx, 0
        self.executor = Executor(ctx, self.plan, external=external)
        self.merge = self.plan.stage("sort merge")

    def __getattr__(self, name):
        if name in ("count", "fmt", "levels", "width", "height", "slots", "index_bits",
                    "key_bits", "key_max", "schedule", "passes", "layout", "defines", "slot_uv",
                    "describe_keys", "quantise", "encode", "decode"):
            return getattr(self.order, name)
        raise AttributeError(name)

    @property
    def texture(self):
        """The front order: the result of the latest pass."""
        return self.executor.front("order")

    def load(self, keys):
        """Upload ``count`` keys, slot i holding (keys[i], i); the rest padding (see
        :meth:`Order.texels`). Starts a new cycle of ``run(passes)``."""
        texels = self.order.texels(keys)
        self.ctx.write(self.texture, texels.tobytes())
        self.cursor = 0

    def read_slots(self):
        """(keys, indices) of every slot of the front order (padding included)."""
        texels = np.frombuffer(self.executor.read("order"), dtype=numpy_dtype(self.fmt))
        return self.order.decode(texels.reshape(-1, 4))

    def read(self):
        """(keys, indices) of the first ``count`` slots, in order (numpy; for tests and tools)."""
        keys, indices = self.read_slots()
        return keys[: self.count], indices[: self.count]

    def run(self, passes=None):
        """Run the whole network (None), or the next ``passes`` passes of its cycle (wrapping
        around; passes on a sorted order change nothing). A whole run leaves the cycle's place
        where it was."""
        if passes is None:
            todo = range(self.passes)
        else:
            passes = int(check_range("passes", passes, 0, None, integer=True))
            todo = [(self.cursor + i) % self.passes for i in range(passes)] if self.passes else []
            if self.passes:
                self.cursor = (self.cursor + passes) % self.passes
        self.executor.run(self.merge, draws=list(todo))

    def rekey(self, position_buffer, camera):
        """The key pass: re-key the current order for ``camera`` from the positions in
        ``position_buffer`` (a StateBuffer of the position quantity given at construction)."""
        name = next(r.name for r in self.plan.resources.values() if r.kind == "state")
        self.executor.bind(name, position_buffer)
        self.executor.run(self.plan.stage("sort key"), self.executor.frame(camera))

    def release(self):
        """Release the textures and the commands; safe to call twice."""
        if self.executor is not None:
            self.executor.release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()


class DepthSorter:
    """Orders particles back to front for a camera, alone: the key pass and a
    :class:`SortingNetwork`, reading the positions of ``position_quantity`` (3 components) laid
    out as ``state_layout`` in ``state_format``. ``fmt``: the order's format (default: see
    :func:`order_format`); ``passes_per_frame``: None runs the whole network every ``update``,
    k the key pass and the next k passes of the network's cycle."""

    def __init__(self, ctx, position_quantity, state_layout, state_format="rgba8", fmt=None,
                 passes_per_frame=None):
        self.network = None
        if getattr(position_quantity, "components", None) != 3:
            raise ParameterError("position_quantity must be a Quantity of 3 components, got "
                                 f"{position_quantity!r}")
        if passes_per_frame is not None:
            passes_per_frame = int(check_range("passes_per_frame", passes_per_frame, 1, None,
                                               integer=True))
        if state_format not in STATE_FORMATS:
            raise ParameterError(f"state_format must be one of {STATE_FORMATS}, got "
                                 f"{state_format!r}")
        fmt = order_format(ctx.caps, position_quantity, state_format, fmt)
        self.ctx, self.quantity, self.layout = ctx, position_quantity, state_layout
        self.network = SortingNetwork(ctx, state_layout.count, fmt, position_quantity,
                                      state_layout, state_format)
        self.passes_per_frame = passes_per_frame
        if passes_per_frame is not None and passes_per_frame >= self.network.passes:
            self.passes_per_frame = None

    @property
    def texture(self):
        return self.network.texture

    def defines(self):
        return self.network.defines()

    def slot_uv(self):
        return self.network.slot_uv()

    def depth_range(self, camera):
        """(near, far): the view depths of the position box's nearest and farthest corners."""
        return depth_range(self.quantity.lo, self.quantity.hi, camera)

    def update(self, buffers, camera):
        """Re-key the current order for ``camera`` from the positions in ``buffers`` (quantity
        name -> StateBuffer; its fronts are read) and run the network's passes for this frame."""
        self.network.rekey(buffers[self.quantity.name], camera)
        self.network.run(self.passes_per_frame)

    def order(self):
        """The particle indices in drawing order, far first (reads the GPU back: tests)."""
        return self.network.read()[1]

    def describe(self):
        return self.network.order.describe(self.passes_per_frame)

    def release(self):
        """Release the key pass and the network; safe to call twice."""
        if self.network is not None:
            self.network.release()
