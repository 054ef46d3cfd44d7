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

from dataclasses import dataclass, replace

import numpy as np

from ..errors import ParameterError, check_range
from ..frame.order import (FLOAT_KEY_MAX, FORMATS, MAX_COUNT, MIN_INDEX_BITS, Order,  # noqa: F401
                           comparators, index_bits, levels, network_pass, network_sort,
                           order_defines, order_format, plan_merge, plan_order, schedule)
from ..frame.plan import PlanBuilder, Ref, Resource, Stage, Vertices, depth_range
from ..frame.settings import FrameSettings
from ..frame.state import FORMATS as STATE_FORMATS, Layout
from ..gl.bindings import generated_values, stage_interface
from ..gl.context import numpy_dtype
from ..params import Params, param

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


# --- the stages ------------------------------------------------------------------------------

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


@dataclass(frozen=True)
class DepthSort:
    """A feature a :class:`~es2particles.render.sprites.Sprites` rendering takes: its sprites
    drawn back to front, sorted by the whole network every frame (``passes`` None) or by
    ``passes`` merge passes a frame, the order converging over frames as the particles move."""

    passes: int = None

    what = "the depth sort"  # how a refusal names it
    vertex_textures = 1  # the order, sampled in the sprites' vertex shader

    def __post_init__(self):
        if self.passes is not None:
            check_range("sort (merge passes per frame)", self.passes, 1, 10 ** 6, integer=True)

    def attach(self, b, sprites, draw):
        """Plan the network before the sprites' ``draw`` (a
        :class:`~es2particles.render.sprites.SpriteDraw`) and draw them in its order."""
        network = plan_sort(b, b.graph_plan.quantities[sprites.roles["position"]], self.passes)
        draw.defines.update(network.defines(), SORTED=None)
        draw.inputs["u_order"] = Ref("order")
        draw.vertices = b.vertex_data(Vertices("slots", "texels", b.layout.count, network.width,
                                               network.height)).name
        draw.order = "back to front"


@dataclass(frozen=True)
class SortParams(Params):
    """The depth sort's option, for a scene whose sprites take the sort as a feature."""

    sort: str = param("full", text=True, metavar="{full,off,N}",
                      help="back-to-front order: full (the whole sorting network every frame), "
                           "off (texel order), or N merge passes per frame (spread over "
                           "frames, Latta 2004)")

    def check(self):
        super().check()
        if self.sort not in ("full", "off"):
            try:
                passes = int(self.sort)
            except ValueError:
                passes = 0
            if not 1 <= passes <= 10 ** 4 or str(passes) != self.sort.strip():
                raise ParameterError(f"--sort must be full, off or a whole number of merge "
                                     f"passes per frame in [1, 10000], got {self.sort!r}")

    def depth_sort(self):
        """The :class:`DepthSort` this option asks for, or None."""
        if self.sort == "off":
            return None
        return DepthSort() if self.sort == "full" else DepthSort(int(self.sort))


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
