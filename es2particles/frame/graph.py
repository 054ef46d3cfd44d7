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

A quantity may be written by several passes in one step (advect, add forces, project), or by a
pass repeated k times (:meth:`PassGraph.repeat`: a Jacobi solve). Such a quantity is *versioned*
(Filament's FrameGraph: each write makes a new version): its writers run in their declared order,
each write goes to the back of its pair and the pair swaps at once, so a ``reads_new`` sees the
latest version written before the reader (in declaration order), and ``reads`` (last step's) is
allowed only before its first writer. A read of a version not yet written is an error naming the
pass and the quantity; ``plan`` shows each pass's versions.

Quantities live on the particles or on a :class:`~es2particles.frame.state.Grid` of their own size
(:meth:`PassGraph.grid`); a pass runs over the domain of the quantity it writes.

Particles see each other through a *neighbour grid* (:meth:`PassGraph.neighbours`): built in
the step from a quantity of theirs (sorted by cell, then a table of each cell's first particle:
``frame/neighbours.py``), read by passes declared with ``neighbours=``, which loop over the
particles of the cells around a point (``lib/neighbours.glsl``). It is ordered and pruned as a
pass is: built after what it reads, before what reads it, and left out when nothing does.
"""

import math
from dataclasses import dataclass, field, replace
from typing import Mapping, Tuple

import numpy as np

from ..errors import GraphError, ParameterError, check_range
from contextlib import contextmanager

from .neighbours import NeighbourGrid
from .parts import format_bytes  # noqa: F401 (the plan's words; render/points.py imports it here)
from .state import Grid, Quantity

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
    neighbours : str
        The neighbour grid (:meth:`PassGraph.neighbours`) whose loop the shader runs
        (``FOR_EACH_NEIGHBOUR``, ``lib/neighbours.glsl``); the pass runs after the grid is built.

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
    repeat: str = None  # the PassGraph.repeat group it belongs to
    neighbours: str = None  # the neighbour grid it reads
    builds: str = None  # the neighbour grid this node builds (not a shader of its own)

    def stage(self, part=0):
        """How errors and plans name draw ``part`` of this pass."""
        return f"pass {self.name!r}" + (f" (part {part + 1})" if part else "")

    def __post_init__(self):
        for name in ("reads", "reads_new", "textures"):
            value = getattr(self, name)
            object.__setattr__(self, name, (value,) if isinstance(value, str) else tuple(value))
        object.__setattr__(self, "uniforms", dict(self.uniforms or {}))
        object.__setattr__(self, "defines", dict(self.defines or {}))
        if self.neighbours is not None and self.neighbours not in self.reads_new:
            # ordered after the grid's build, as a read of this step's value of it
            object.__setattr__(self, "reads_new", self.reads_new + (self.neighbours,))
        both = set(self.reads) & set(self.reads_new)
        if both:
            raise GraphError(f"pass {self.name!r} reads {sorted(both)} both as last step's and this "
                             "step's value; a sampler name u_<quantity> can hold only one")


@dataclass(frozen=True)
class Repeat:
    """A group of passes run ``count`` times in a row inside each step (a Jacobi solve)."""

    name: str
    count: int
    passes: tuple = ()


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
    versioned: tuple = ()  # quantities written more than once a step (swapped after each write)
    repeats: dict = field(default_factory=dict)  # name -> Repeat, of the planned passes
    grids: dict = field(default_factory=dict)  # name -> Grid, of the planned quantities
    neighbours: dict = field(default_factory=dict)  # name -> NeighbourGrid, of those built

    def domain_of(self, quantity):
        """The Grid ``quantity`` lives on, or None for the particles."""
        return self.quantities[quantity].domain

    def versions(self):
        """pass name -> ({quantity: (first, last) version read}, (first, last) version written
        or None), for the plan's words: a versioned quantity's writes are numbered in run order
        (version 0 is last step's); a pass in a repeat spans the versions of its iterations."""
        seen, out = {q: 0 for q in self.versioned}, {}
        for p in self.passes:
            count = self.repeats[p.repeat].count if p.repeat else 1
            reads = {q: (0, 0) for q in p.reads if q in seen}  # last step's: version 0
            reads.update({q: (seen[q], seen[q] + count - 1) if q == p.writes
                          else (seen[q], seen[q]) for q in p.reads_new if q in seen})
            written = None
            if p.writes in seen:
                written = (seen[p.writes] + 1, seen[p.writes] + count)
                seen[p.writes] += count
            out[p.name] = (reads, written)
        return out

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
            parts = 1 if p.builds else self.quantities[p.writes].parts(fmt)
            out += [(p, part, parts) for part in range(parts)]
        return out

    def describe(self, fmt="rgba8", layout=None):
        """The plan as lines, with the draws and textures of storage format ``fmt`` and, given a
        :class:`~es2particles.frame.state.Layout`, the bytes of each texture."""
        from ..gl.context import bytes_per_texel

        texel_count = layout.width * layout.height if layout is not None else None
        lines = [f"outputs: {', '.join(self.outputs)}"]
        for grid in self.grids.values():
            lines.append(f"grid {grid.name}: {grid.describe()}, one texel a cell")
        lines.append("passes, in order:")
        versions = self.versions()

        def version(span):
            first, last = span
            return f"v{first}" if first == last else f"v{first}..v{last}"

        open_repeat = None
        for i, (p, part, parts) in enumerate(self.draws(fmt), 1):
            if p.repeat != open_repeat and p.repeat is not None:
                r = self.repeats[p.repeat]
                lines.append(f"  repeat {r.name}: {r.count} iterations of "
                             f"{', '.join(r.passes)}, ping-ponging")
            open_repeat = p.repeat
            if p.builds:
                n = self.neighbours[p.builds]
                lines.append(f"  {i}. {p.name}: neighbour grid of {n.of} "
                             f"({'this step' if n.this_step else 'last step'}) over "
                             f"{'x'.join(map(str, n.grid.shape))} cells: a key pass, a sort "
                             f"by cell, a table of each cell's first particle")
                continue
            mine, written = versions[p.name]
            reads = [f"{q} (last step)" if q not in mine else f"{q} ({version(mine[q])})"
                     for q in p.reads]
            reads += [f"{q} (this step)" if q not in mine else f"{q} ({version(mine[q])})"
                      for q in p.reads_new if q != p.neighbours]
            if p.neighbours:
                reads.append(f"neighbours {p.neighbours} (at most "
                             f"{self.neighbours[p.neighbours].bound} a row of 3 cells)")
            reads += [f"texture {t}" for t in p.textures]
            q = self.quantities[p.writes]
            what = p.writes
            if written is not None:
                what += f" ({version(written)})"
            if parts > 1:
                what += f" part {part + 1}/{parts} ({q.part_axes(fmt, part)})"
            where = f" over grid {q.domain.name}" if q.domain is not None else ""
            indent = "    " if p.repeat else "  "
            lines.append(f"{indent}{i}. {p.name}: {p.frag} writes {what}{where}; reads "
                         f"{', '.join(reads) if reads else 'nothing'}")
        particle_buffers = {q: n for q, n in self.buffers.items()
                            if self.quantities[q].domain is None}
        per_particle = sum(n * self.quantities[q].bytes_per_particle(fmt)
                           for q, n in particle_buffers.items())
        others = ", ".join(f"{f} {sum(n * self.quantities[q].bytes_per_particle(f) for q, n in particle_buffers.items())}"
                           for f in ("rgba8", "rgba16f", "rgba32f") if f != fmt)
        lines.append(f"state textures ({fmt}): {self.texture_count_in(fmt)}, {per_particle} bytes "
                     f"per particle (in {others})")
        for name, n in self.buffers.items():
            q = self.quantities[name]
            why = ("ping-pong: last step's value is read" if n == 2
                   else "single: only this step's value is read")
            if name in self.versioned:
                why = "ping-pong: written more than once a step, swapped after each write"
            parts = q.parts(fmt)
            count = f"{n}" if parts == 1 else f"{parts} parts x {n}"
            size = ""
            texels = (math.prod(q.domain.size) if q.domain is not None else texel_count)
            if texels is not None:
                size = f", {format_bytes(n * parts * texels * bytes_per_texel(q.format_in(fmt)))}"
            pinned = (f", always {q.storage}" if q.storage
                      else f", {q.format_in(fmt)}: 32 bits a value" if q.format_in(fmt) != fmt
                      else "")
            where = f", on grid {q.domain.name}" if q.domain is not None else ""
            lines.append(f"  {name} ({q.components} components{pinned}{where}): {count} "
                         f"({why}{size})")
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


class PassGraph:
    """Quantities and the passes that write them; :meth:`plan` decides what a step runs."""

    def __init__(self):
        self.quantities = {}
        self.passes = []
        self.textures = {}
        self.grids = {}
        self.repeats = {}
        self.neighbour_grids = {}
        self.notes = []  # lines for the printed plan (a fallback taken, say)
        self._repeating = None  # the Repeat being declared (inside ``with g.repeat(...)``)

    def grid(self, name, shape, box=None):
        """Declare a grid domain of ``shape`` (W, H) cells over the world rectangle ``box``
        ((x0, y0), (x1, y1); default the cells themselves), or (W, H, D) cells over the box
        ((x0, y0, z0), (x1, y1, z1)), stored as an atlas of its slices; returns its
        :class:`~es2particles.frame.state.Grid`, to give ``quantity(..., domain=)``."""
        if name in self.grids or name == "particles":
            raise GraphError(f"grid {name!r} is declared twice" if name in self.grids else
                             "'particles' is the particles' domain: name the grid otherwise")
        self.grids[name] = Grid(name, shape, box)
        return self.grids[name]

    def quantity(self, name, lo, hi, components=None, storage=None, domain=None, bits=16,
                 sampling="hand", clamps="both"):
        """Declare a quantity of 1 to 4 components with world range [lo, hi] (numbers, or one
        per component; ``components`` defaults to their length, else 2); ``storage`` pins its
        format (see :class:`~es2particles.frame.state.Quantity`); ``domain``: the grid it lives
        on (a :meth:`grid` or its name; None: the particles); ``bits=32``: kept to float32's
        precision in every format (32-bit packed where the simulation's holds less);
        ``sampling="hardware"``: a grid quantity's ``sample_q`` filtered by the hardware where
        it is stored as floats the context filters (see
        :class:`~es2particles.frame.state.Quantity`); ``clamps``: the edges of the range where a
        value means a clamped write (``"both"``; ``"lo"``, ``"hi"``, or ``"none"`` where an edge
        is a value the physics holds: a wall, a unit vector, a density's 0); returns it."""
        if name in self.quantities:
            raise GraphError(f"quantity {name!r} is declared twice")
        if isinstance(domain, str):
            if domain not in self.grids:
                raise GraphError(f"quantity {name!r}: grid {domain!r} is not declared (grids: "
                                 f"{', '.join(self.grids) or 'none'})")
            domain = self.grids[domain]
        elif domain is not None and self.grids.get(getattr(domain, "name", None)) is not domain:
            raise GraphError(f"quantity {name!r}: its domain must be a grid this graph declares "
                             "(PassGraph.grid)")
        self.quantities[name] = Quantity(name, lo, hi, components, storage, domain, bits,
                                         sampling, clamps)
        return self.quantities[name]

    def neighbours(self, name, of, cell, box=None, bound=64, this_step=False, sets=""):
        """Declare neighbour grid ``name``: square cells of side ``cell`` over ``box`` ((x0, y0),
        (x1, y1), or in 3D ((x0, y0, z0), (x1, y1, z1)); default the range of ``of``, grown to
        whole cells) holding the particles by the cell of their quantity ``of`` (2 or 3
        components, on the particles: the grid's dimensions), last step's value, or this
        step's (``this_step``: built after ``of``'s writers). A pass declared with
        ``neighbours=name`` visits, for a point, the particles of the 3 x 3 (x 3) cells around it:
        every particle within ``cell`` of the point, and others (test the distance). A point
        outside the box takes the nearest cell, as particles outside it are held: the search
        stays exact. ``bound``: the most particles a pass's loop visits in a row of 3 cells
        (GLSL ES 1.00 loops have constant bounds); a row holding more is an error when checked
        (:meth:`~es2particles.frame.simulation.Simulation.check_neighbours`). ``sets``: what
        sets the cell (a scene's option: "--radii's largest"), named where too many cells are
        refused. Returns the :class:`~es2particles.frame.neighbours.NeighbourGrid`."""
        if name in self.neighbour_grids or name in self.quantities:
            raise GraphError(f"neighbour grid {name!r} is declared twice" if name in
                             self.neighbour_grids else f"neighbour grid {name!r}: a quantity "
                             "has that name")
        source = self.quantities.get(of)
        if source is None or source.domain is not None or source.components not in (2, 3):
            raise GraphError(f"neighbour grid {name!r}: 'of' must be a declared quantity of 2 "
                             f"or 3 components on the particles, got {of!r}"
                             + ("" if source is None else f" ({source.components} components"
                                f"{', on grid ' + source.domain.name if source.domain else ''})"))
        n = NeighbourGrid.over(name, source, cell, box, bound, this_step, sets)
        self.grid(name, n.grid.shape, n.grid.box)
        self.neighbour_grids[name] = n
        # The grid's build is a node of the graph: it "writes" the table (a quantity only to the
        # graph's ordering, left out of the plan's quantities) and reads what it keys.
        self.quantities[name] = Quantity(name, 0.0, 1.0, 1, domain=self.grids[name])
        self.add_pass(Pass(name, "(neighbour grid)", name, reads=() if this_step else (of,),
                           reads_new=(of,) if this_step else (), builds=name))
        return n

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
            defines=None, neighbours=None):
        """Add a :class:`Pass` built from these arguments (see :class:`Pass`); returns it."""
        if neighbours is not None and neighbours not in self.neighbour_grids:
            raise GraphError(f"pass {name!r} reads neighbour grid {neighbours!r}, which is not "
                             f"declared (neighbour grids: "
                             f"{', '.join(self.neighbour_grids) or 'none'}; PassGraph.neighbours)")
        return self.add_pass(Pass(name, frag, writes, reads, reads_new, textures, uniforms or {},
                                  defines or {}, neighbours=neighbours))

    def add_pass(self, new):
        """Add a :class:`Pass` (to the repeat being declared, inside ``with repeat()``);
        returns it."""
        for other in self.passes:
            if other.name == new.name:
                raise GraphError(f"two passes are named {new.name!r}")
        if self._repeating is not None:
            new = replace(new, repeat=self._repeating)
            r = self.repeats[self._repeating]
            self.repeats[r.name] = replace(r, passes=r.passes + (new.name,))
        self.passes.append(new)
        return new

    @contextmanager
    def repeat(self, name, count, warm_start=None):
        """Passes added inside ``with g.repeat(name, count):`` run ``count`` times in a row each
        step (one whole round of them, then the next), each iteration reading the last one's
        writes: a Jacobi solve is one pass writing and reading the pressure. ``count`` is a
        whole number >= 1; the plan lists the group with its count.

        ``warm_start``: {quantity: factor}, where the iterations start from: a quantity is state,
        so by default they start from last step's solution as it is (factor 1); a factor in
        [0, 1) adds a pass before the group that scales it (``lib/warm_start.frag``; 0: from
        zero, a cold start)."""
        if self._repeating is not None:
            raise GraphError(f"repeat {name!r} is inside repeat {self._repeating!r}: repeats do "
                             "not nest")
        if name in self.repeats:
            raise GraphError(f"two repeats are named {name!r}")
        count = int(check_range(f"repeat {name!r} count", count, 1, 2 ** 16, integer=True))
        for q, factor in (warm_start or {}).items():
            check_range(f"repeat {name!r} warm start of {q!r}", factor, 0.0, 1.0)
            if q not in self.quantities:
                raise GraphError(f"repeat {name!r}: warm start of {q!r}, which is not a declared "
                                 "quantity")
            if factor != 1:
                self.add(f"{name}_warm_start", "lib/warm_start.frag", writes=q, reads=[q],
                         uniforms={"u_warm": float(factor)}, defines={"WARM_READ": f"read_{q}"})
        self.repeats[name] = Repeat(name, count)
        self._repeating = name
        try:
            yield self.repeats[name]
        finally:
            self._repeating = None
        if not self.repeats[name].passes:
            raise GraphError(f"repeat {name!r} holds no pass")

    def writers(self, quantity):
        """The passes writing ``quantity``, in declaration order."""
        return [p for p in self.passes if p.writes == quantity]

    def writer(self, quantity):
        """The first pass writing ``quantity`` (None: none)."""
        return next(iter(self.writers(quantity)), None)

    def versioned(self):
        """The quantities that may be written more than once a step: by several passes, or by
        a pass in a repeat (whatever its count, so that its reads mean the same at any count)."""
        return {q for q in self.quantities
                if len(self.writers(q)) > 1 or any(p.repeat for p in self.writers(q))}

    def plan(self, outputs=None):
        """The :class:`Plan` computing ``outputs`` (default: every written quantity)."""
        if outputs is None:
            outputs = list(dict.fromkeys(p.writes for p in self.passes if not p.builds))
        outputs = (outputs,) if isinstance(outputs, str) else tuple(outputs)  # one name or several
        if not outputs and (self.passes or self.quantities):  # an empty graph: nothing to do
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
        versioned = self.versioned() & used
        last_step = {q for p in ordered for q in p.reads}
        built = {q for q in used if q in self.neighbour_grids}
        buffers = {q: (2 if q in last_step or q in versioned else 1)
                   for q in self.quantities if q in used and q not in built}
        sampled = {t for p in ordered for t in p.textures}
        planned = {p.repeat for p in ordered if p.repeat}
        return Plan(
            passes=ordered,
            quantities={q: self.quantities[q] for q in buffers},
            buffers=buffers,
            outputs=outputs,
            left_out_passes=[p for p in self.passes if p.name not in needed],
            left_out_quantities=[q for q in self.quantities if q not in buffers
                                 and q not in self.neighbour_grids],
            textures={t: data for t, data in self.textures.items() if t in sampled},
            left_out_textures=[t for t in self.textures if t not in sampled],
            versioned=tuple(q for q in self.quantities if q in versioned),
            repeats={n: r for n, r in self.repeats.items() if n in planned},
            grids={g: grid for g, grid in self.grids.items()
                   if g not in self.neighbour_grids
                   and any(self.quantities[q].domain is grid for q in buffers)},
            neighbours={n: self.neighbour_grids[n] for n in self.neighbour_grids if n in built},
        )

    def uniform_names(self):
        """Every uniform some pass of the graph declares (planned or not)."""
        return {name for p in self.passes for name in p.uniforms}

    def _check(self):
        for p in self.passes:
            if p.writes not in self.quantities:
                raise GraphError(f"pass {p.name!r} writes {p.writes!r}, which is not a declared "
                                 "quantity")
            if p.writes in self.neighbour_grids and not p.builds:
                raise GraphError(f"pass {p.name!r} writes {p.writes!r}, a neighbour grid: the "
                                 "step builds it; passes read it with neighbours=")
            for q in p.reads + p.reads_new:
                if q in self.neighbour_grids and q != p.neighbours:
                    raise GraphError(f"pass {p.name!r} reads neighbour grid {q!r} as a "
                                     f"quantity: declare it with neighbours={q!r}")
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
        """Names of the passes the outputs depend on, through either kind of read: every writer
        of a needed quantity, and every pass of a repeat one of whose passes is needed."""
        needed, todo, seen = set(), list(outputs), set()
        while todo:
            q = todo.pop()
            if q in seen:
                continue
            seen.add(q)
            for writer in self.writers(q):
                group = ([self._pass(n) for n in self.repeats[writer.repeat].passes]
                         if writer.repeat else [writer])
                for p in group:
                    if p.name not in needed:
                        needed.add(p.name)
                        todo.extend((p.writes,) + p.reads + p.reads_new)
        return needed

    def _pass(self, name):
        return next(p for p in self.passes if p.name == name)

    def _dependencies(self, passes):
        """pass name -> names of the passes that must run before it. A this-step read follows
        the write it reads; a versioned quantity's writers keep their declared order, each
        read of one of its versions comes before the write that replaces it, and a read of a
        version not yet written is an error naming the pass and the quantity."""
        deps = {p.name: [] for p in passes}
        versioned = self.versioned()
        by_output = {p.writes: p for p in passes}
        index = {p.name: i for i, p in enumerate(passes)}
        writers = {q: [p for p in passes if p.writes == q] for q in versioned}

        def loops_on(p, q):  # p repeats, and its repeat writes q: the last iteration's version
            return p.repeat is not None and any(
                self._pass(n).writes == q for n in self.repeats[p.repeat].passes)

        for p in passes:
            for q in p.reads_new:
                if q not in versioned:
                    if q == p.writes:
                        raise GraphError(f"pass {p.name!r} cannot read this step's value of "
                                         f"{q!r}, which it writes itself")
                    deps[p.name].append(by_output[q].name)
                    continue
                before = [w for w in writers[q] if index[w.name] < index[p.name]]
                if not before and not loops_on(p, q):
                    raise GraphError(f"pass {p.name!r} reads this step's {q!r}, but no pass "
                                     f"declared before it writes {q!r}: that version is not "
                                     "written yet (declare a writer first, or read last step's "
                                     "value with reads=)")
                if before:
                    deps[p.name].append(before[-1].name)
                after = [w for w in writers[q] if index[w.name] > index[p.name]]
                if after and after[0].name != p.name:
                    deps[after[0].name].append(p.name)  # read before it is replaced
            for q in p.reads:
                if q not in versioned:
                    continue
                if loops_on(p, q):
                    raise GraphError(f"pass {p.name!r} repeats in {p.repeat!r}, which writes "
                                     f"{q!r}: from its second iteration on, last step's {q!r} "
                                     "is gone; read the latest version with reads_new=")
                chain = writers[q]
                if p.writes == q and p is not chain[0]:
                    raise GraphError(f"pass {p.name!r} reads last step's {q!r}, but pass "
                                     f"{chain[0].name!r} writes {q!r} before it in this step: "
                                     "read this step's latest version with reads_new=")
                # Last step's value is in the pair until the second write: read before the first
                # (the front), or after it (the back), never after the second.
                before = [w for w in chain if index[w.name] < index[p.name]]
                if len(before) > 1 or (before and before[0].repeat):
                    raise GraphError(f"pass {p.name!r} reads last step's {q!r}, but passes "
                                     f"{', '.join(w.name for w in before)} write {q!r} before "
                                     "it in this step and its pair holds two versions: read "
                                     "this step's latest with reads_new=, or read it earlier")
                if before:
                    deps[p.name].append(before[0].name)
                following = [w for w in chain if index[w.name] > index[p.name]]
                if following:
                    deps[following[0].name].append(p.name)  # read before it goes
        for q, chain in writers.items():
            for earlier, later in zip(chain, chain[1:]):
                deps[later.name].append(earlier.name)
        return deps

    def last_step_after_a_write(self, passes):
        """{(pass name, quantity)} of the reads of last step's value of a versioned quantity
        made after its first write (in run order ``passes``): that value is in the back of the
        pair then."""
        out, written = set(), set()
        versioned = self.versioned()
        for p in passes:
            out |= {(p.name, q) for q in p.reads if q in versioned and q in written}
            written.add(p.writes)
        return out

    def _order(self, passes):
        """Topological order over the dependencies (:meth:`_dependencies`), declaration order
        among equals; a repeat's passes must come out together."""
        ordered, placed, visiting = [], set(), []
        by_name = {p.name: p for p in passes}
        deps = self._dependencies(passes)

        def visit(p):
            if p.name in placed:
                return
            if p.name in visiting:
                cycle = visiting[visiting.index(p.name):] + [p.name]
                raise GraphError("passes form a cycle through this step's reads: "
                                 + " -> ".join(cycle))
            visiting.append(p.name)
            for name in deps[p.name]:
                visit(by_name[name])
            visiting.pop()
            placed.add(p.name)
            ordered.append(p)

        for p in passes:
            visit(p)
        for r in self.repeats.values():
            at = [i for i, p in enumerate(ordered) if p.repeat == r.name]
            if at and (at[-1] - at[0] + 1 != len(at)
                       or [ordered[i].name for i in at] != list(r.passes)):
                raise GraphError(f"the passes of repeat {r.name!r} ({', '.join(r.passes)}) must "
                                 "run together and in their order, but the reads put "
                                 f"{', '.join(p.name for p in ordered[at[0]:at[-1] + 1])} "
                                 "between them")
        return ordered


def scene_graph(scene, caps, count=None):
    """``scene.graph(caps)``; a plug-in scene whose ``graph()`` takes no capabilities is called
    without them, and a scene whose ``graph`` takes ``count`` (a length that follows the
    particle count: the liquid's h) gets the run's."""
    import inspect

    try:
        parameters = inspect.signature(scene.graph).parameters
    except (TypeError, ValueError):
        return scene.graph(caps)
    if "count" in parameters:
        return scene.graph(caps, count=count)
    return scene.graph(caps) if parameters else scene.graph()
