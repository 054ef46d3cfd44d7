"""The parts a frame plan is made of (``plan.py``): resources, vertex data and stages, as data.

Apart from ``plan.py`` so that what adds stages to a plan (the sort order, a neighbour grid, the
renderers) can import them without importing the planner that imports it.
"""

from dataclasses import dataclass, field

import numpy as np

from ..errors import GraphError
from ..gl.context import bytes_per_texel
from ..gl.device import DrawState
from .state import Layout


def format_bytes(n):
    for unit in ("bytes", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.3g} {unit}"
        n /= 1024


def _made(value):
    """``value``, or what it makes where it is a function (data made when its buffer or texture
    is, after the run's memory is checked)."""
    return value() if callable(value) else value


@dataclass(frozen=True)
class Ref:
    """Where a sampler's texture comes from, or where a stage draws: part ``part`` of resource
    ``resource``; of a ping-pong pair, ``front`` (the latest value: last step's, during a step)
    or ``written`` (this step's, written by an earlier pass of the same step); ``depth``: a
    target's depth texture."""

    resource: str
    part: int = 0
    when: str = "front"


@dataclass(frozen=True)
class Resource:
    """A texture (or a pair, for ping-pong) the frame makes.

    ``kind``: ``state`` (a quantity, ``quantity`` its declaration), ``image`` (uploaded once from
    ``data``: an (h, w, 4) uint8 or float32 array, or ASTC blocks) or ``target`` (drawn into; with
    ``depth``, a depth buffer beside it; ``data``, if given, its first contents, or a function
    making them when the texture is made, after the run's memory is checked). ``swap``:
    ``step`` (the pair swaps at the end of each step: state) or ``draw`` (after each draw into it:
    a sort order). ``linear``: sampled with linear filtering (never packed state)."""

    name: str
    kind: str
    size: tuple
    format: str
    parts: int = 1
    buffers: int = 1
    swap: str = None
    depth: bool = False
    linear: bool = False
    data: object = field(default=None, repr=False, compare=False)
    quantity: object = None
    what: str = ""

    def contents(self):
        """The first contents: ``data``, or what its function makes."""
        return _made(self.data)

    @property
    def nbytes(self):
        if self.data is not None and hasattr(self.data, "block"):  # ASTC blocks
            return self.data.nbytes
        w, h = self.size
        colour = self.parts * self.buffers * w * h * bytes_per_texel(self.format)
        return colour + (w * h * 4 if self.depth else 0)

    def describe(self):
        w, h = self.size
        if self.data is not None and hasattr(self.data, "block"):
            kind = (f"ASTC {self.data.block[0]}x{self.data.block[1]} "
                    f"({self.data.bits_per_texel:.2f} bits a texel)")
        else:
            kind = self.format
        count = ""
        if self.parts > 1 or self.buffers > 1:
            count = (f" {self.parts} parts x {self.buffers}" if self.parts > 1
                     else f" x{self.buffers}")
        depth = " + depth" if self.depth else ""
        return f"{self.name}: {kind} {w}x{h}{count}{depth}, {format_bytes(self.nbytes)}"


@dataclass(frozen=True)
class Vertices:
    """Vertex data of the frame's draws. ``texels``: the texel centres of ``count`` cells of a
    ``width`` x ``height`` grid, row by row (a particle's texel, or a sort slot's: ES 1.00 has no
    gl_VertexID), attribute ``a_texel``; ``data``: an array (n, k) of float32 with ``attributes``
    ((name, components), ...) interleaved (a mesh). ``indices``: uint32 vertex indices the draw
    walks (a static index buffer), or None. Either may be a function making the array, called
    when the buffers are made: after the run's memory is checked, so a plan of 2^26 quads is
    refused before gigabytes of corners exist (``index_count``: how many a function of indices
    makes)."""

    name: str
    source: str
    count: int
    width: int = 0
    height: int = 0
    data: object = field(default=None, repr=False, compare=False)
    attributes: tuple = (("a_texel", 2),)
    indices: object = field(default=None, repr=False, compare=False)
    index_count: int = None

    def array(self):
        """The vertex data as an (n, k) float32 array."""
        if self.source == "texels":
            return Layout(self.count, self.width, self.height).texel_uv()
        return np.ascontiguousarray(_made(self.data), dtype=np.float32)

    def index_array(self):
        """The indices as a uint32 array, or None."""
        if self.indices is None:
            return None
        indices = np.ascontiguousarray(_made(self.indices), np.uint32)
        if len(indices) != self.indices_size:  # the memory estimate counted indices_size
            raise GraphError(f"vertex data {self.name!r}: its index function made "
                             f"{len(indices)} indices, not the {self.indices_size} declared")
        return indices

    @property
    def indexed(self):
        return self.indices is not None

    @property
    def indices_size(self):
        """How many indices, without making them."""
        return self.index_count if callable(self.indices) else len(self.indices)


@dataclass(frozen=True)
class Stage:
    """One draw of the frame, complete.

    ``kind`` groups stages for a reader (pass, sort key, sort merge, shadow map, mesh, points,
    sprites, post); executors treat every kind alike. ``inputs``: sampler -> :class:`Ref`;
    ``attributes``: vertex attribute -> the :class:`Ref` of a state texture read back into it
    before each draw (where the vertex shader cannot fetch textures).
    ``target``: the :class:`Ref` it draws into (the back of a pair). ``vertices``: the name of its
    :class:`Vertices`, or None for the full-screen triangle; ``count``: vertices drawn (None:
    all). ``uniforms``: its own values, set strictly (a name the shader does not declare and use
    is an error); ``generated``: the values of its generated interface (ranges, state size and
    count), set where the driver keeps them. ``frame_uniforms``: uniform -> a frame value
    (:func:`frame_value`). ``clear``: a colour its target is cleared to first (and the depth to
    1). ``repeat``: uniform sets, one draw each (the sort's merge passes), of which ``per_frame``
    are drawn each frame, continuing where the last frame stopped (None: all). ``slice``: points
    per draw call where a CPU rasteriser draws better in slices. ``step``: a simulation pass (run
    every step) rather than a stage of the frame. ``swap``: its target's pair swaps right after
    it (the last draw of a write of a versioned quantity: the next read sees it). ``loop``:
    (name, count) of the repeat it belongs to: consecutive stages of one loop run ``count``
    times in a row. ``samples``: draws summed into its target a frame (accumulation): after the
    first, each follows a step of its own with that sample's uniforms (FramePlan.samples)."""

    name: str
    kind: str
    fragment: str
    vertex: str = "lib/fullscreen.vert"
    defines: dict = field(default_factory=dict)
    interface: object = field(default=None, repr=False, compare=False)
    vertex_interface: object = field(default=None, repr=False, compare=False)
    inputs: dict = field(default_factory=dict)
    attributes: dict = field(default_factory=dict)
    target: Ref = None
    vertices: str = None
    primitive: str = "triangles"
    count: int = None
    state: DrawState = DrawState()
    uniforms: dict = field(default_factory=dict)
    generated: dict = field(default_factory=dict)
    frame_uniforms: dict = field(default_factory=dict)
    clear: tuple = None
    repeat: tuple = ()
    per_frame: int = None
    slice: int = None
    step: bool = False
    swap: bool = False
    loop: tuple = None
    samples: int = 1
    what: str = ""

    @property
    def files(self):
        return (self.fragment,) if self.vertex == "lib/fullscreen.vert" else (self.vertex,
                                                                              self.fragment)

    @property
    def reads(self):
        refs = list(self.inputs.values()) + list(self.attributes.values())
        return tuple(dict.fromkeys(ref.resource for ref in refs))
