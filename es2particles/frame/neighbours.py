"""Neighbour grids: particles that see each other, in ES 2.0 passes (no scatter, no atomics).

A neighbour grid holds the particles by the cell of one of their quantities (a position of 2
or 3 components), in square (cubic) cells no smaller than the distance a pass looks. Each step builds it in
three stages of the simulation (:func:`plan_neighbours`):

1. **key** (``neighbours/key.frag``): each slot of a sort order keeps the particle it held and
   takes that particle's cell number, row by row (y * W + x; in 3D (z * H + y) * W + x), as
   its key;
2. **sort**: Batcher's odd-even merge network over the slots (``frame/order.py``, the smoke's
   depth sort's, here a stage of the step): the particles by cell, ties by index;
3. **table** (``neighbours/table.frag``): a pass over the cells, each finding by binary search
   the first slot whose key is at least its number: its first particle. The cell's particles
   are the slots up to the next cell's first. Nothing is capped: a cell may hold every particle.

A pass declared with ``neighbours=`` loops over the 3 x 3 (3D: 3 x 3 x 3) cells around a point
(three runs of slots, or nine, one per row: a row's three cells are consecutive in the order)
with
``FOR_EACH_NEIGHBOUR(point, uv)`` (``lib/neighbours.glsl``). GLSL ES 1.00 loops need constant
bounds: a row visits at most ``bound`` particles, and a row holding more is an error when
checked (:func:`row_counts`; ``Simulation.check_neighbours``), never a silent miss.

The order's key bits bound the cells: an RGBA8 order over 2^L slots keys 2^(32 - max(L, 8))
cells (65,536 at 2^16 particles, 4,096 at 2^20); an RGBA32F order (float state) 2^24.
"""

import math
from dataclasses import dataclass

import numpy as np

from ..errors import CapabilityError, GraphError, ParameterError, check_range
from .order import Order, order_format, plan_merge, plan_order
from .parts import Ref, Resource, Stage
from .state import Grid

MAX_BOUND = 2 ** 16  # particles a row: beyond, a driver's loop of that length is a stall


@dataclass(frozen=True)
class NeighbourGrid:
    """A neighbour grid's declaration (see the module's docstring): ``name``, the particles'
    quantity ``of`` it keys, its ``grid`` of square cells, the ``bound`` of a loop's row, and
    whether it is built from this step's value of ``of`` (``this_step``) or last step's;
    ``sets``: what sets its cells (a scene's option, for the refusals that name a way out)."""

    name: str
    of: str
    grid: Grid
    bound: int
    this_step: bool = False
    sets: str = ""

    @property
    def larger_cells(self):
        """How a refusal says to make the cells larger: naming what sets them, where known."""
        return f"larger cells ({self.sets})" if self.sets else "larger cells"

    @classmethod
    def over(cls, name, quantity, cell, box=None, bound=64, this_step=False, sets=""):
        """The grid of cells of side ``cell`` over ``box`` (default: ``quantity``'s range),
        grown to whole cells from its lower left; ``sets``: what sets the cell, for messages."""
        cell = check_range(f"neighbour grid {name!r} cell", cell, 0.0, None)
        if not cell > 0:
            raise ParameterError(f"neighbour grid {name!r}: cell must be > 0, got {cell}")
        bound = int(check_range(f"neighbour grid {name!r} bound", bound, 1, MAX_BOUND,
                                integer=True))
        d = quantity.components
        if box is None:
            box = (tuple(quantity.lo), tuple(quantity.hi))
        corners = "((x0, y0), (x1, y1))" if d == 2 else "((x0, y0, z0), (x1, y1, z1))"
        try:
            lo, hi = (tuple(float(v) for v in corner) for corner in box)
            if len(lo) != d or len(hi) != d:
                raise ValueError
        except (TypeError, ValueError):
            raise ParameterError(f"neighbour grid {name!r}: box must be {corners}, "
                                 f"got {box!r}") from None
        if not all(b > a for a, b in zip(lo, hi)):
            raise ParameterError(f"neighbour grid {name!r}: box must be larger than 0 along "
                                 f"each axis, got {box!r}")
        shape = tuple(max(1, math.ceil((b - a) / cell - 1e-9)) for a, b in zip(lo, hi))
        if math.prod(shape) > 2 ** 24:
            raise ParameterError(f"neighbour grid {name!r}: cells of {cell:g} over {box} make "
                                 f"{'x'.join(map(str, shape))} cells, more than 2^24: use "
                                 + (f"larger cells ({sets})" if sets else "larger cells"))
        grid = Grid(name, shape, (lo, tuple(a + n * cell for a, n in zip(lo, shape))))
        return cls(name, quantity.name, grid, bound, bool(this_step), str(sets))

    @property
    def cell(self):
        return self.grid.cell[0]

    @property
    def cells(self):
        return math.prod(self.grid.shape)

    @property
    def dimensions(self):
        return len(self.grid.shape)

    @property
    def table_size(self):
        """The cell table's texture (W, H), or (W, H D) in 3D: row k H + j holds the cells
        (i, j, k) of that row, so a cell's number (k H + j) W + i counts the table's texels
        row by row, and the three cells i - 1 .. i + 1 of a row are consecutive."""
        w, h, *depth = self.grid.shape
        return (w, h * (depth[0] if depth else 1))

    def uniforms(self):
        """What its shaders see: ``u_neighbour_size`` (W, H[, D]), the box's lower corner
        (``u_neighbour_box`` (x0, y0, x1, y1) in 2D, ``u_neighbour_lo`` (x0, y0, z0) in 3D) and
        ``u_neighbour_cell`` (the side)."""
        lo, hi = self.grid.box
        corner = ({"u_neighbour_box": tuple(map(float, (*lo, *hi)))} if self.dimensions == 2
                  else {"u_neighbour_lo": tuple(map(float, lo))})
        return {"u_neighbour_size": tuple(float(n) for n in self.grid.shape), **corner,
                "u_neighbour_cell": float(self.cell)}

    def defines(self):
        """``NEIGHBOUR_3D`` for a grid of 3D cells (lib/neighbours.glsl visits 3 x 3 rows)."""
        return {"NEIGHBOUR_3D": None} if self.dimensions == 3 else {}

    def cells_of(self, points):
        """The float64 twin of ``neighbour_cell`` (lib/neighbours.glsl): the (i, j[, k]) cell of
        each point, clamped into the grid."""
        c = np.floor((np.asarray(points, np.float64) - self.grid.box[0]) / self.cell)
        return np.clip(c, 0, np.array(self.grid.shape) - 1).astype(np.int64)


def order_of(n, quantity, layout, caps, fmt):
    """The :class:`~es2particles.frame.order.Order` neighbour grid ``n`` sorts over ``layout``'s
    particles; refuses more cells than its keys hold, naming the ways out."""
    order = Order(layout.count, order_format(caps, quantity, fmt), caps.max_texture_size)
    keys = order.key_max + 1 if order.fmt == "rgba8" else 2 ** 24
    if n.cells > keys:
        raise CapabilityError(
            f"neighbour grid {n.name!r} has {'x'.join(map(str, n.grid.shape))} = {n.cells} "
            f"cells, more than the {keys} an "
            f"{order.fmt} sort order over {layout.count} particles can key "
            f"({order.describe_keys()}): use {n.larger_cells}, fewer particles, or a float state "
            "format (rgba32f keys 2^24 cells)")
    return order


def plan_neighbours(b, n, plan, layout, inputs_of):
    """Add the build of neighbour grid ``n`` to plan builder ``b`` (stages of the step): its
    order and table resources, the key pass, the sort, the table. ``inputs_of(interface)``:
    the samplers' refs of a generated interface (last step's or this step's ``of``, as the pass
    graph ordered the build). Returns the :class:`Order`."""
    from ..gl.bindings import generated_values, stage_interface

    quantity = plan.quantities[n.of]
    order = order_of(n, quantity, layout, b.caps, b.format)
    order_name = f"{n.name}_order"
    plan_order(b, order, order_name, f"neighbour grid {n.name}: particles by cell")
    interface = stage_interface((n.of,), plan.quantities, b.format, this_step=n.this_step)
    defines = {**order.defines(), **n.defines(), "NEIGHBOUR_KEY": None,
               "NEIGHBOUR_READ": f"read_{n.of}"}
    b.stage(Stage(f"{n.name} key", "neighbour key", "neighbours/key.frag", defines=defines,
                  interface=interface,
                  inputs={**inputs_of(interface), "u_order": Ref(order_name)},
                  target=Ref(order_name), generated=generated_values(interface, layout),
                  uniforms=n.uniforms(), step=True,
                  what=f"each slot's particle and the cell of its {n.of}"))
    plan_merge(b, order, None, order_name, f"{n.name} sort", step=True)
    b.resource(Resource(n.name, "target", n.table_size, order.fmt,
                        what=f"neighbour grid {n.name}: each cell's first slot"
                             + (", a row of the table a row of cells (j, k)"
                                if n.dimensions == 3 else "")))
    b.stage(Stage(f"{n.name} table", "neighbour table", "neighbours/table.frag",
                  defines=order.defines(), inputs={"u_order": Ref(order_name)},
                  target=Ref(n.name), step=True,
                  uniforms={"u_order_size": (float(order.width), float(order.height)),
                            "u_neighbour_size": tuple(map(float, n.table_size)),
                            "u_levels": float(order.levels + 1)},
                  what=f"binary search of the slots, {order.levels + 1} fetches a cell"))
    rows = 3 ** (n.dimensions - 1)
    b.notes.append(
        f"neighbour grid {n.name}: {'x'.join(map(str, n.grid.shape))} cells of {n.cell:g} over "
        f"{n.of}; a step sorts {order.slots} slots ({order.passes} merge passes, "
        f"{order.describe_keys()}) and searches {n.cells} cells; a pass reading it visits "
        f"{rows} rows of 3 cells, at most {n.bound} particles a row ({rows * n.bound} a point)")
    return order


def interface_lines(n, order, layout):
    """(lines, samplers, fixed uniforms) a pass declared with ``neighbours=n.name`` sees before
    ``lib/neighbours.glsl``: the loop's bound and the order's library, the order and table
    samplers, their sizes and the particles' layout."""
    fixed = {**n.uniforms(),
             "u_neighbour_order_size": (float(order.width), float(order.height)),
             "u_neighbour_state_size": (float(layout.width), float(layout.height)),
             "u_neighbour_count": float(layout.count)}
    samplers = {"u_neighbour_order": ("texture", f"{n.name}_order"),
                "u_neighbour_table": ("texture", n.name)}
    lines = [f"#define NEIGHBOUR_BOUND {n.bound}"] + [f"#define {d}" for d in n.defines()]
    return lines + ['#include "lib/order.glsl"'], samplers, fixed


def decode_table(texels, fmt):
    """Each cell's first slot (int64, row by row) from the table's texels (cells, 4)."""
    if fmt == "rgba32f":
        return texels[:, 0].astype(np.int64)
    b = texels.astype(np.int64)
    return (b[:, 0] << 24) | (b[:, 1] << 16) | (b[:, 2] << 8) | b[:, 3]


def row_counts(first, shape, count):
    """The particles each loop row visits: for each cell of the table (``shape`` its (W, H),
    :attr:`NeighbourGrid.table_size`), those of the run of cells x - 1 .. x + 1 of its row
    (clamped), from the cells' first slots ``first``."""
    w, h = shape
    ends = np.append(first[1:], count)
    per_cell = (ends - first).reshape(h, w)
    padded = np.pad(per_cell, ((0, 0), (1, 1)))
    return padded[:, :-2] + padded[:, 1:-1] + padded[:, 2:]


def check_rows(n, first, count, step):
    """Raise unless every row of 3 cells of neighbour grid ``n`` holds at most its bound."""
    rows = row_counts(first, n.table_size, count)
    worst = int(rows.max()) if rows.size else 0
    if worst > n.bound:
        row, i = (int(v) for v in np.unravel_index(int(rows.argmax()), rows.shape))
        h = n.grid.shape[1]
        cell = (i, row) if n.dimensions == 2 else (i, row % h, row // h)
        raise GraphError(f"neighbour grid {n.name!r}: the cells around {cell} hold {worst} "
                         f"particles in a row of 3 after step {step}, more than the {n.bound} "
                         "its loops visit: raise its bound (a scene's --bound), or use smaller cells")
    return worst
