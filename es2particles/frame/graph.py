"""The pass graph: passes declare what they read and write; a plan orders and prunes them.

Pure Python, no GL: a :class:`Plan` says which passes run in which order, which quantities get
textures (two for ping-pong where last step's value is read, one where only this step's is; a
quantity of three or four components in RGBA8 has two parts, each written by its own draw), which
scene textures are sampled, and what was left out because the requested outputs do not need it.
``executor.py`` runs a plan (under a ``Simulation`` or a ``Pipeline``).

Reads are explicit about time, because the same name means two values during a step:

- ``reads``: last step's value (the front texture). Creates no ordering between passes.
- ``reads_new``: this step's value, written earlier in the same step; the writer is ordered first.
  A cycle of ``reads_new`` is an error: no order could satisfy it.
"""

from dataclasses import dataclass, field
from typing import Mapping, Tuple

import numpy as np

from ..errors import GraphError, ParameterError
from .state import Quantity

@dataclass(frozen=True)
class Pass:
    """One full-screen fragment pass that writes exactly one quantity (ES 2.0: one target).

    Parameters
    ----------
    name : str
        Unique name, shown in the plan.
    frag : str
        Fragment shader: a library name (``dejong.frag``) or a path to the user's own file.
    writes : str
        The quantity this pass writes, encoded with ``state_encode(value, u_out_range)``.
    reads, reads_new : tuple of str
        Quantities read as last step's and this step's values: the shader calls ``read_<q>(uv)``.
    textures : tuple of str
        Scene textures (``PassGraph.texture``) the pass samples as ``u_<name>``.
    uniforms : mapping
        The pass's own uniforms and their first values; the graph declares each for the shader
        (see ``bindings.py``), and ``Simulation.set_uniform`` changes them.
    defines : mapping
        ``#define`` lines of this pass's variant: a pass carries all it needs.

    The shader holds only its logic: the graph writes its declarations (``bindings.py``).
    """

    name: str
    frag: str
    writes: str
    reads: Tuple[str, ...] = ()
    reads_new: Tuple[str, ...] = ()
    textures: Tuple[str, ...] = ()
    uniforms: Mapping = field(default_factory=dict)
    defines: Mapping = field(default_factory=dict)

    def stage(self, part=0):
        """How errors and plans name draw ``part`` of this pass."""
        return f"pass {self.name!r}" + (f" (part {part + 1})" if part else "")

    def __post_init__(self):
        for name in ("reads", "reads_new", "textures"):
            value = getattr(self, name)
            object.__setattr__(self, name, (value,) if isinstance(value, str) else tuple(value))
        object.__setattr__(self, "uniforms", dict(self.uniforms or {}))
        object.__setattr__(self, "defines", dict(self.defines or {}))
        both = set(self.reads) & set(self.reads_new)
        if both:
            raise GraphError(f"pass {self.name!r} reads {sorted(both)} both as last step's and this "
                             "step's value; a sampler name u_<quantity> can hold only one")
        if self.writes in self.reads_new:
            raise GraphError(f"pass {self.name!r} cannot read this step's value of "
                             f"{self.writes!r}, which it writes itself")


@dataclass
class Plan:
    """What one step executes: passes in order and the textures they need."""

    passes: list
    quantities: dict  # name -> Quantity, of the quantities that get textures
    buffers: dict  # name -> 1 or 2 textures per part
    outputs: tuple
    left_out_passes: list
    left_out_quantities: list
    textures: dict = field(default_factory=dict)  # scene textures sampled: name -> array
    left_out_textures: list = field(default_factory=list)

    @property
    def texture_count(self):
        """State textures in the baseline format (RGBA8): each part of each quantity, 1 or 2."""
        return self.texture_count_in("rgba8")

    def texture_count_in(self, fmt):
        return sum(n * self.quantities[q].parts(fmt) for q, n in self.buffers.items())

    def draws(self, fmt):
        """(pass, part, parts) of each full-screen draw of a step, in order."""
        out = []
        for p in self.passes:
            parts = self.quantities[p.writes].parts(fmt)
            out += [(p, part, parts) for part in range(parts)]
        return out

    def describe(self, fmt="rgba8", layout=None):
        """The plan as lines, with the draws and textures of storage format ``fmt`` and, given a
        :class:`~es2particles.frame.state.Layout`, the bytes of each texture."""
        from ..gl.context import bytes_per_texel

        texel_count = layout.width * layout.height if layout is not None else None
        lines = [f"outputs: {', '.join(self.outputs)}", "passes, in order:"]
        for i, (p, part, parts) in enumerate(self.draws(fmt), 1):
            reads = [f"{q} (last step)" for q in p.reads] + [f"{q} (this step)" for q in p.reads_new]
            reads += [f"texture {t}" for t in p.textures]
            q = self.quantities[p.writes]
            what = p.writes
            if parts > 1:
                what += f" part {part + 1}/{parts} ({q.part_axes(fmt, part)})"
            lines.append(f"  {i}. {p.name}: {p.frag} writes {what}; reads "
                         f"{', '.join(reads) if reads else 'nothing'}")
        per_particle = sum(n * self.quantities[q].bytes_per_particle(fmt)
                           for q, n in self.buffers.items())
        others = ", ".join(f"{f} {sum(n * self.quantities[q].bytes_per_particle(f) for q, n in self.buffers.items())}"
                           for f in ("rgba8", "rgba16f", "rgba32f") if f != fmt)
        lines.append(f"state textures ({fmt}): {self.texture_count_in(fmt)}, {per_particle} bytes "
                     f"per particle (in {others})")
        for name, n in self.buffers.items():
            q = self.quantities[name]
            why = ("ping-pong: last step's value is read" if n == 2
                   else "single: only this step's value is read")
            parts = q.parts(fmt)
            count = f"{n}" if parts == 1 else f"{parts} parts x {n}"
            size = ""
            if texel_count is not None:
                size = f", {format_bytes(n * parts * texel_count * bytes_per_texel(q.format_in(fmt)))}"
            pinned = f", always {q.storage}" if q.storage else ""
            lines.append(f"  {name} ({q.components} components{pinned}): {count} ({why}{size})")
        for name, data in self.textures.items():
            if hasattr(data, "block"):  # astc.Compressed
                kind = f"ASTC {data.block[0]}x{data.block[1]} ({data.bits_per_texel:.2f} bits a texel)"
                lines.append(f"  scene texture {name}: {data.width}x{data.height} {kind}, "
                             f"{format_bytes(data.nbytes)}")
            else:
                lines.append(f"  scene texture {name}: {data.shape[1]}x{data.shape[0]} "
                             f"{data.dtype}, {format_bytes(data.nbytes)}")
        left = [f"pass {p.name}" for p in self.left_out_passes]
        left += [f"quantity {q}" for q in self.left_out_quantities]
        left += [f"texture {t}" for t in self.left_out_textures]
        lines.append("left out: " + (", ".join(left) if left else "nothing"))
        return lines

    def __str__(self):
        return "\n".join(self.describe())


def format_bytes(n):
    for unit in ("bytes", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.3g} {unit}"
        n /= 1024


class PassGraph:
    """Quantities and the passes that write them; :meth:`plan` decides what a step runs."""

    def __init__(self):
        self.quantities = {}
        self.passes = []
        self.textures = {}
        self.notes = []  # lines for the printed plan (a fallback taken, say)

    def quantity(self, name, lo, hi, components=None, storage=None):
        """Declare a quantity of 1 to 4 components with world range [lo, hi] (numbers, or one
        per component; ``components`` defaults to their length, else 2); ``storage`` pins its
        format (see :class:`~es2particles.frame.state.Quantity`); returns it."""
        if name in self.quantities:
            raise GraphError(f"quantity {name!r} is declared twice")
        self.quantities[name] = Quantity(name, lo, hi, components, storage)
        return self.quantities[name]

    def texture(self, name, data):
        """Declare a scene texture: ``data`` is an (h, w, 4) uint8, float16 or float32 array (a
        collision field, a ramp; stored RGBA8, RGBA16F or RGBA32F), or :class:`~es2particles.gl.astc.Compressed` blocks. The simulation uploads
        it, samples it NEAREST and owns it; a pass that lists ``name`` in ``textures=`` samples it
        as ``u_<name>``."""
        from ..gl.astc import Compressed

        if not (isinstance(name, str) and name.isidentifier()):
            raise ParameterError(f"texture name must be a GLSL identifier, got {name!r}")
        if name in self.textures:
            raise GraphError(f"texture {name!r} is declared twice")
        if isinstance(data, Compressed):
            self.textures[name] = data
            return data
        data = np.asarray(data)
        if data.ndim != 3 or data.shape[2] != 4 or \
                data.dtype not in (np.uint8, np.float16, np.float32):
            raise ParameterError(f"texture {name!r}: data must be an (h, w, 4) uint8, float16 or "
                                 f"float32 array, got shape {data.shape} {data.dtype}")
        self.textures[name] = data
        return data

    def add(self, name, frag, writes, reads=(), reads_new=(), textures=(), uniforms=None,
            defines=None):
        """Add a :class:`Pass` built from these arguments (see :class:`Pass`); returns it."""
        return self.add_pass(Pass(name, frag, writes, reads, reads_new, textures, uniforms or {},
                                  defines or {}))

    def add_pass(self, new):
        """Add a :class:`Pass`; returns it."""
        for other in self.passes:
            if other.name == new.name:
                raise GraphError(f"two passes are named {new.name!r}")
            if other.writes == new.writes:
                raise GraphError(f"passes {other.name!r} and {new.name!r} both write "
                                 f"{new.writes!r}; a quantity has one writer per step")
        self.passes.append(new)
        return new

    def writer(self, quantity):
        return next((p for p in self.passes if p.writes == quantity), None)

    def plan(self, outputs=None):
        """The :class:`Plan` computing ``outputs`` (default: every written quantity)."""
        if outputs is None:
            outputs = [p.writes for p in self.passes]
        outputs = (outputs,) if isinstance(outputs, str) else tuple(outputs)  # one name or several
        if not outputs:
            raise ParameterError("outputs must name at least one quantity")
        self._check()
        for name in outputs:
            if name not in self.quantities:
                raise GraphError(f"output {name!r} is not a declared quantity "
                                 f"(declared: {', '.join(self.quantities) or 'none'})")
            if self.writer(name) is None:
                raise GraphError(f"output {name!r} is written by no pass")
        needed = self._needed(outputs)
        ordered = self._order([p for p in self.passes if p.name in needed])
        used = {p.writes for p in ordered}
        last_step = {q for p in ordered for q in p.reads}
        buffers = {q: (2 if q in last_step else 1) for q in self.quantities if q in used}
        sampled = {t for p in ordered for t in p.textures}
        return Plan(
            passes=ordered,
            quantities={q: self.quantities[q] for q in buffers},
            buffers=buffers,
            outputs=outputs,
            left_out_passes=[p for p in self.passes if p.name not in needed],
            left_out_quantities=[q for q in self.quantities if q not in buffers],
            textures={t: data for t, data in self.textures.items() if t in sampled},
            left_out_textures=[t for t in self.textures if t not in sampled],
        )

    def uniform_names(self):
        """Every uniform some pass of the graph declares (planned or not)."""
        return {name for p in self.passes for name in p.uniforms}

    def _check(self):
        for p in self.passes:
            if p.writes not in self.quantities:
                raise GraphError(f"pass {p.name!r} writes {p.writes!r}, which is not a declared "
                                 "quantity")
            for q in p.reads + p.reads_new:
                if q not in self.quantities:
                    raise GraphError(f"pass {p.name!r} reads {q!r}, which is not a declared "
                                     "quantity")
                if self.writer(q) is None:
                    raise GraphError(f"pass {p.name!r} reads {q!r}, but no pass writes it")
            for t in p.textures:
                if t not in self.textures:
                    raise GraphError(f"pass {p.name!r} samples texture {t!r}, which is not "
                                     f"declared (declared: {', '.join(self.textures) or 'none'})")

    def _needed(self, outputs):
        """Names of the passes the outputs depend on, through either kind of read."""
        needed, todo = set(), list(outputs)
        while todo:
            writer = self.writer(todo.pop())
            if writer.name not in needed:
                needed.add(writer.name)
                todo.extend(writer.reads + writer.reads_new)
        return needed

    def _order(self, passes):
        """Topological order over this-step reads, declaration order among equals."""
        ordered, placed, visiting = [], set(), []
        by_output = {p.writes: p for p in passes}

        def visit(p):
            if p.name in placed:
                return
            if p.name in visiting:
                cycle = visiting[visiting.index(p.name):] + [p.name]
                raise GraphError("passes form a cycle through this step's reads: "
                                 + " -> ".join(cycle))
            visiting.append(p.name)
            for q in p.reads_new:
                visit(by_output[q])
            visiting.pop()
            placed.add(p.name)
            ordered.append(p)

        for p in passes:
            visit(p)
        return ordered
