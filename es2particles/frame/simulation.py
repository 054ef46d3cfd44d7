"""A simulation: a pass graph's plan made real, stepped, and its state read and written.

:class:`Simulation` is the public face of the simulation part of a frame plan: made from a
:class:`~es2particles.frame.graph.PassGraph` alone (``Simulation(ctx, graph, count)``: an
:class:`~es2particles.frame.executor.Executor` of the graph's passes and nothing else), or over a
whole frame's executor (``Simulation.over``, what a :class:`~es2particles.frame.pipeline.Pipeline`
hands a scene). Everything GL is made once, when the executor is; ``step()`` only binds textures,
sets the step number and draws, pass by pass, and swaps the ping-pong buffers at the end.
"""

import numpy as np

from ..errors import Es2ParticlesError, ParameterError, check_range
from .executor import Executor
from .plan import plan_graph
from .settings import check_rounding
from .state import edge_counts, per_component


def fill_box(name, lo, hi, components):
    """(lo, span) as float32 of the box [lo, hi] for a quantity of ``components``, checked."""
    lo = np.array(per_component(f"fill of {name!r}: lo", lo, components))
    hi = np.array(per_component(f"fill of {name!r}: hi", hi, components))
    if not np.all(hi >= lo):
        raise ParameterError(f"fill of {name!r}: lo and hi must have hi >= lo, got "
                             f"{lo.tolist()} and {hi.tolist()}")
    return lo.astype(np.float32), (hi - lo).astype(np.float32)


class Simulation:
    """A plan made real: state textures for ``count`` particles and the passes that update them.

    Parameters
    ----------
    ctx : Context
        The owner of every GL object made here.
    graph : PassGraph
        The passes and quantities.
    count : int or None
        Number of particles, 1 .. max_texture_size**2; None where no planned quantity lives
        on the particles (a grid solver alone).
    outputs : list of str, optional
        Quantities wanted; passes and textures they do not need are left out (see ``plan``).
    fmt : str
        Storage format: ``rgba8`` (16-bit packed, default), ``rgba16f``, ``rgba32f``, or ``auto``
        (the most precise one the context can render to; ``format_note`` says which).
    rounding : str
        How the packed format rounds: ``nearest``; ``dither`` (stochastic on write, from a hash
        of particle and step: deterministic, unbiased, so sub-code changes are not lost); or
        ``jitter`` (nearest on write, and every read offset within its code by a hash of
        particle and step: a value reads as a sample of its code's interval, so a chaotic map
        keeps float32's statistics where a 16-bit grid would alias).
    """

    def __init__(self, ctx, graph, count=None, outputs=None, fmt="rgba8", rounding="nearest"):
        self.executor = None
        check_rounding(rounding)
        ctx.make_current()
        frame_plan = plan_graph(graph, count, outputs, fmt, rounding, ctx.caps)
        self._attach(ctx, graph, Executor(ctx, frame_plan), owns=True)

    @classmethod
    def over(cls, executor):
        """The simulation of a frame's ``executor`` (which keeps owning everything)."""
        sim = cls.__new__(cls)
        sim._attach(executor.ctx, executor.plan.pass_graph, executor, owns=False)
        return sim

    def _attach(self, ctx, graph, executor, owns):
        self.ctx, self.graph, self.executor, self._owns = ctx, graph, executor, owns
        frame_plan = executor.plan
        self.plan, self.layout = frame_plan.graph, frame_plan.layout
        self.fmt, self.format_note, self.rounding = (frame_plan.format, frame_plan.format_note,
                                                     frame_plan.rounding)
        self.buffers = {name: executor.resources[name] for name in self.plan.buffers}
        self.textures = {name: executor.resources[name] for name in self.plan.textures}

    @property
    def count(self):
        return self.layout.count

    @property
    def steps_done(self):
        """Steps run so far: the step number ``u_step`` the next step's passes see."""
        return self.executor.steps_done

    @steps_done.setter
    def steps_done(self, value):
        self.executor.steps_done = int(check_range("steps_done", value, 0, None, integer=True))

    @property
    def stages(self):
        """The plan's draws of one step, in order (:class:`~es2particles.frame.plan.Stage`: a
        pass of a quantity of three or four components in RGBA8 draws twice)."""
        return self.executor.plan.step_stages

    def _use(self):
        """Make this simulation's context current; a released simulation refuses."""
        if self.executor is None or self.executor.group is None:
            raise Es2ParticlesError("this Simulation was released; make a new one")
        self.ctx.make_current()

    def _buffer(self, name):
        self._use()
        if name not in self.buffers:
            raise ParameterError(f"quantity {name!r} is not in this simulation's plan "
                                 f"(has: {', '.join(self.buffers)})")
        return self.buffers[name]

    def upload(self, name, values):
        """Set quantity ``name`` to world values of shape (count, components); a grid
        quantity's as (H, W, components), row 0 at the bottom (or flat, (W * H, components));
        a 3D grid's as (D, H, W, components) (or flat, k then j then i)."""
        self._buffer(name).upload(values)

    def fill_uniform(self, name, lo, hi, rng):
        """Set quantity ``name`` to values drawn uniformly from the box [lo, hi] (one bound per
        component, clamped to its range) by numpy generator ``rng``: a run's usual start, several
        times cheaper than ``upload`` of the same values (see ``StateBuffer.fill_uniform``)."""
        buffer = self._buffer(name)
        lo, span = fill_box(name, lo, hi, buffer.quantity.components)
        buffer.fill_uniform(lo, span, rng)

    def download(self, name):
        """World values (count, components), float64, of quantity ``name`` after the last step;
        a grid quantity's as (H, W, components), row 0 at the bottom, values at cell centres (a
        3D grid's (D, H, W, components))."""
        buffer = self._buffer(name)
        values = buffer.download()
        grid = buffer.quantity.domain
        return values if grid is None else grid.arranged(values)

    def set_uniform(self, name, value):
        """Set uniform ``name`` on every planned pass that declares it. The name must be declared
        by some pass of the graph (``uniforms=``); a pass the plan left out is skipped."""
        self._use()
        known = self.graph.uniform_names()
        if name not in known:
            raise ParameterError(f"no pass of this graph declares a uniform {name!r} (declared: "
                                 f"{', '.join(sorted(known)) or 'none'})")
        self.executor.set_uniforms({name: value})

    def set_uniforms(self, values):
        """Set several uniforms (each as :meth:`set_uniform`)."""
        for name, value in values.items():
            self.set_uniform(name, value)

    def non_finite(self, name):
        """Particles whose ``name`` holds NaN or Inf (only float formats can store them)."""
        buffer = self._buffer(name)
        values = buffer.read_texels()[:, 0, : buffer.quantity.components]
        if values.dtype == np.uint8:
            return 0
        return int(np.count_nonzero(~np.isfinite(values.astype(np.float64)).all(axis=1)))

    def clamped(self, name):
        """How many particles sit on an edge of ``name``'s range, per component: how many values
        were clamped on write (a value is clamped, never wrapped)."""
        lo, hi = self.edge_counts(name)
        return [int(a + b) for a, b in zip(lo, hi)]

    def edge_counts(self, name):
        """(on lo, on hi): how many elements of ``name`` sit on each edge of its range, per
        component, counted on the stored codes (no decode: a few ms at 2^20): a packed value's
        code 0 or its top, a float's value at or beyond lo or lo + span."""
        buffer = self._buffer(name)
        q, texels = buffer.quantity, buffer.read_texels()
        if q.domain is not None and q.domain.dimensions == 3:  # not the atlas's spare tiles
            texels = q.domain.arranged(texels.reshape(len(texels), -1)).reshape(
                -1, *texels.shape[1:])
        return edge_counts(q, texels, buffer.fmt)

    def clamped_writes(self, name):
        """How many elements of ``name`` sit on an edge of its range that means a clamped
        write (the quantity's ``clamps``: a wall, a unit vector's end or a density's 0 are
        values, not clamps), per component; zeros without a read where no edge means one."""
        q = self._buffer(name).quantity
        if q.clamps == "none":
            return [0] * q.components
        lo, hi = self.edge_counts(name)
        return [int(a * (q.clamps in ("both", "lo")) + b * (q.clamps in ("both", "hi")))
                for a, b in zip(lo, hi)]

    def neighbour_table(self, name):
        """Neighbour grid ``name``'s table after the last step: each cell's first slot in the
        order sorted by cell, (H, W) int64 ((D H, W) in 3D, row k H + j), row 0 at the bottom (a cell's particles are its
        slots up to the next cell's first; the last cell's end at the particle count)."""
        from ..gl.context import numpy_dtype
        from .neighbours import decode_table

        self._use()
        if name not in self.plan.neighbours:
            raise ParameterError(f"neighbour grid {name!r} is not in this simulation's plan "
                                 f"(has: {', '.join(self.plan.neighbours) or 'none'})")
        r = self.executor.plan.resources[name]
        texels = np.frombuffer(self.executor.read(name), numpy_dtype(r.format)).reshape(-1, 4)
        w, h = self.plan.neighbours[name].table_size
        return decode_table(texels, r.format).reshape(h, w)

    def check_neighbours(self):
        """{grid: the most particles a loop's row of 3 cells held} of each neighbour grid after
        the last step; raises :class:`~es2particles.errors.GraphError` where a row held more
        than the grid's bound (its loops would have missed some). ``run`` checks after its
        steps; a caller stepping by hand checks when it likes (each check reads the tables
        back)."""
        from .neighbours import check_rows

        return {name: check_rows(n, self.neighbour_table(name).ravel(), self.count,
                                 self.steps_done)
                for name, n in self.plan.neighbours.items()}

    def step(self):
        """Run every planned draw once, then make this step's values the front ones."""
        self._use()
        self.executor.step()

    def run(self, steps):
        """Run ``steps`` steps (a whole number >= 0)."""
        steps = int(check_range("steps", steps, 0, None, integer=True))
        for _ in range(steps):
            self.step()
        if steps and self.plan.neighbours:
            self.check_neighbours()

    def describe(self):
        """The plan as lines, with this simulation's format and texture sizes, and what its
        neighbour grids cost."""
        return self.plan.describe(self.fmt, self.layout) + list(self.executor.plan.notes)

    def release(self):
        """Release the state and scene textures (programs stay cached in the context); safe
        twice. A simulation over a pipeline's executor leaves it to the pipeline."""
        if self.executor is not None and self._owns:
            self.executor.release()
        self.executor = None
        self.buffers, self.textures = {}, {}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()
