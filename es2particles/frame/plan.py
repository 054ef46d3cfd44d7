"""The whole frame as one plan: what a frame runs, in order, as data, made with no GL.

:func:`plan_frame` makes a :class:`FramePlan` from a scene, its :class:`FrameSettings` and the
context's :class:`~es2particles.gl.context.Capabilities` (stated ones where there is no context):

- **resources**: the state quantities (ping-pong where last step's value is read), the scene's
  textures, fixed images (a sprite, a colour ramp, a mesh's texture) and the targets the frame
  draws into (the density, the colour image with its depth, a shadow map, a sort order, each post
  stage's output), each with its size, format and bytes;
- **stages**, in order, each a complete draw (regl's commands): its shaders and defines, the
  generated interface, which resource every sampler reads, the target it writes, its vertex data
  and primitive, its GL state, its uniforms, and the per-frame values it takes (the camera, the
  step number, a moving object's model matrix). The simulation's passes are stages of the step;
  sort, shadow map, meshes, particles and post are stages of the frame;
- **present**: the resource that is the picture. Culling walks back from it (Filament's
  ``present()``): a stage whose target nothing needed reads is left out, and the plan says so,
  with every pass, quantity and texture the pass graph left out and every feature switched off.

Two executors run the same plan: :class:`~es2particles.frame.executor.Executor` on EGL and the
WebGL page (``export/``), which serialises it. Renderers are chosen by what the scene declares
(a :class:`~es2particles.render.points.Density` or a
:class:`~es2particles.render.sprites.Sprites`), never by a string.
"""

import re
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import CapabilityError, GraphError, ParameterError, check_range
from ..gl.bindings import generated_values, pass_interface, uniform_value
from ..gl.context import Capabilities, texture_format
from .graph import scene_graph
from .neighbours import interface_lines, plan_neighbours
from .parts import Ref, Resource, Stage, Vertices, format_bytes  # noqa: F401 (renderers import them here)
from .motion import Motion
from .settings import (COMMON_SETTINGS, MAX_STEPS, Bloom, Defaults, FrameSettings, check_rounding,
                       check_settings, parse_size, parse_trails, resolve, resolve_format,
                       scene_rendering)
from .state import Layout

# --- frame values -------------------------------------------------------------------------------

FRAME_VALUES = ("step", "view_projection", "eye", "forward", "depth_range", "motion",
                "sprite_size", "jogl_sprite_size", "light_size", "depth_planes")
# lib/motion.glsl's uniforms as a frame gives them: the motion's time and Motion.uniforms.
MOTION_UNIFORMS = ("u_motion_time", "u_motion_pivot", "u_motion_spin", "u_motion_sway",
                   "u_motion_offset")
STILL = Motion(dt=0.0)  # the motion of meshes that move where the scene gives none: none


def motion_values(motion, step, drag=None):
    """:data:`MOTION_UNIFORMS`' values after ``step`` steps of ``motion`` (None: :data:`STILL`),
    its rest offset moved by ``drag`` (a hand's, 3 floats; None: none)."""
    motion = motion or STILL
    return {"u_motion_time": float(step * motion.dt),
            **motion.uniforms((0.0, 0.0, 0.0) if drag is None else drag)}


def depth_range(lo, hi, camera):
    """(near, far): the view depths of the nearest and farthest corners of the box [lo, hi]."""
    lo, hi = (np.asarray(v, dtype=np.float64) for v in (lo, hi))
    corners = np.array([[(hi if (c >> a) & 1 else lo)[a] for a in range(3)] for c in range(8)])
    depth = (corners - np.array(camera.eye)) @ camera.forward
    return float(depth.min()), float(depth.max())


def frame_value(spec, camera=None, step=0, caps=None, motion=None, aspect=1.0):
    """A uniform's value for this frame, from its ``spec`` (a name of :data:`FRAME_VALUES` and
    its arguments): the simulation's ``step``, the ``camera``'s view-projection for a target of
    ``aspect``, its eye and viewing direction, the ``depth_range`` (far, 1 / (far - near)) of a
    box's corners along it, a uniform of the moving object's ``motion`` (:func:`motion_values`;
    None: :data:`STILL`'s),
    and the sprites' and shadow map's sizes, whose last two numbers are the context's point size
    range. The WebGL page's executor computes the same from its own camera (``executor.js``)."""
    name, *args = spec
    if name == "step":
        return float(step)
    if name == "motion":
        return (motion or motion_values(None, 0))[args[0]]
    if name == "sprite_size":
        lo, hi = caps.drawn_point_size_range
        pixels, spread = args
        return (float(pixels), float(spread), float(lo), float(hi))
    if camera is None:
        raise ParameterError(f"frame value {name!r} needs a camera: this scene has none")
    if name == "jogl_sprite_size":  # the JOGL seed: size over the squared xz distance fraction
        lo, hi = caps.drawn_point_size_range
        pixels, spread, ax, az, d0 = args
        d2 = (camera.eye[0] - ax) ** 2 + (camera.eye[2] - az) ** 2
        return (float(pixels * d0 * d0 / max(d2, 1e-12)), float(spread), float(lo), float(hi))
    if name == "light_size":
        lo, hi = caps.drawn_point_size_range
        per_focal, light_focal, spread, height = args
        world = per_focal / camera.focal_pixels(height)
        return (float(world * light_focal), float(spread), float(lo), float(hi))
    if name == "view_projection":
        return camera.uniform(aspect)
    if name == "eye":
        return tuple(float(v) for v in camera.eye)
    if name == "forward":
        return tuple(float(v) for v in camera.forward)
    if name == "depth_planes":  # the camera's near and far: a depth buffer's value to a distance
        return (float(camera.near), float(camera.far), 1.0 if camera.ortho is not None else 0.0)
    if name == "depth_range":
        near, far = depth_range(*args, camera)
        return (far, 1.0 / max(far - near, 1e-30))
    raise ParameterError(f"unknown frame value {name!r} (known: {', '.join(FRAME_VALUES)})")


def _reads_state(stage):
    """Whether ``stage`` reads a quantity: through a sampler or a read-back attribute."""
    return bool(stage.attributes) or any(
        source[0] == "quantity" for interface in (stage.interface, stage.vertex_interface)
        if interface is not None for source in interface.samplers.values())


# --- the plan -----------------------------------------------------------------------------------

CATCH_UP_STEPS = 4  # steps a frame shown in real time may run to catch up with the clock


@dataclass
class FramePlan:
    """What a frame runs (see the module's docstring). ``graph``: the pass graph's
    :class:`~es2particles.frame.graph.Plan` of the simulation step; ``layout``, ``format``
    (``format_note`` says why) and ``rounding`` of the state; ``steps``, run before the first
    frame; ``accumulate``, samples summed into each image; ``camera``: a function of (frame,
    frames) giving the frame's camera (None for 2D); ``motion``: the moving object's
    :class:`~es2particles.frame.motion.Motion` (None where nothing moves).

    What a frame or a sample changes is data here, the same for every loop that runs the plan
    (Pipeline, the cluster's shares, the page): ``animation``, a function of (frame, frames)
    giving the uniforms a frame sets before its steps (the scene's ``frame_uniforms``; tabled
    by :meth:`animation_table` once the frame count is known), and ``samples``, the uniforms of
    each of the ``accumulate`` samples of this share's image (sample 0 first: the plain
    frame's)."""

    scene: str
    layout: Layout
    format: str
    format_note: str
    rounding: str
    graph: object
    pass_graph: object
    resources: dict
    vertices: dict
    stages: list
    present: str
    steps: int = 0
    accumulate: int = 1
    size: tuple = None
    camera: object = None
    motion: object = None
    rendering: object = None
    left_out: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    settings: dict = field(default_factory=dict)
    layouts: dict = field(default_factory=dict)  # grid name -> its Layout
    animation: object = None
    samples: tuple = ({},)
    dt: float = None  # the scene's time step (s): a live view or a playing page steps by it

    @property
    def clock(self):
        """How a frame shown in real time steps (LiveView, the page playing): the steps the
        wall time since the last frame is worth at ``dt``, at most ``max_steps`` (beyond that
        the scene runs slower than real time); without a time step, one step a frame."""
        return {"dt": self.dt, "max_steps": CATCH_UP_STEPS}

    def animation_table(self, frames):
        """The uniforms each of ``frames`` frames sets before its steps, one name -> value
        mapping a frame (empty ones where nothing is animated)."""
        if self.animation is None:
            return [{} for _ in range(frames)]
        return [dict(self.animation(frame, frames)) for frame in range(frames)]

    def layout_of(self, quantity):
        """The :class:`~es2particles.frame.state.Layout` of ``quantity``'s domain."""
        return self.layout if quantity.domain is None else self.layouts[quantity.domain.name]

    @property
    def step_stages(self):
        return [s for s in self.stages if s.step]

    @property
    def frame_stages(self):
        return [s for s in self.stages if not s.step]

    def stage(self, name):
        for s in self.stages:
            if s.name == name:
                return s
        raise GraphError(f"the plan has no stage {name!r} (stages: "
                         f"{', '.join(s.name for s in self.stages)})")

    def describe(self, measured=()):
        """The plan as lines: the simulation step's passes and state textures, the frame's
        stages with their targets and bytes, the textures of the frame, what was left out."""
        layout = self.layout
        lines = [f"scene: {self.scene}; {layout.count} particles in {layout.width}x"
                 f"{layout.height} texels ({layout.spare} spare, never drawn); state format "
                 f"{self.format_note}" + (f", {self.rounding} rounding" if self.format == "rgba8"
                                          else "")
                 + f"; {self.steps} steps before the first frame", "simulation step:"]
        lines += ["  " + line for line in self.graph.describe(self.format, layout)]
        lines += ["  " + line for line in self.notes]
        lines += ["  " + line for line in measured]
        lines.append("frame, in order:")
        if self.accumulate > 1:
            lines.append(f"  accumulate: {self.accumulate} samples per image (this step's "
                         f"density and the next {self.accumulate - 1} steps', "
                         f"{self.accumulate * layout.count} points), one tone map")
        first = len(self.step_stages)
        for i, stage in enumerate(self.frame_stages, first + 1):
            lines.append(f"  {i}. {self._describe_stage(stage)}")
        if self.present is not None:
            target = self.resources[self.present]
            lines.append(f"  present: {target.name} ({target.format} {target.size[0]}x"
                         f"{target.size[1]})")
        frame_textures = [r for r in self.resources.values() if r.kind != "state"]
        total = sum(r.nbytes for r in self.resources.values())
        lines.append(f"textures of the frame (state above), {format_bytes(total)} in all with "
                     "the state:")
        lines += [f"  {r.describe()}" + (f" ({r.what})" if r.what else "")
                  for r in frame_textures]
        lines.append("left out: " + (", ".join(self.left_out) if self.left_out else "nothing"))
        return lines

    def _describe_stage(self, s):
        reads = [("texture " if self.resources[r].kind == "image" else "") + r
                 for r in s.reads]
        draws = ""
        if s.repeat:
            draws = f"{len(s.repeat)} draws a frame, one per pass"
            if s.per_frame is not None:
                frames = -(-len(s.repeat) // s.per_frame)
                draws = (f"{s.per_frame} of {len(s.repeat)} draws a frame (all of them every "
                         f"{frames} frames)")
        if s.vertices is not None:
            v = self.vertices[s.vertices]
            count = s.count if s.count is not None else v.count
            unit = {"points": "points", "triangles": "vertices"}[s.primitive]
            draws = f"{count} {unit} ({v.name})"
        target = self.resources[s.target.resource]
        w, h = target.size
        clear = ", cleared first" if s.clear is not None else ""
        text = (f"{s.name}: {' + '.join(s.files)} -> {target.name} ({target.format} {w}x{h}, "
                f"{format_bytes(target.nbytes)}{clear}); reads {', '.join(reads) or 'nothing'}; "
                f"{s.state.describe()}")
        if draws:
            text += f"; {draws}"
        if s.what:
            text += f"; {s.what}"
        return text

    def __str__(self):
        return "\n".join(self.describe())


class PlanBuilder:
    """What :func:`plan_frame` and the render declarations add to while a plan is made: resources,
    vertex data and stages, with names checked unique; which settings were used; what was
    switched off."""

    def __init__(self, scene_name, settings, caps, rendering=None, defaults=None):
        self.scene_name, self.settings, self.caps = scene_name, settings, caps
        # the scene's Defaults, where a setting was not given (the framework's where none)
        self.defaults = defaults if defaults is not None else Defaults()
        self.rendering = rendering  # its settings are used, and its defaults of the post's
        self.uses = set(COMMON_SETTINGS) | set(getattr(rendering, "settings", ()))
        self.resources, self.vertices, self.stages = {}, {}, []
        self.left_out, self.notes = [], []
        self.layout = self.format = self.format_note = self.rounding = self.graph_plan = None
        self.pass_graph = None
        self.layouts = {}
        self.size, self.accumulate = None, 1

    def finish(self, present, **more):
        """The :class:`FramePlan` of what was added."""
        return FramePlan(scene=self.scene_name, layout=self.layout, format=self.format,
                         format_note=self.format_note, rounding=self.rounding,
                         graph=self.graph_plan, pass_graph=self.pass_graph,
                         resources=self.resources, layouts=self.layouts,
                         vertices=self.vertices, stages=self.stages, present=present,
                         accumulate=self.accumulate, left_out=self.left_out, notes=self.notes,
                         **more)

    def setting(self, name):
        """Setting ``name``, resolved (:func:`~es2particles.frame.settings.resolve`: given, else
        the scene's default, else the framework's): one the rendering declares it uses
        (``Rendering.settings``), or every frame's."""
        if name not in self.uses:
            raise GraphError(f"the rendering reads setting {name!r} but does not declare it "
                             f"(Rendering.settings: {', '.join(sorted(self.uses))})")
        return resolve(self.settings, self.defaults, name, self.rendering)

    def resource(self, resource):
        if resource.name in self.resources:
            raise GraphError(f"two resources of the frame are named {resource.name!r}")
        self.resources[resource.name] = resource
        return resource

    def vertex_data(self, vertices):
        if vertices.name in self.vertices:
            raise GraphError(f"two vertex data of the frame are named {vertices.name!r}")
        self.vertices[vertices.name] = vertices
        return vertices

    def stage(self, stage):
        """Add ``stage``, with what the state's rounding asks of it, whoever declared it
        (lib/state.glsl): STATE_DITHER for a pass, which writes state, under rounding "dither";
        STATE_JITTER and the step for a stage that reads packed state under "jitter", and to one
        that reads it through read-back attributes, each particle's texel (the jitter's hash
        input, which its reads otherwise do without)."""
        if self.rounding == "dither" and stage.step:
            stage = replace(stage, defines={"STATE_DITHER": None, **stage.defines})
        if self.jittered_reads and _reads_state(stage):
            stage = replace(stage, defines={**stage.defines, "STATE_JITTER": None},
                            frame_uniforms={**stage.frame_uniforms, "u_step": ("step",)})
            if stage.attributes and stage.vertices is None:
                stage = replace(stage, vertices=self.particle_texels())
        if any(s.name == stage.name for s in self.stages):
            raise GraphError(f"two stages of the frame are named {stage.name!r}")
        for sampler, ref in stage.inputs.items():
            if ref.resource not in self.resources:
                raise GraphError(f"{stage.name}: sampler {sampler} reads {ref.resource!r}, which "
                                 f"the frame does not have (has: {', '.join(self.resources)})")
        if stage.target.resource not in self.resources:
            raise GraphError(f"{stage.name} draws into {stage.target.resource!r}, which the "
                             "frame does not have")
        if stage.vertices is not None and stage.vertices not in self.vertices:
            raise GraphError(f"{stage.name} draws vertex data {stage.vertices!r}, which the "
                             "frame does not have")
        self.stages.append(stage)
        return stage

    @property
    def jittered_reads(self):
        """Whether reads of packed state are jittered (rounding "jitter" in RGBA8): each needs
        the texel it reads, a vertex stage too where it reads state back from attributes."""
        return self.rounding == "jitter" and self.format == "rgba8"

    def particle_texels(self):
        """The name of the vertex data naming each particle's texel, added the first time."""
        if "particles" not in self.vertices:
            self.vertex_data(Vertices("particles", "texels", self.layout.count, self.layout.width,
                                      self.layout.height))
        return "particles"

    def state_attributes(self, interface):
        """The :class:`Ref` of each attribute of a generated interface that reads quantities
        back (``bindings.stage_interface(..., attributes=True)``)."""
        return {name: Ref(q, part) for name, (q, part) in interface.attributes.items()}

    def state_inputs(self, interface, versioned=(), behind=()):
        """The :class:`Ref` of each sampler of a generated interface (quantities and scene
        textures). A ``versioned`` quantity's pair swaps after each write: its front is always
        the latest version, and last step's value, read after the first write (a quantity of
        ``behind``), is in the back."""
        out = {}
        for sampler, source in interface.samplers.items():
            if source[0] == "quantity":
                _, q, part, this_step = source
                back = (this_step and q not in versioned) or q in behind
                out[sampler] = Ref(q, part, "written" if back else "front")
            else:
                out[sampler] = Ref(source[1])
        return out


def plan_simulation(builder, graph, outputs, count, fmt, rounding):
    """Add the simulation of ``graph`` to ``builder``: the pass graph's plan of ``outputs``, the
    state layout of ``count`` particles in ``fmt``, a state resource per quantity, an image per
    scene texture, and a stage per draw of each pass (a quantity of three or four components in
    RGBA8 is written by two draws). Checks, with no GL, that each pass uses what it declares it
    reads."""
    from ..gl.command import _names
    from ..gl.shaders import expand

    caps = builder.caps
    check_rounding(rounding)
    plan = graph.plan(outputs)
    if count is None:  # a grid solver alone: no particle texture is made
        on_particles = [q for q, quantity in plan.quantities.items() if quantity.domain is None]
        if on_particles:
            raise ParameterError(f"the particle count is needed: quantities "
                                 f"{', '.join(on_particles)} live on the particles")
        layout = Layout(0, 1, 1)
    else:
        layout = Layout.for_count(count, caps.max_texture_size)
    fmt, note = resolve_format(caps, fmt)
    builder.graph_plan, builder.layout, builder.format = plan, layout, fmt
    builder.pass_graph = graph
    builder.format_note, builder.rounding = note, rounding
    builder.layouts = {name: grid.layout(caps.max_texture_size)
                       for name, grid in plan.grids.items()}
    for n in plan.neighbours.values():  # its table: one texel a cell
        if max(n.table_size) > caps.max_texture_size:
            raise ParameterError(f"neighbour grid {n.name!r}: its table of "
                                 f"{'x'.join(map(str, n.grid.shape))} cells is "
                                 f"{n.table_size[0]}x{n.table_size[1]} texels; this context's "
                                 f"textures are at most {caps.max_texture_size} a side: use "
                                 f"{n.larger_cells}")

    def layout_of(quantity):
        return layout if quantity.domain is None else builder.layouts[quantity.domain.name]

    for name, n in plan.buffers.items():
        q = plan.quantities[name]
        if q.storage and not caps.renderable.get(texture_format(q.storage)):
            raise CapabilityError(f"quantity {name!r} is pinned to {q.storage}, which cannot be "
                                  f"rendered to on {caps.renderer}")
        if q.format_in(fmt).startswith("rgba8") and not caps.fragment_highp:
            raise CapabilityError(f"quantity {name!r} is kept packed in {q.format_in(fmt)} "
                                  "(its declaration asks it), which fragment shaders without "
                                  "highp float cannot unpack")
        swap = "write" if name in plan.versioned else "step" if n == 2 else None
        where = f", on grid {q.domain.name}" if q.domain is not None else ""
        builder.resource(Resource(name, "state", layout_of(q).size, q.format_in(fmt),
                                  parts=q.parts(fmt), buffers=n, swap=swap, quantity=q,
                                  what=f"quantity, {q.components} components{where}"))
    hardware = _sampled_grids(builder, plan, fmt)
    for name in hardware:
        builder.resources[name] = replace(builder.resources[name], linear=True)
    for name, data in plan.textures.items():
        compressed = not isinstance(data, np.ndarray)
        fmt_of = "rgba8" if compressed else {np.dtype(np.uint8): "rgba8",
                                             np.dtype(np.float16): "rgba16f"}.get(data.dtype,
                                                                                  "rgba32f")
        size = (data.width, data.height) if compressed else (data.shape[1], data.shape[0])
        builder.resource(Resource(name, "image", size, fmt_of, data=data,
                                  what="scene texture"))
    behind = graph.last_step_after_a_write(plan.passes)
    orders = {}  # neighbour grid -> its Order, once built
    for spec, part, parts in plan.draws(fmt):
        mine = {q for name, q in behind if name == spec.name}
        if spec.builds:
            orders[spec.builds] = plan_neighbours(
                builder, plan.neighbours[spec.builds], plan, layout,
                lambda interface: builder.state_inputs(interface, plan.versioned, mine))
            continue
        near, defines = None, dict(spec.defines)
        if spec.neighbours is not None:
            n = plan.neighbours[spec.neighbours]
            near = interface_lines(n, orders[n.name], layout)
            defines.update(orders[n.name].defines())
        interface = pass_interface(spec, graph.quantities, fmt, part, near, hardware)
        stage_name = spec.stage(part)
        source = expand(spec.frag, defines, interface.lines, interface.epilogue)
        _, referenced = _names(source)
        for sampler, (kind, what) in ((n, v[:2]) for n, v in interface.samplers.items()):
            calls = [sampler]
            if kind == "quantity":  # a grid's quantity has three accessors; any of them reads
                grid = graph.quantities[what].domain is not None
                calls = [f"read_{what}"] + ([f"{what}_at", f"sample_{what}"] if grid else [])
            if not set(calls) & referenced:
                raise ParameterError(f"{stage_name} ({spec.frag}) declares it reads {kind} "
                                     f"{what!r} but its shader never uses {' or '.join(calls)}")
        q = plan.quantities[spec.writes]
        what = f"part {part + 1}/{parts} ({q.part_axes(fmt, part)})" if parts > 1 else ""
        loop = plan.repeats[spec.repeat] if spec.repeat else None
        builder.stage(Stage(
            stage_name, "pass", spec.frag, defines=defines, interface=interface,
            inputs=builder.state_inputs(interface, plan.versioned, mine),
            target=Ref(spec.writes, part),
            uniforms={name: uniform_value(name, value, interface.uniforms[name])
                      for name, value in spec.uniforms.items()},
            generated=generated_values(interface, layout_of(q)),
            frame_uniforms={"u_step": ("step",)} if "u_step" in referenced else {},
            step=True, swap=spec.writes in plan.versioned and part == parts - 1,
            loop=(loop.name, loop.count) if loop else None, what=what))
    builder.left_out += [f"pass {p.name}" for p in plan.left_out_passes]
    builder.left_out += [f"quantity {q}" for q in plan.left_out_quantities]
    builder.left_out += [f"texture {t}" for t in plan.left_out_textures]
    return plan


def _sampled_grids(builder, plan, fmt):
    """The grid quantities whose samples (``sample_q``) the hardware filters: those declared
    ``sampling="hardware"`` that are stored as floats in a format this context filters LINEAR.
    The rest are sampled by hand from decoded cells; a note says which for each one sampled."""
    from ..gl.bindings import strip_comments
    from ..gl.shaders import expand

    on_grids = {q for q in plan.buffers if plan.quantities[q].domain is not None}
    sampled = set()
    for spec in plan.passes:
        reads = (set(spec.reads) | set(spec.reads_new)) & on_grids - sampled
        if reads:
            text = strip_comments(expand(spec.frag, dict(spec.defines)).text)
            sampled |= {q for q in reads if re.search(rf"\bsample_{q}\b", text)}
    hardware = set()
    for name in sorted(sampled):
        q = plan.quantities[name]
        stored, how = q.format_in(fmt), ("bilinear", "trilinear")[q.domain.dimensions - 2]
        floats = stored in ("rgba16f", "rgba32f")
        if q.sampling == "hardware" and floats and builder.caps.filters(stored):
            hardware.add(name)
            taps = ", one fetch a slice" if q.domain.dimensions == 3 else ""
            builder.notes.append(f"sample_{name}: {how} by the hardware ({stored} filtered "
                                 f"LINEAR{taps}; weights at its sub-texel precision)")
            continue
        why = (f"{stored} is packed: linear filtering would mix its bytes" if not floats else
               "declared by hand: exact to float32" if q.sampling == "hand" else
               f"this context does not filter {stored} LINEAR")
        builder.notes.append(f"sample_{name}: {how} by hand from "
                             f"{4 * (q.domain.dimensions - 1)} decoded cells ({why})")
    return frozenset(hardware)


def plan_graph(graph, count, outputs=None, fmt="rgba8", rounding="nearest", caps=None):
    """The :class:`FramePlan` of a simulation alone: the passes of ``graph`` computing
    ``outputs`` (default: every written quantity) for ``count`` particles, and no frame stages."""
    b = PlanBuilder("", FrameSettings(), caps if caps is not None else Capabilities.assumed())
    plan_simulation(b, graph, outputs, count, fmt, rounding)
    return b.finish(present=None)


def plan_frame(scene, settings=FrameSettings(), caps=None):
    """The :class:`FramePlan` of ``scene`` with ``settings`` on a context of ``caps`` (stated
    ones, :meth:`Capabilities.assumed`, where None): pure Python, no GL. Every setting left as
    DEFAULT takes the scene's default, resolved here once; a setting given that the frame does not
    use is an error naming it (:func:`check_settings`)."""
    if caps is None:
        caps = Capabilities.assumed()
    rendering = scene_rendering(scene, settings.particles)
    check_settings(settings, scene, rendering)
    defaults = scene.defaults
    b = PlanBuilder(scene.name, settings, caps, rendering, defaults)
    size = parse_size(b.setting("size"), caps.max_texture_size)
    steps = int(check_range("steps", b.setting("steps"), 0, MAX_STEPS,
                            integer=True))
    seed = b.setting("seed")
    graph = scene_graph(scene, caps, b.setting("particles"))
    rendering.check_reads(scene, graph)
    b.size = size
    outputs = tuple(dict.fromkeys(tuple(rendering.reads) + tuple(getattr(scene, "saves", ()))))
    trails, value = parse_trails(b.setting("trails"))  # the fade's opacity, ribbons' K
    if trails == "ribbons" and "life" in graph.quantities and graph.writer("life") is not None:
        outputs = tuple(dict.fromkeys(outputs + ("life",)))  # a ribbon ends where a life does
    count = b.setting("particles") or None  # 0: the grids alone
    count = count if graph.quantities else None
    plan_simulation(b, graph, outputs, count, b.setting("format"),
                    b.setting("rounding"))
    present = plan_picture(b, rendering, defaults)
    if trails != "off":
        from .trails import plan_trails

        present = plan_trails(b, present, trails, value, rendering)
    culled = _cull(b.stages, present)
    b.left_out += [f"{s.kind} stage {s.name} (nothing reads {s.target.resource})"
                   for s in b.stages if s.name in culled]
    b.stages = [s for s in b.stages if s.name not in culled]
    b.notes = list(graph.notes) + list(scene.describe()) + b.notes
    first = settings.share * b.accumulate  # this share's samples follow the shares before it
    return b.finish(present=present, steps=steps, size=size, rendering=rendering,
                    camera=scene.camera_at if rendering.has_camera else None,
                    motion=scene.motion() if rendering.has_camera else None,
                    settings={"seed": seed, "share": settings.share},
                    animation=scene.frame_uniforms,
                    dt=scene.time_step(b.setting("particles")),
                    samples=tuple(dict(scene.sample_uniforms(first + s, b.accumulate))
                                  for s in range(b.accumulate)))


def plan_picture(b, rendering, defaults):
    """The stages of ``rendering``'s picture added to plan builder ``b``, then the post chain
    every rendering's picture takes: the gradient map, where the rendering maps none of its own
    (``own_gradient``) and the run asks for a ramp, and bloom, where the run or the rendering's
    default asks for it; returns the name of the picture then."""
    from .bloom import plan_bloom
    from .gradient import plan_gradient_map

    picture = rendering.plan(b, defaults)
    if not rendering.own_gradient:
        picture = plan_gradient_map(b, picture, b.setting("gradient"))
    return plan_bloom(b, picture, b.setting("bloom"))


def _cull(stages, present):
    """Names of the frame stages whose target no needed stage reads, walking back from the
    presented resource (the simulation's passes are culled by the pass graph)."""
    needed_resources, needed = {present}, set()
    for stage in reversed([s for s in stages if not s.step]):
        if stage.target.resource in needed_resources:
            needed.add(stage.name)
            needed_resources.update(stage.reads)
    return {s.name for s in stages if not s.step and s.name not in needed}


class Rendering:
    """What a scene draws, declared (a :class:`~es2particles.render.points.Density` or
    :class:`~es2particles.render.sprites.Sprites`): the quantities it reads, which are outputs
    of the simulation's plan, and the stages it adds to a frame plan (:meth:`plan`, which returns
    the name of the presented resource). ``has_camera``: its frames are seen through the scene's
    camera (3D)."""

    reads = ("position",)
    settings = ()  # the frame settings it uses beside COMMON_SETTINGS
    # True where its own stages colour the picture along the gradient map (a density's tone
    # map); else the post chain's gradient map recolours the picture where a ramp is asked for
    own_gradient = False
    # Bloom over its picture: where a run does not say (None: off), and the parts a run that
    # switches it on without giving them takes. Over lit meshes a threshold of 0.2 (the
    # density's) blooms the floor and blurs its checks; at 0.6 the sprites' cores glow.
    default_bloom = None
    bloom_parts = Bloom(threshold=0.6)
    has_camera = False
    kind = "a rendering"

    def check_reads(self, scene, graph):
        """Raise unless every quantity read is one a pass of ``graph`` writes."""
        for name in self.reads:
            if name not in graph.quantities or graph.writer(name) is None:
                how = ("declares but no pass writes" if name in graph.quantities
                       else "does not declare")
                raise GraphError(f"the renderer reads {name!r}, which scene {scene.name!r} {how} "
                                 f"(its quantities: {', '.join(graph.quantities) or 'none'})")

    def check_settings(self, given):
        """Check the settings given (name -> value) of those it uses (``settings``), with no
        context: each of its kind and in its range. Raises :class:`ParameterError`."""

    def plan(self, b, defaults):
        raise NotImplementedError

    def warnings(self, camera, size):
        """Why a feature switched on may barely show in a picture of ``size`` seen by ``camera``:
        one line each: the light shafts' (``render/shafts.py``) of a rendering that has them in
        a ``shafts`` field; none otherwise."""
        shafts = getattr(self, "shafts", None)
        return () if shafts is None else shafts.warnings(camera, size)
