"""The EGL executor of a frame plan: every resource and command made once, then only draws.

:class:`Executor` makes the plan real on a context: a :class:`~es2particles.frame.state.
StateBuffer` per quantity, an uploaded texture per image, a texture (a pair for ping-pong,
with a depth buffer where asked) per target, a buffer per vertex data, and one
:class:`~es2particles.gl.command.DrawCommand` per stage. Running a stage is the same for every
kind: its samplers are fed from the resources its inputs name (the front of a pair, or the texture
written earlier in this step), its per-frame values are computed (:func:`~es2particles.frame.plan.
frame_value`), its target is cleared where the stage says, and it draws, once, in slices of points
on a CPU rasteriser, or once per uniform set of its ``repeat`` (swapping a target that swaps per
draw after each). :meth:`Executor.step` runs the simulation's stages and swaps the state;
:meth:`Executor.render` runs the frame's stages and returns the presented texture.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import Es2ParticlesError, ParameterError, ShaderError
from ..gl.bindings import uniform_value
from ..gl.command import DrawCommand
from ..gl.context import numpy_dtype
from .plan import frame_value, motion_values
from .state import StateBuffer, Textures


@dataclass(frozen=True)
class Frame:
    """What a frame's values come from: its ``camera`` (None for 2D), the simulation's ``step``
    and the moving object's ``motion`` uniforms (:func:`~es2particles.frame.plan.motion_values`;
    None: still)."""

    camera: object = None
    step: int = 0
    motion: dict = None


class Executor:
    """The resources and commands of a :class:`~es2particles.frame.plan.FramePlan` on ``ctx``;
    ``release()`` (or a ``with``) releases them all (programs stay cached in the context)."""

    def __init__(self, ctx, plan, external=None):
        self.group = None
        ctx.make_current()
        self.ctx, self.plan = ctx, plan
        self.steps_done = 0
        self.resources, self.buffers, self.commands, self.cursors = {}, {}, {}, {}
        self.external = dict(external or {})  # resources someone else owns: name -> made one
        self.group = ctx.group()
        try:
            for resource in plan.resources.values():
                if resource.name in self.external:
                    self.resources[resource.name] = self.external[resource.name]
                else:
                    self.resources[resource.name] = self._make(resource)
            for vertices in plan.vertices.values():
                # The arrays' own memory, not a bytes copy: 8 MB less to copy and fault in at
                # 2^20 particles' texels (~4 ms of a still's start), 128 MB at 2^24.
                self.buffers[vertices.name] = self.group.buffer(_raw(vertices.array()))
                if vertices.indexed:
                    self.buffers[(vertices.name, "indices")] = self.group.buffer(
                        _raw(vertices.index_array()))
            for stage in plan.stages:
                self.commands[stage.name] = self._command(stage)
        except Exception:
            self.release()
            raise
        self._swapped = [name for name in self.resources if name not in self.external
                         and plan.resources[name].swap == "step"]
        self._rounds = step_rounds(plan.step_stages)

    # -- making -----------------------------------------------------------------------------------

    def _make(self, r):
        if r.kind == "state":
            if r.quantity.storage:
                self.ctx.require_format(r.quantity.storage)
            return StateBuffer(self.group, r.quantity, self.plan.layout_of(r.quantity), r.format,
                               r.buffers, r.linear)
        if r.kind == "image":
            if not isinstance(r.data, np.ndarray):  # ASTC blocks
                return self.group.compressed_texture(r.data)
            return self.group.texture(r.size, r.format, data=_raw(r.contents()),
                                      filter_nearest=not r.linear)
        target = Textures(self.group, r.size, r.format, r.parts, r.buffers, r.depth, r.linear)
        if r.data is not None:
            self.ctx.write(target.fronts[0], _raw(r.contents()))
        return target

    def _command(self, stage):
        vertices = indices = None
        if stage.vertices is not None:
            v = self.plan.vertices[stage.vertices]
            layout = " ".join(f"{n}f" for _, n in v.attributes)
            vertices = [(self.buffers[v.name], layout, *(a for a, _ in v.attributes))]
            indices = self.buffers.get((v.name, "indices"))
        if stage.attributes:  # state read back before each draw: bytes as bytes, floats as floats
            vertices = vertices or []
            for attribute, ref in stage.attributes.items():
                bytes_per = 4 if numpy_dtype(self.plan.resources[ref.resource].format) == np.uint8 \
                    else 16
                buffer = self.group.buffer(bytes(stage.count * bytes_per))
                self.buffers[(stage.name, attribute)] = buffer
                vertices.append((buffer, "4f1" if bytes_per == 4 else "4f", attribute))
        try:
            command = DrawCommand(self.group, stage.name, stage.fragment, stage.vertex,
                                  stage.defines, stage.interface, stage.vertex_interface,
                                  vertices, stage.primitive, stage.state, indices)
        except ShaderError as error:
            interface = stage.interface or stage.vertex_interface
            if interface is None:
                raise
            raise ShaderError(f"{error}\n  (the plan declares for {stage.name}: "
                              f"{', '.join(sorted(interface.names))})") from None
        command.check_fed(stage.inputs)
        for name, value in stage.generated.items():
            if command.has(name):
                command.values.set(name, value)
        command.set_many(stage.uniforms)
        return command

    # -- running ----------------------------------------------------------------------------------

    def _use(self):
        if self.group is None:
            raise Es2ParticlesError("this executor was released; make a new one")
        self.ctx.make_current()

    def bind(self, name, made):
        """Use ``made`` (a StateBuffer or Textures someone else owns) as external resource
        ``name`` from now on."""
        if name not in self.external:
            raise ParameterError(f"{name!r} is not an external resource of this plan (external: "
                                 f"{', '.join(self.external) or 'none'})")
        self.external[name] = self.resources[name] = made

    def frame(self, camera=None, drag=None, step=None):
        """The :class:`Frame` of a render after ``step`` steps (default the steps done): the
        moving meshes placed by the plan's motion then, its rest offset moved by ``drag`` (a
        hand's, 3 floats; None: none)."""
        step = self.steps_done if step is None else step
        return Frame(camera, step, motion_values(self.plan.motion, step, drag))

    def texture(self, ref):
        """The texture a :class:`~es2particles.frame.plan.Ref` names now."""
        made = self.resources[ref.resource]
        if not isinstance(made, Textures):
            return made  # an image
        if ref.when == "depth":
            return made.depth  # a target's depth texture
        return (made.written if ref.when == "written" else made.fronts)[ref.part]

    def front(self, name, part=0):
        """The latest texture of resource ``name``."""
        made = self.resources[name]
        return made.fronts[part] if isinstance(made, Textures) else made

    def run(self, stage, frame=None, clear=True, draws=None):
        """Draw ``stage`` (see the module's docstring) for ``frame`` (a :class:`Frame`; None:
        :meth:`frame` with no camera); ``clear`` False keeps what its target holds (an
        accumulated sample); ``draws``: indices into its ``repeat`` to draw instead of this
        frame's share."""
        self._use()
        frame = self.frame() if frame is None else frame
        command = self.commands[stage.name]
        target = self.resources[stage.target.resource]
        aspect = target.size[0] / target.size[1]
        values = {name: frame_value(spec, frame.camera, frame.step, self.ctx.caps, frame.motion,
                                    aspect)
                  for name, spec in stage.frame_uniforms.items()}
        swaps = self.plan.resources[stage.target.resource].swap == "draw"
        if clear:
            self.clear(stage)
        if stage.repeat:
            for index in self._next_draws(stage) if draws is None else draws:
                textures = {s: self.texture(ref) for s, ref in stage.inputs.items()}
                command.draw(target.framebuffer(stage.target.part), textures,
                             {**values, **stage.repeat[index]})
                if swaps:
                    target.swap()
            return
        textures = {s: self.texture(ref) for s, ref in stage.inputs.items()}
        framebuffer = target.framebuffer(stage.target.part)
        count = stage.count
        for attribute, ref in stage.attributes.items():
            self._read_back(stage, attribute, ref)
        if stage.slice is not None and count is not None and stage.slice < count:
            command.draw(framebuffer, textures, values, 0, stage.slice)
            self.ctx.flush()
            for first in range(stage.slice, count, stage.slice):
                command.draw(framebuffer, textures, None, first, min(stage.slice, count - first))
                self.ctx.flush()
        else:
            command.draw(framebuffer, textures, values, 0, count)
        if swaps:
            target.swap()

    def clear(self, stage):
        """Clear ``stage``'s target as the stage does before it draws (if it does)."""
        if stage.clear is not None:
            target = self.resources[stage.target.resource]
            self.ctx.clear(target.framebuffer(stage.target.part), stage.clear,
                           1.0 if target.depth is not None else None)

    def _read_back(self, stage, attribute, ref):
        """Read the texels of ``ref`` into the vertex buffer of ``attribute``: the first
        ``stage.count``, in texel order (RGBA8 as its bytes; half floats widened to float32,
        which ES 2.0 attributes take)."""
        fmt = self.plan.resources[ref.resource].format
        raw = self.ctx.read(self.texture(ref))
        texels = np.frombuffer(raw, numpy_dtype(fmt)).reshape(-1, 4)[:stage.count]
        if fmt == "rgba16f":
            texels = texels.astype(np.float32)
        self.ctx.write(self.buffers[(stage.name, attribute)], np.ascontiguousarray(texels)
                       .tobytes())

    def _next_draws(self, stage):
        """Indices into ``stage.repeat`` of this frame's draws: all, or the next ``per_frame``
        of the cycle (a whole cycle leaves its place where it was)."""
        n = len(stage.repeat)
        if stage.per_frame is None or stage.per_frame >= n:
            return range(n)
        cursor = self.cursors.get(stage.name, 0)
        self.cursors[stage.name] = (cursor + stage.per_frame) % n
        return [(cursor + i) % n for i in range(stage.per_frame)]

    def step(self):
        """Run every simulation stage once, then make this step's values the front ones."""
        self._use()
        frame = Frame(step=self.steps_done)
        for stages, count in self._rounds:
            for _ in range(count):
                for stage in stages:
                    self.run(stage, frame)
                    if stage.swap:
                        self.resources[stage.target.resource].swap()
        for name in self._swapped:
            self.resources[name].swap()
        self.steps_done += 1

    def render(self, frame=None, stages=None):
        """Run the frame's stages (or ``stages``) in order for ``frame`` (a :class:`Frame`),
        each of its ``samples`` (an accumulating stage: a step with the sample's uniforms before
        each draw after the first, the plain frame's set again after); returns the presented
        texture. The one place a frame is drawn: Pipeline, its live views, the Renderer and the
        cluster's shares draw through it, and the page's executor.js mirrors it."""
        self._use()
        frame = self.frame() if frame is None else frame
        for stage in self.plan.frame_stages if stages is None else stages:
            self.run(stage, frame)
            for sample in range(1, stage.samples):
                self.set_uniforms(self.plan.samples[sample])
                self.step()
                self.run(stage, self.frame(frame.camera), clear=False)
            if stage.samples > 1:
                self.set_uniforms(self.plan.samples[0])  # the next frame starts as a plain one
        return self.front(self.plan.present) if self.plan.present else None

    def set_uniforms(self, values):
        """Set simulation uniforms (name -> value, as the pass graph declares them) on every
        stage that declares each: a step's pass takes its interface's form."""
        for name, value in values.items():
            self.set_uniform(name, value, lambda stage, v, name=name: uniform_value(
                name, v, stage.interface.uniforms[name]) if stage.step else v)

    def set_uniform(self, name, value, convert=None):
        """Set uniform ``name`` on every stage that declares it among its own uniforms
        (``convert(stage, value)``, if given, turns the value into the stage's form)."""
        self._use()
        for stage in self.plan.stages:
            if name in stage.uniforms:
                self.commands[stage.name].set(name, value if convert is None
                                              else convert(stage, value))

    def write_vertices(self, name, array):
        """Replace vertex data ``name`` (the draw order of the particles, say)."""
        self._use()
        self.ctx.write(self.buffers[name], np.ascontiguousarray(array, np.float32).tobytes())

    def read(self, name, part=0):
        """The bytes of resource ``name``'s latest texture."""
        self._use()
        return self.ctx.read(self.front(name, part))

    def release(self):
        """Release every resource and command; safe to call twice."""
        if self.group is None:
            return
        if self.ctx._open:
            self.ctx.make_current()
        self.group.release()
        self.group = None
        self.resources, self.buffers, self.commands, self._swapped = {}, {}, {}, []
        self.external = {}  # borrowed, never released here: let go of them too

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()


def step_rounds(stages):
    """The step's stages as (stages, count) rounds: a run of consecutive stages of one loop
    (:attr:`~es2particles.frame.plan.Stage.loop`) repeated its count, each other stage once."""
    rounds = []
    for stage in stages:
        if stage.loop is not None and rounds and rounds[-1][0][-1].loop == stage.loop:
            rounds[-1][0].append(stage)
        else:
            rounds.append(([stage], stage.loop[1] if stage.loop else 1))
    return rounds


def _raw(array):
    """The bytes of a C-contiguous array as a flat memoryview (no copy)."""
    return memoryview(np.ascontiguousarray(array)).cast("B")
