"""Neighbour grids: particles that see each other, in ES 2.0 passes (no scatter, no atomics).

A neighbour grid holds the particles by the cell of one of their quantities (a position of 2
components), in square cells no smaller than the distance a pass looks. Each step builds it in
three stages of the simulation (:func:`plan_neighbours`):

1. **key** (``neighbours/key.frag``): each slot of a sort order keeps the particle it held and
   takes that particle's cell number, row by row (y * W + x), as its key;
2. **sort**: Batcher's odd-even merge network over the slots (``frame/order.py``, the smoke's
   depth sort's, here a stage of the step): the particles by cell, ties by index;
3. **table** (``neighbours/table.frag``): a pass over the cells, each finding by binary search
   the first slot whose key is at least its number: its first particle. The cell's particles
   are the slots up to the next cell's first. Nothing is capped: a cell may hold every particle.

A pass declared with ``neighbours=`` loops over the 3 x 3 cells around a point (three runs of
slots, one per row: a row's three cells are consecutive in the order) with
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
    whether it is built from this step's value of ``of`` (``this_step``) or last step's."""

    name: str
    of: str
    grid: Grid
    bound: int
    this_step: bool = False

    @classmethod
    def over(cls, name, quantity, cell, box=None, bound=64, this_step=False):
        """The grid of cells of side ``cell`` over ``box`` (default: ``quantity``'s range),
        grown to whole cells from its lower left."""
        cell = check_range(f"neighbour grid {name!r} cell", cell, 0.0, None)
        if not cell > 0:
            raise ParameterError(f"neighbour grid {name!r}: cell must be > 0, got {cell}")
        bound = int(check_range(f"neighbour grid {name!r} bound", bound, 1, MAX_BOUND,
                                integer=True))
        if box is None:
            box = (tuple(quantity.lo), tuple(quantity.hi))
        try:
            (x0, y0), (x1, y1) = box
        except (TypeError, ValueError):
            raise ParameterError(f"neighbour grid {name!r}: box must be ((x0, y0), (x1, y1)), "
                                 f"got {box!r}") from None
        if not (x1 > x0 and y1 > y0):
            raise ParameterError(f"neighbour grid {name!r}: box must have x1 > x0 and y1 > y0, "
                                 f"got {box!r}")
        shape = [max(1, math.ceil((hi - lo) / cell - 1e-9)) for lo, hi in ((x0, x1), (y0, y1))]
        if shape[0] * shape[1] > 2 ** 24:
            raise ParameterError(f"neighbour grid {name!r}: cells of {cell:g} over {box} make "
                                 f"{shape[0]}x{shape[1]} cells, more than 2^24: use larger cells")
        grid = Grid(name, tuple(shape), ((x0, y0), (x0 + shape[0] * cell, y0 + shape[1] * cell)))
        return cls(name, quantity.name, grid, bound, bool(this_step))

    @property
    def cell(self):
        return self.grid.cell[0]

    @property
    def cells(self):
        return self.grid.shape[0] * self.grid.shape[1]

    def uniforms(self):
        """What its shaders see: ``u_neighbour_size`` (W, H), ``u_neighbour_box`` (x0, y0, x1,
        y1) and ``u_neighbour_cell`` (the side)."""
        (x0, y0), (x1, y1) = self.grid.box
        return {"u_neighbour_size": tuple(float(n) for n in self.grid.shape),
                "u_neighbour_box": (float(x0), float(y0), float(x1), float(y1)),
                "u_neighbour_cell": float(self.cell)}

    def cells_of(self, points):
        """The float64 twin of ``neighbour_cell`` (lib/neighbours.glsl): the (i, j) cell of each
        point, clamped into the grid."""
        (x0, y0), _ = self.grid.box
        c = np.floor((np.asarray(points, np.float64) - (x0, y0)) / self.cell)
        return np.clip(c, 0, np.array(self.grid.shape) - 1).astype(np.int64)


def order_of(n, quantity, layout, caps, fmt):
    """The :class:`~es2particles.frame.order.Order` neighbour grid ``n`` sorts over ``layout``'s
    particles; refuses more cells than its keys hold, naming the ways out."""
    order = Order(layout.count, order_format(caps, quantity, fmt), caps.max_texture_size)
    keys = order.key_max + 1 if order.fmt == "rgba8" else 2 ** 24
    if n.cells > keys:
        w, h = n.grid.shape
        raise CapabilityError(
            f"neighbour grid {n.name!r} has {w}x{h} = {n.cells} cells, more than the {keys} an "
            f"{order.fmt} sort order over {layout.count} particles can key "
            f"({order.describe_keys()}): use larger cells, fewer particles, or a float state "
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
    defines = {**order.defines(), "NEIGHBOUR_KEY": None, "NEIGHBOUR_READ": f"read_{n.of}"}
    b.stage(Stage(f"{n.name} key", "neighbour key", "neighbours/key.frag", defines=defines,
                  interface=interface,
                  inputs={**inputs_of(interface), "u_order": Ref(order_name)},
                  target=Ref(order_name), generated=generated_values(interface, layout),
                  uniforms=n.uniforms(), step=True,
                  what=f"each slot's particle and the cell of its {n.of}"))
    plan_merge(b, order, None, order_name, f"{n.name} sort", step=True)
    b.resource(Resource(n.name, "target", n.grid.shape, order.fmt,
                        what=f"neighbour grid {n.name}: each cell's first slot"))
    b.stage(Stage(f"{n.name} table", "neighbour table", "neighbours/table.frag",
                  defines=order.defines(), inputs={"u_order": Ref(order_name)},
                  target=Ref(n.name), step=True,
                  uniforms={"u_order_size": (float(order.width), float(order.height)),
                            "u_neighbour_size": n.uniforms()["u_neighbour_size"],
                            "u_levels": float(order.levels + 1)},
                  what=f"binary search of the slots, {order.levels + 1} fetches a cell"))
    w, h = n.grid.shape
    b.notes.append(
        f"neighbour grid {n.name}: {w}x{h} cells of {n.cell:g} over {n.of}; a step sorts "
        f"{order.slots} slots ({order.passes} merge passes, {order.describe_keys()}) and "
        f"searches {n.cells} cells; a pass reading it visits 3 rows of cells, at most "
        f"{n.bound} particles a row ({3 * n.bound} a point)")
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
    return [f"#define NEIGHBOUR_BOUND {n.bound}", '#include "lib/order.glsl"'], samplers, fixed


def decode_table(texels, fmt):
    """Each cell's first slot (int64, row by row) from the table's texels (cells, 4)."""
    if fmt == "rgba32f":
        return texels[:, 0].astype(np.int64)
    b = texels.astype(np.int64)
    return (b[:, 0] << 24) | (b[:, 1] << 16) | (b[:, 2] << 8) | b[:, 3]


def row_counts(first, shape, count):
    """The particles each loop row visits: for each cell (H, W), those of the run of cells
    x - 1 .. x + 1 of its row (clamped), from the cells' first slots ``first``."""
    w, h = shape
    ends = np.append(first[1:], count)
    per_cell = (ends - first).reshape(h, w)
    padded = np.pad(per_cell, ((0, 0), (1, 1)))
    return padded[:, :-2] + padded[:, 1:-1] + padded[:, 2:]


def check_rows(n, first, count, step):
    """Raise unless every row of 3 cells of neighbour grid ``n`` holds at most its bound."""
    rows = row_counts(first, n.grid.shape, count)
    worst = int(rows.max()) if rows.size else 0
    if worst > n.bound:
        j, i = np.unravel_index(int(rows.argmax()), rows.shape)
        raise GraphError(f"neighbour grid {n.name!r}: the cells around ({i}, {j}) hold {worst} "
                         f"particles in a row of 3 after step {step}, more than the {n.bound} "
                         "its loops visit: raise its bound (a scene's --bound), or use smaller cells")
    return worst
