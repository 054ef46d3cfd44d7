"""The pass graph: passes declare what they read and write; a plan orders and prunes them.

Pure Python, no GL: a :class:`Plan` says which passes run in which order, which quantities get
textures (two for ping-pong where last step's value is read, one where only this step's is), and
what was left out because the requested outputs do not need it. ``simulation.py`` executes a plan.

Reads are explicit about time, because the same name means two values during a step:

- ``reads``: last step's value (the front texture). Creates no ordering between passes.
- ``reads_new``: this step's value, written earlier in the same step; the writer is ordered first.
  A cycle of ``reads_new`` is an error: no order could satisfy it.
"""

from dataclasses import dataclass, field
from typing import Mapping, Tuple

from .errors import GraphError, ParameterError
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
        Quantities read as last step's and this step's values; each is bound to the sampler
        ``u_<name>`` with its range in ``u_<name>_range``.
    uniforms : mapping
        Initial values of the pass's own uniforms (change them with ``Simulation.set_uniform``).
    defines : mapping
        ``#define`` lines injected into the shader.
    """

    name: str
    frag: str
    writes: str
    reads: Tuple[str, ...] = ()
    reads_new: Tuple[str, ...] = ()
    uniforms: Mapping = field(default_factory=dict)
    defines: Mapping = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "reads", tuple(self.reads))
        object.__setattr__(self, "reads_new", tuple(self.reads_new))
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
    buffers: dict  # name -> 1 or 2 textures
    outputs: tuple
    left_out_passes: list
    left_out_quantities: list

    @property
    def texture_count(self):
        return sum(self.buffers.values())

    def __str__(self):
        lines = [f"outputs: {', '.join(self.outputs)}", "passes, in order:"]
        for i, p in enumerate(self.passes, 1):
            reads = [f"{q} (last step)" for q in p.reads] + [f"{q} (this step)" for q in p.reads_new]
            lines.append(f"  {i}. {p.name}: {p.frag} writes {p.writes}; reads "
                         f"{', '.join(reads) if reads else 'nothing'}")
        lines.append(f"textures: {self.texture_count}")
        for name, n in self.buffers.items():
            why = "ping-pong: last step's value is read" if n == 2 else "single: only this step's value is read"
            lines.append(f"  {name}: {n} ({why})")
        left = [f"pass {p.name}" for p in self.left_out_passes]
        left += [f"quantity {q}" for q in self.left_out_quantities]
        lines.append("left out: " + (", ".join(left) if left else "nothing"))
        return "\n".join(lines)


class PassGraph:
    """Quantities and the passes that write them; :meth:`plan` decides what a step runs."""

    def __init__(self):
        self.quantities = {}
        self.passes = []

    def quantity(self, name, lo, hi):
        """Declare a two-component quantity with world range [lo, hi]; returns it."""
        if name in self.quantities:
            raise GraphError(f"quantity {name!r} is declared twice")
        self.quantities[name] = Quantity(name, lo, hi)
        return self.quantities[name]

    def add(self, *args, **kwargs):
        """Add a :class:`Pass` (or build one from the same arguments); returns it."""
        new = args[0] if args and isinstance(args[0], Pass) else Pass(*args, **kwargs)
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
        outputs = tuple(outputs)
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
        return Plan(
            passes=ordered,
            quantities={q: self.quantities[q] for q in buffers},
            buffers=buffers,
            outputs=outputs,
            left_out_passes=[p for p in self.passes if p.name not in needed],
            left_out_quantities=[q for q in self.quantities if q not in buffers],
        )

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
