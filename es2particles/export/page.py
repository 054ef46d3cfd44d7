"""A scene as one self-contained WebGL 1 page: its frame plan, serialised, run in a real OpenGL ES
2.0 context.

:func:`page_plan` makes the scene's :class:`~es2particles.frame.plan.FramePlan` for a page (the
capabilities a WebGL 1 context states, :data:`PAGE_CAPS`; state in RGBA8, the one format every
ES 2.0 context renders to) and writes it as data, without GL: every resource with its start
contents (the state's start texels as the scene sets them, images, a sort order's first slots),
the vertex data, every stage's expanded GLSL ES 1.00 sources (the very text EGL compiles,
generated interface included), its inputs, target, GL state, uniforms and per-frame values, the
scene's camera and motion, and its sliders. :func:`write_page` puts that data, the executor
(``webpage/executor.js``, which runs any plan's stages in order, as the EGL executor does) and
the page around it into one HTML file that needs no network. Mouse drag orbits a 3D page's camera
and the wheel zooms.

What WebGL 1 may lack is decided by the page from what its context offers, each fallback named
on the page:

- the density of 2D scenes (``DENSITY_PATHS``; ``?density=NAME`` forces one): ``float``,
  additive points into RGBA32F (WEBGL_color_buffer_float + EXT_float_blend), as EGL; ``half``,
  batches of points into RGBA16F, each added to an exact whole count in RGBA8
  (``density/add.frag``, ``lib/counts.glsl``); ``bytes``, the same with RGBA8 batches, one code a
  hit, a quarter of each batch per channel (colour masks), nothing beyond ES 2.0. A batch channel
  that fills to its top flags its pixel (``es2particles.density()`` counts them);
- a target in a float format (the opacity shadow map) falls back to the next format the context
  can blend into, with the stages' uniforms for that format (``fallbacks``);
- an ASTC-compressed scene texture is sent as its blocks and as the texels they decode to: the
  page uploads the blocks where the context offers WEBGL_compressed_texture_astc, else the texels.
"""

import base64
import json
import re
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..errors import CapabilityError, GraphError, ParameterError
from ..frame.plan import frame_value, motion_values, plan_frame
from ..frame.settings import DEFAULT
from ..frame.state import as_rows, encode_values, fill_texels, part_textures, zero_texels
from ..gl.context import Capabilities, texture_format
from ..gl.shaders import expand

DENSITY_PATHS = ("float", "half", "bytes")
# What one hit adds to a batch channel, and how many codes a full-strength hit is worth: a point
# that fades with its age (AGE_FADE) adds round(fade * levels) codes, so a fade keeps that many
# steps where a batch is counted in whole codes.
FADE_LEVELS = {"half": 64, "bytes": 8}
# Points per batch: a quarter per channel. A bytes channel holds 255 codes, a half float one
# 2048 exactly; a batch is a point draw plus a full-screen add, so fewer batches are faster.
BATCH_POINTS = {"half": 2 ** 18, "bytes": 2 ** 14}
# What a page plans with: the sizes nearly every WebGL 1 device offers and the formats the page
# can fall back from (the page checks its own context's limits and says what it took).
MAX_TEXTURE_SIZE = 4096
_FLOATS = {"rgba8": True, "rgba16f": True, "rgba32f": True, "r32f": False}
PAGE_CAPS = Capabilities.assumed(
    backend="webgl", renderer="a WebGL 1 page", version="WebGL 1.0 (OpenGL ES 2.0)",
    max_texture_size=MAX_TEXTURE_SIZE, point_size_range=(1.0, 64.0), renderable=dict(_FLOATS),
    blendable=dict(_FLOATS))
# The frame values that depend on the camera: a page computes them from its own (mouse-driven)
# camera, and takes the plan's numbers for the camera it starts with.
CAMERA_VALUES = ("view_projection", "eye", "forward", "depth_range", "light_size",
                 "jogl_sprite_size")
WEBPAGE = Path(__file__).resolve().parent / "webpage"


class _Start:
    """What ``Scene.initialise`` sets, recorded as texels (the simulation's calls, no GL)."""

    def __init__(self, quantities, layout, plan=None):
        self.quantities, self.layout, self.texels = quantities, layout, {}
        self.plan = plan

    @property
    def count(self):
        return self.layout.count

    def _quantity(self, name):
        if name not in self.quantities:
            raise ParameterError(f"the start sets quantity {name!r}, which is not in the plan "
                                 f"(has: {', '.join(self.quantities)})")
        return self.quantities[name]

    def _layout(self, q):
        return self.layout if self.plan is None else self.plan.layout_of(q)

    def fill_uniform(self, name, lo, hi, rng):
        from ..frame.simulation import fill_box

        q = self._quantity(name)
        lo, span = fill_box(name, lo, hi, q.components)
        self.texels[name] = fill_texels(q, self._layout(q), lo, span, rng, "rgba8")

    def upload(self, name, values):
        q = self._quantity(name)
        layout = self._layout(q)
        self.texels[name] = encode_values(q, layout, as_rows(q, layout, values), "rgba8")


def _flat(value):
    """A uniform's value as a flat list of floats (what uniform*fv takes)."""
    return [float(v) for v in np.asarray(value, dtype=np.float64).ravel()]


def _bytes(array):
    return base64.b64encode(np.ascontiguousarray(array).tobytes()).decode("ascii")


class _Programs:
    """The expanded sources of the page's programs, each pair once."""

    def __init__(self):
        self.sources, self._index = [], {}

    def add(self, name, vertex, fragment, defines=None, vertex_prelude=None,
            fragment_prelude=None, fragment_epilogue=None):
        vs = expand(vertex, defines, vertex_prelude)
        fs = expand(fragment, defines, fragment_prelude, fragment_epilogue)
        key = (vs.text, fs.text)
        if key not in self._index:
            self._index[key] = len(self.sources)
            self.sources.append({"name": name, "vertex": vs.text, "fragment": fs.text,
                                 "files": [str(vertex), str(fragment)]})
        return self._index[key]

    def of(self, stage, extra_defines=None):
        return self.add(stage.name, stage.vertex, stage.fragment,
                        {**stage.defines, **(extra_defines or {})},
                        stage.vertex_interface.lines if stage.vertex_interface else None,
                        stage.interface.lines if stage.interface else None,
                        stage.interface.epilogue if stage.interface else None)


def page_settings(settings=None, **given):
    """The frame settings of a page: a FrameSettings, changed by keywords (as
    :class:`~es2particles.frame.pipeline.Pipeline` takes them), checked for what a page
    cannot do."""
    from ..frame.pipeline import settings_of

    settings = settings_of(settings, **given)
    if settings.format not in (DEFAULT, "rgba8"):
        raise ParameterError(f"--format {settings.format}: a page keeps its state in rgba8, the "
                             "one format every ES 2.0 context can render to")
    return settings


def page_plan(scene, settings=None, frames=1, steps_per_frame=1, **given):
    """The scene's whole frame as JSON-ready data for the WebGL page (see the module's
    docstring): ``settings`` (a FrameSettings) and keywords as
    :class:`~es2particles.frame.pipeline.Pipeline` takes them, defaults resolved the same way.
    ``frames`` and ``steps_per_frame``: the run's animation, whose frame uniforms the page sets
    frame by frame as Pipeline.frames does (and then holds the last frame's), taking
    ``steps_per_frame`` steps between frames."""
    from ..frame.pipeline import SeededRandom

    settings = page_settings(settings, **given)
    plan = plan_frame(scene, settings, PAGE_CAPS)
    for name, r in plan.resources.items():
        if r.kind == "state" and texture_format(r.format) != "rgba8":
            raise CapabilityError(f"quantity {name!r} is pinned to {r.format}; the page keeps "
                                  "every quantity in rgba8, the one format every ES 2.0 context "
                                  "renders to")
    layout = plan.layout
    programs = _Programs()

    start = _Start({n: r.quantity for n, r in plan.resources.items() if r.kind == "state"},
                   layout, plan)
    scene.initialise(start, SeededRandom(plan.settings["seed"]))
    resources = {name: _resource(r, plan.layout_of(r.quantity) if r.kind == "state" else layout,
                                 start) for name, r in plan.resources.items()}
    _fallbacks(plan, resources)
    camera = plan.camera(0, 1) if plan.camera is not None else None
    stages = []
    for stage in plan.stages:
        target = plan.resources[stage.target.resource]
        aspect = target.size[0] / target.size[1]
        entry = {"name": stage.name, "kind": stage.kind, "program": programs.of(stage),
                 "inputs": {s: [r.resource, r.part, r.when] for s, r in stage.inputs.items()},
                 "target": [stage.target.resource, stage.target.part],
                 "vertices": stage.vertices, "primitive": stage.primitive, "count": stage.count,
                 "attributes": {a: [ref.resource, ref.part] for a, ref in stage.attributes.items()},
                 "state": asdict(stage.state), "clear": stage.clear, "step": stage.step,
                 "uniforms": {k: _flat(v) for k, v in {**stage.generated,
                                                       **stage.uniforms}.items()},
                 "frame_uniforms": {k: [spec[0], *(a if isinstance(a, str) else _json_number(a)
                                                    for a in spec[1:])]
                                    for k, spec in stage.frame_uniforms.items()},
                 "repeat": [{k: _flat(v) for k, v in r.items()} for r in stage.repeat],
                 "per_frame": stage.per_frame, "swap": stage.swap, "samples": stage.samples,
                 "loop": list(stage.loop) if stage.loop else None}
        # The numbers of the camera the page starts with, as EGL computes them, so the first
        # frames are the EGL run's (the page's own float64 arithmetic may round a last bit the
        # other way); a page whose camera was moved computes its own.
        entry["initial"] = {k: _flat(frame_value(spec, camera, 0, PAGE_CAPS, None, aspect))
                            for k, spec in stage.frame_uniforms.items()
                            if spec[0] in CAMERA_VALUES and camera is not None}
        if stage.kind == "post" and stage.fragment == "post/tonemap.frag" \
                and "HUE" not in stage.defines:  # a hue needs the float path's sums
            entry["program_counts"] = programs.of(stage, {"DENSITY_COUNTS": None})
        stages.append(entry)
    density = None
    if "points" in [s.kind for s in plan.stages]:
        points = plan.stage("points")
        hue = "HUE" in points.defines  # the sums of a hue need blending in floats
        density = {"paths": ["float"] if hue else list(DENSITY_PATHS), "hue": hue,
                   "fade_levels": FADE_LEVELS,
                   "batch": BATCH_POINTS, "fade": "AGE_FADE" in points.defines,
                   "intensity": float(points.uniforms["u_colour"][0]),
                   "add": programs.add("density add", "lib/fullscreen.vert", "density/add.frag")}
    present = programs.add("present", "lib/fullscreen.vert", "post/present.frag")
    vertices = {}
    for name, v in plan.vertices.items():
        entry = {"source": v.source, "count": v.count, "width": v.width, "height": v.height,
                 "attributes": [list(a) for a in v.attributes]}
        if v.source == "data":
            entry["data"] = _bytes(v.array())
        if v.indexed:
            entry["indices"] = _bytes(v.index_array())
        vertices[name] = entry
    return {"scene": scene.name, "title": (scene.__doc__ or scene.name).strip().splitlines()[0],
            "layout": {"count": layout.count, "width": layout.width, "height": layout.height},
            "size": list(plan.size), "steps": plan.steps, "seed": plan.settings["seed"],
            # What a frame or a sample changes, as the plan tables it (FramePlan's animation
            # and samples): the uniforms each frame sets before its steps, and each
            # accumulated sample's uniforms (sample 0 first; a stage's samples draws them).
            "animation": _animation(plan, frames),
            "samples": [{k: _flat(v) for k, v in row.items()} for row in plan.samples],
            "steps_per_frame": steps_per_frame,
            "clock": plan.clock,
            "rounding": plan.rounding, "resources": resources, "vertices": vertices,
            "stages": stages, "present": plan.present, "present_program": present,
            "programs": programs.sources, "density": density,
            "camera": _camera(camera), "motion": _motion(plan.motion),
            "controls": [asdict(c) for c in scene.controls()],
            "grip": _grip(scene.grip(), plan.motion),
            "push": _push(scene, plan),
            # Whether a vertex shader samples a texture (particles by vertex texture fetch):
            # the page needs vertex texture units only then.
            "vertex_fetch": any(s.vertex_interface is not None and s.vertex_interface.samplers
                                for s in plan.stages),
            "plan": plan.describe()}


def _animation(plan, frames):
    """The uniforms of each frame, flat; none at all where nothing is animated."""
    table = [{k: _flat(v) for k, v in row.items()} for row in plan.animation_table(frames)]
    return table if any(table) else []


def _json_number(value):
    """A frame value's argument as JSON: numbers, or lists of numbers."""
    if np.ndim(value):
        return [float(v) for v in np.ravel(value)]
    return float(value)


def _resource(r, layout, start):
    entry = {"kind": r.kind, "width": r.size[0], "height": r.size[1],
             "format": texture_format(r.format),
             "parts": r.parts, "buffers": r.buffers, "swap": r.swap, "depth": r.depth,
             "linear": r.linear}
    if r.kind == "state":
        q = r.quantity
        if r.name in start.texels:
            texels = np.asarray(start.texels[r.name], np.uint8).reshape(layout.count, r.parts, 4)
            entry["parts_data"] = [_bytes(full) for full in part_textures(texels, layout,
                                                                          "rgba8")]
        else:  # what StateBuffer clears to: one texel a part
            entry["clear"] = np.asarray(zero_texels(q, "rgba8"), np.uint8).tolist()
        return entry
    if r.data is None:
        return entry
    if hasattr(r.data, "block"):  # ASTC blocks, and the texels they decode to
        from ..gl import astc

        c = r.data
        entry["data"] = _bytes(astc.decompress(c))
        entry["type"] = "bytes"
        entry["astc"] = {"block": list(c.block), "internal_format": c.internal_format,
                         "data": _bytes(np.frombuffer(c.data, np.uint8))}
        return entry
    data = np.asarray(r.contents())
    entry["type"] = "bytes" if data.dtype == np.uint8 else "float"
    entry["data"] = _bytes(data.astype(np.uint8 if entry["type"] == "bytes" else np.float32))
    return entry


def _fallbacks(plan, resources):
    """A float target's fallbacks: the formats the page tries after its own, each with the
    uniforms the stages take for it (the shadow map's opacity unit)."""
    from ..render.shadow import map_uniforms

    rendering = plan.rendering
    shadow = getattr(rendering, "shadow", None)
    if "shadow map" not in resources or shadow is None:
        return
    order = ("rgba32f", "rgba16f", "rgba8")
    first = resources["shadow map"]["format"]
    resources["shadow map"]["fallbacks"] = [
        {"format": fmt, "uniforms": {k: _flat(v) for k, v in map_uniforms(
            shadow, fmt, rendering.opacity).items() if k in ("u_shadow", "u_shadow_opacity")}}
        for fmt in order[order.index(first):]]


def _camera(camera):
    """The scene's camera and the mouse's constants (``live/controls.py``'s, the window's)."""
    if camera is None:
        return None
    from ..live.controls import DISTANCE_LIMITS, ELEVATION_LIMIT, ORBIT_RATE, WHEEL_STEP

    return {"eye": list(camera.eye), "target": list(camera.target), "up": list(camera.up),
            "fov": camera.fov, "near": camera.near, "far": camera.far, "ortho": camera.ortho,
            "orbit_rate": ORBIT_RATE, "elevation_limit": ELEVATION_LIMIT,
            "distance_limits": list(DISTANCE_LIMITS), "wheel_step": WHEEL_STEP}


def _grip(grip, motion):
    """A scene's grip (what a drag moves over the floor), or None. Its drag moves the motion's
    rest offset, at the motion's step: a grip without a motion is refused."""
    if grip is None:
        return None
    if motion is None:
        raise GraphError("the scene declares a grip but no motion: the page moves a grip's "
                         "sphere by the motion's offset, a step of its dt (Scene.motion)")
    return {k: _json_number(v) if k not in ("uniform", "velocity") else v
            for k, v in asdict(grip).items()}


def _push(scene, plan):
    """A 2D scene's push (what a drag does to the air): its uniforms, radius, the world
    rectangle the picture shows and the step's dt (the pointer's velocity is its move over a
    step), or None."""
    push = scene.push() if not plan.rendering.has_camera else None
    if push is None:
        return None
    if not isinstance(plan.dt, float):
        raise ParameterError(f"scene {scene.name!r} has a push but no dt a step: the page "
                             "cannot give the pointer a velocity")
    return {"at": push.at, "velocity": push.velocity, "radius": _json_number(push.radius),
            "view": [_json_number(v) for v in scene.view], "dt": plan.dt}


def _motion(motion):
    """The moving object's step length and ``lib/motion.glsl``'s uniforms at step 0 (the page
    gives the time and the grip's drag): the formula itself stays in the shader."""
    return {"dt": _json_number(motion.dt if motion is not None else 0.0),
            "uniforms": {name: [_json_number(v) for v in np.atleast_1d(value)]
                         for name, value in motion_values(motion, 0).items()}}


def write_page(plan, out):
    """Write the page of ``plan`` (from :func:`page_plan`) to ``out`` (.html), atomically."""
    from ..io.output import write_atomic

    # JSON inside a script element: every "<" escaped, so no "</script>" or "<!--" can close it.
    fills = {"title": _escape(f"es2particles: {plan['title']}"),
             "style": (WEBPAGE / "page.css").read_text(encoding="utf-8"),
             "executor": (WEBPAGE / "executor.js").read_text(encoding="utf-8"),
             "plan": json.dumps(plan, separators=(",", ":")).replace("<", "\\u003c")}
    template = (WEBPAGE / "page.html").read_text(encoding="utf-8")
    text = re.sub(r"\{\{(\w+)\}\}", lambda m: fills[m.group(1)], template)
    return write_atomic(out, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def _escape(text):
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")

