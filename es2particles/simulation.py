"""Executing a pass graph's plan on the GPU: textures, programs, one step after another.

Everything GL is made once here, in the constructor: state textures and framebuffers, programs,
vertex arrays, and the uniform handles that are set per step. ``step()`` then only binds textures,
sets the step number and draws, pass by pass, and swaps the ping-pong buffers at the end.
"""

import moderngl
import numpy as np

from .errors import ParameterError
from .state import Layout, StateBuffer

FORMAT_DEFINES = {"rgba8": {"STATE_RGBA8": None}, "rgba16f": {"STATE_FLOAT": None},
                  "rgba32f": {"STATE_FLOAT": None}}
ROUNDINGS = ("nearest", "dither")
AUTO_ORDER = ("rgba32f", "rgba16f", "rgba8")  # most precise first


def resolve_format(ctx, fmt):
    """The storage format to use and a note saying why: ``auto`` takes the most precise format
    the context can render to; a named one must be renderable (else CapabilityError)."""
    if fmt == "auto":
        for candidate in AUTO_ORDER:
            if ctx.caps.renderable.get(candidate):
                return candidate, f"{candidate} (auto: the most precise renderable format)"
    if fmt not in FORMAT_DEFINES:
        raise ParameterError(f"format must be one of {sorted(FORMAT_DEFINES)} or 'auto', got {fmt!r}")
    ctx.require_format(fmt)
    return fmt, fmt


def _rectangle(lo, hi):
    """(lo.x, lo.y, span.x, span.y) of a rectangle given by two corners, checked."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if lo.shape != (2,) or hi.shape != (2,) or not np.all(np.isfinite([lo, hi])) \
            or not np.all(hi >= lo):
        raise ParameterError(f"lo and hi must be finite (x, y) pairs with hi >= lo, "
                             f"got {lo.tolist()} and {hi.tolist()}")
    return np.concatenate([lo, hi - lo])


class _BoundPass:
    """A pass with its program, vertex array and uniform handles, ready to draw."""

    def __init__(self, ctx, spec, buffers, layout, defines):
        self.spec = spec
        self.program = ctx.program("lib/fullscreen.vert", spec.frag, {**defines, **spec.defines})
        self.vao = ctx.fullscreen(self.program)
        self.target = buffers[spec.writes]
        # Samplers: (texture unit, buffer, this step's value?) in a fixed order.
        self.inputs = []
        for unit, (name, new) in enumerate([(q, False) for q in spec.reads]
                                           + [(q, True) for q in spec.reads_new]):
            self._set(f"u_{name}", unit)
            self._set(f"u_{name}_range", tuple(buffers[name].quantity.range_vec4))
            self.inputs.append((unit, buffers[name], new))
        self._set("u_out_range", tuple(self.target.quantity.range_vec4))
        self._set("u_state_size", (float(layout.width), float(layout.height)))
        self._set("u_count", float(layout.count))
        self.step_uniform = self._handle("u_step")
        self.extra = []  # (unit, texture) of textures that are not quantities, e.g. a field
        for name, value in spec.uniforms.items():
            self.set_uniform(name, value)

    def attach(self, name, texture):
        """Bind ``texture`` to sampler ``name`` if this pass declares it."""
        if self._handle(name) is None:
            return False
        unit = len(self.inputs) + len(self.extra)
        self._set(name, unit)
        self.extra.append((unit, texture))
        return True

    def _handle(self, name):
        return self.program[name] if name in self.program else None

    def _set(self, name, value):
        handle = self._handle(name)
        if handle is not None:
            handle.value = value

    def set_uniform(self, name, value):
        handle = self._handle(name)
        if handle is None:
            return False
        try:
            handle.value = value
        except Exception as error:
            raise ParameterError(f"uniform {name} of pass {self.spec.name!r}: cannot take "
                                 f"{value!r} ({error})") from None
        return True

    def draw(self, step):
        for unit, buffer, new in self.inputs:
            (buffer.written if new else buffer.front).use(unit)
        for unit, texture in self.extra:
            texture.use(unit)
        if self.step_uniform is not None:
            self.step_uniform.value = float(step)
        self.target.target.use()
        self.vao.render(moderngl.TRIANGLES)


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
    defines : mapping, optional
        ``#define`` lines for every pass.
    rounding : str
        How the packed format rounds on write: ``nearest``, or ``dither`` (stochastic, from a hash
        of particle and step: deterministic, unbiased, so sub-code changes are not lost).
    """

    def __init__(self, ctx, graph, count, outputs=None, fmt="rgba8", defines=None,
                 rounding="nearest"):
        if rounding not in ROUNDINGS:
            raise ParameterError(f"rounding must be one of {ROUNDINGS}, got {rounding!r}")
        self.ctx, self.rounding = ctx, rounding
        self.plan = graph.plan(outputs)
        self.layout = Layout.for_count(count, ctx.caps.max_texture_size)
        self.fmt, self.format_note = resolve_format(ctx, fmt)
        fmt = self.fmt
        self.steps_done = 0
        self.attached = []
        self.buffers = {}
        self.passes = []
        try:
            for name, n in self.plan.buffers.items():
                self.buffers[name] = StateBuffer(ctx, self.plan.quantities[name], self.layout,
                                                 fmt, n)
            all_defines = {**FORMAT_DEFINES[fmt], **(defines or {})}
            if rounding == "dither" and fmt == "rgba8":
                all_defines["STATE_DITHER"] = None
            self.passes = [_BoundPass(ctx, p, self.buffers, self.layout, all_defines)
                           for p in self.plan.passes]
        except Exception:
            self.release()
            raise
        self._swapped = [b for name, b in self.buffers.items() if len(b.textures) == 2]

    @property
    def count(self):
        return self.layout.count

    def _buffer(self, name):
        if name not in self.buffers:
            raise ParameterError(f"quantity {name!r} is not in this simulation's plan "
                                 f"(has: {', '.join(self.buffers)})")
        return self.buffers[name]

    def upload(self, name, values):
        """Set quantity ``name`` to world values of shape (count, 2)."""
        self._buffer(name).upload(values)

    def fill_uniform(self, name, lo, hi, rng):
        """Set quantity ``name`` to points drawn uniformly from the rectangle [lo, hi] (clamped to
        its range) by numpy generator ``rng``: a run's usual start, several times cheaper than
        ``upload`` of the same points (see ``StateBuffer.fill_uniform``)."""
        self._buffer(name).fill_uniform(_rectangle(lo, hi), rng)

    def download(self, name):
        """World values (count, 2), float64, of quantity ``name`` after the last step."""
        return self._buffer(name).download()

    def attach_texture(self, name, texture):
        """Bind a texture that is not a quantity (a collision field, say) to sampler ``name`` of
        every pass that declares it. The simulation owns it from now on and releases it."""
        self.attached.append(texture)
        if not any([p.attach(name, texture) for p in self.passes]):
            raise ParameterError(f"no pass of this plan has a sampler named {name!r}")

    def set_uniform(self, name, value):
        """Set uniform ``name`` on every pass whose shader declares it."""
        if not any([p.set_uniform(name, value) for p in self.passes]):
            raise ParameterError(f"no pass of this plan has a uniform named {name!r}")

    def set_uniforms(self, values):
        """Set several uniforms; names no planned pass declares are passed over (a pruned pass
        may have been the only one to use them)."""
        for name, value in values.items():
            for bound in self.passes:
                bound.set_uniform(name, value)

    def non_finite(self, name):
        """Particles whose ``name`` holds NaN or Inf (only float formats can store them)."""
        values = self._buffer(name).read_texels()[:, :2]
        if values.dtype == np.uint8:
            return 0
        return int(np.count_nonzero(~np.isfinite(values.astype(np.float64)).all(axis=1)))

    def clamped(self, name):
        """Particles whose ``name`` sits on an edge of its range, per component (N,) x 2: how
        many values were clamped on write (a value is clamped, never wrapped)."""
        values = self.download(name)
        q = self.buffers[name].quantity
        return [int(np.count_nonzero((values[:, k] <= q.lo[k]) | (values[:, k] >= q.hi[k])))
                for k in range(2)]

    def step(self):
        """Run every planned pass once, then make this step's values the front ones."""
        self.ctx.mgl.disable(moderngl.BLEND)
        for bound in self.passes:
            bound.draw(self.steps_done)
        for buffer in self._swapped:
            buffer.swap()
        self.steps_done += 1

    def run(self, steps):
        """Run ``steps`` steps."""
        steps = int(steps)
        if steps < 0:
            raise ParameterError(f"steps must be >= 0, got {steps}")
        for _ in range(steps):
            self.step()

    def release(self):
        """Release the state textures (programs stay cached in the context); safe twice."""
        for bound in self.passes:
            self.ctx.free(bound.vao)
        for buffer in self.buffers.values():
            buffer.release()
        self.ctx.free(*self.attached)
        self.passes, self.buffers, self._swapped, self.attached = [], {}, [], []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()
