"""Executing a pass graph's plan on the GPU: textures, programs, one step after another.

Everything GL is made once here, in the constructor: state textures and framebuffers, programs,
vertex arrays, and the uniform handles that are set per step. ``step()`` then only binds textures,
sets the step number and draws, pass by pass, and swaps the ping-pong buffers at the end.
"""

import numpy as np

from ..gl.bindings import pass_interface, uniform_value
from ..gl.command import FullscreenCommand
from ..errors import Es2ParticlesError, ParameterError, ShaderError, check_range
from .state import FORMATS, Layout, StateBuffer, per_component

ROUNDINGS = ("nearest", "dither")
AUTO_ORDER = ("rgba32f", "rgba16f", "rgba8")  # most precise first


def resolve_format(ctx, fmt):
    """The storage format to use and a note saying why: ``auto`` takes the most precise format
    the context can render to; a named one must be renderable (else CapabilityError)."""
    if fmt == "auto":
        for candidate in AUTO_ORDER:
            if ctx.caps.renderable.get(candidate):
                return candidate, f"{candidate} (auto: the most precise renderable format)"
    if fmt not in FORMATS:
        raise ParameterError(f"format must be one of {sorted(FORMATS)} or 'auto', got {fmt!r}")
    ctx.require_format(fmt)
    return fmt, fmt


def check_rounding(rounding):
    if rounding not in ROUNDINGS:
        raise ParameterError(f"rounding must be one of {ROUNDINGS}, got {rounding!r}")
    return rounding


def draw_defines(spec, rounding):
    """The defines of a pass's draws: the pass's own, and STATE_DITHER for dithered rounding."""
    return {**({"STATE_DITHER": None} if rounding == "dither" else {}), **spec.defines}


def fill_box(name, lo, hi, components):
    """(lo, span) as float32 of the box [lo, hi] for a quantity of ``components``, checked."""
    lo = np.array(per_component(f"fill of {name!r}: lo", lo, components))
    hi = np.array(per_component(f"fill of {name!r}: hi", hi, components))
    if not np.all(hi >= lo):
        raise ParameterError(f"fill of {name!r}: lo and hi must have hi >= lo, got "
                             f"{lo.tolist()} and {hi.tolist()}")
    return lo.astype(np.float32), (hi - lo).astype(np.float32)


class _Draw:
    """One full-screen draw of a pass: part ``part`` of the quantity it writes."""

    def __init__(self, group, spec, part, quantities, buffers, fmt, defines, layout, textures):
        self.spec = spec
        self.interface = pass_interface(spec, quantities, fmt, part)
        stage = spec.stage(part)
        try:
            self.command = FullscreenCommand(group, spec.frag, stage, defines, self.interface)
        except ShaderError as error:
            raise ShaderError(f"{error}\n  (the graph declares for {stage}: "
                              f"{', '.join(sorted(self.interface.names))})") from None
        cmd = self.command
        for name, (kind, what) in ((n, v[:2]) for n, v in self.interface.samplers.items()):
            call = f"read_{what}" if kind == "quantity" else name
            if not cmd.uses(call):
                raise ParameterError(f"{cmd.where()} declares it reads {kind} {what!r} but its "
                                     f"shader never uses {call}")
        cmd.check_fed(self.interface.samplers)
        cmd.set_generated(self.interface, layout)
        for name, value in spec.uniforms.items():
            self.set_uniform(name, value)
        self.step_uniform = cmd.program["u_step"] if cmd.has("u_step") else None
        self.written, self.part = buffers[spec.writes], part  # its target swaps each step
        # (sampler, buffer, part, this step?) of quantities; fixed textures by sampler name
        self.inputs = [(s, buffers[q], k, new) for s, (kind, q, k, new) in
                       ((s, v) for s, v in self.interface.samplers.items() if v[0] == "quantity")]
        self.fixed_textures = {s: textures[v[1]] for s, v in self.interface.samplers.items()
                               if v[0] == "texture"}

    def set_uniform(self, name, value):
        self.command.set(name, uniform_value(name, value, self.interface.uniforms[name]))

    def draw(self, step):
        textures = dict(self.fixed_textures)
        for sampler, buffer, part, new in self.inputs:
            textures[sampler] = (buffer.written if new else buffer.fronts)[part]
        if self.step_uniform is not None:
            self.step_uniform.value = float(step)
        self.command.draw(self.written.framebuffer(self.part), textures)


class Simulation:
    """A plan made real: state textures for ``count`` particles and the passes that update them.

    Parameters
    ----------
    ctx : Context
        The owner of every GL object made here.
    graph : PassGraph
        The passes and quantities.
    count : int
        Number of particles, 1 .. max_texture_size**2.
    outputs : list of str, optional
        Quantities wanted; passes and textures they do not need are left out (see ``plan``).
    fmt : str
        Storage format: ``rgba8`` (16-bit packed, default), ``rgba16f``, ``rgba32f``, or ``auto``
        (the most precise one the context can render to; ``format_note`` says which).
    rounding : str
        How the packed format rounds on write: ``nearest``, or ``dither`` (stochastic, from a hash
        of particle and step: deterministic, unbiased, so sub-code changes are not lost).
    """

    def __init__(self, ctx, graph, count, outputs=None, fmt="rgba8", rounding="nearest"):
        self.group = None
        check_rounding(rounding)
        ctx.make_current()
        self.ctx, self.rounding, self.graph = ctx, rounding, graph
        self.plan = graph.plan(outputs)
        self.layout = Layout.for_count(count, ctx.caps.max_texture_size)
        self.fmt, self.format_note = resolve_format(ctx, fmt)
        self.steps_done = 0
        self.group = ctx.group()
        self.buffers, self.draws, self.textures = {}, [], {}
        try:
            for name, n in self.plan.buffers.items():
                quantity = self.plan.quantities[name]
                if quantity.storage:
                    ctx.require_format(quantity.storage)
                self.buffers[name] = StateBuffer(self.group, quantity, self.layout,
                                                 quantity.format_in(self.fmt), n)
            for name, data in self.plan.textures.items():
                if not isinstance(data, np.ndarray):  # astc.Compressed blocks
                    self.textures[name] = self.group.compressed_texture(data)
                    continue
                h, w = data.shape[:2]
                fmt = "rgba8" if data.dtype == np.uint8 else "rgba32f"
                self.textures[name] = self.group.texture((w, h), fmt, data=data.tobytes())
            for spec, part, _ in self.plan.draws(self.fmt):
                self.draws.append(_Draw(self.group, spec, part, graph.quantities, self.buffers,
                                        self.fmt, draw_defines(spec, rounding), self.layout,
                                        self.textures))
        except Exception:
            self.release()
            raise
        self._swapped = [b for b in self.buffers.values() if b.ping_pong]

    @property
    def count(self):
        return self.layout.count

    def _use(self):
        """Make this simulation's context current; a released simulation refuses."""
        if self.group is None:
            raise Es2ParticlesError("this Simulation was released; make a new one")
        self.ctx.make_current()

    def _buffer(self, name):
        self._use()
        if name not in self.buffers:
            raise ParameterError(f"quantity {name!r} is not in this simulation's plan "
                                 f"(has: {', '.join(self.buffers)})")
        return self.buffers[name]

    def upload(self, name, values):
        """Set quantity ``name`` to world values of shape (count, components)."""
        self._buffer(name).upload(values)

    def fill_uniform(self, name, lo, hi, rng):
        """Set quantity ``name`` to values drawn uniformly from the box [lo, hi] (one bound per
        component, clamped to its range) by numpy generator ``rng``: a run's usual start, several
        times cheaper than ``upload`` of the same values (see ``StateBuffer.fill_uniform``)."""
        buffer = self._buffer(name)
        lo, span = fill_box(name, lo, hi, buffer.quantity.components)
        buffer.fill_uniform(lo, span, rng)

    def download(self, name):
        """World values (count, components), float64, of quantity ``name`` after the last step."""
        return self._buffer(name).download()

    def set_uniform(self, name, value):
        """Set uniform ``name`` on every planned pass that declares it. The name must be declared
        by some pass of the graph (``uniforms=``); a pass the plan left out is skipped."""
        self._use()
        known = self.graph.uniform_names()
        if name not in known:
            raise ParameterError(f"no pass of this graph declares a uniform {name!r} (declared: "
                                 f"{', '.join(sorted(known)) or 'none'})")
        for draw in self.draws:
            if name in draw.spec.uniforms:
                draw.set_uniform(name, value)

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
        values = self.download(name)
        q = self.buffers[name].quantity
        # the edges as a decode gives them: lo and lo + span in float32
        lo, hi = q.lo32.astype(np.float64), (q.lo32 + q.span32).astype(np.float64)
        return [int(np.count_nonzero((values[:, k] <= lo[k]) | (values[:, k] >= hi[k])))
                for k in range(q.components)]

    def step(self):
        """Run every planned draw once, then make this step's values the front ones."""
        self._use()
        for draw in self.draws:
            draw.draw(self.steps_done)
        for buffer in self._swapped:
            buffer.swap()
        self.steps_done += 1

    def run(self, steps):
        """Run ``steps`` steps (a whole number >= 0)."""
        steps = int(check_range("steps", steps, 0, None, integer=True))
        for _ in range(steps):
            self.step()

    def describe(self):
        """The plan as lines, with this simulation's format and texture sizes."""
        return self.plan.describe(self.fmt, self.layout)

    def release(self):
        """Release the state and scene textures (programs stay cached in the context); safe
        twice."""
        if self.group is None:
            return
        if self.ctx.mgl is not None:
            self.ctx.make_current()
        self.group.release()
        self.group = None
        self.draws, self.buffers, self._swapped, self.textures = [], {}, [], {}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()
