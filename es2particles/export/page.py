"""A scene as one self-contained WebGL 1 page: the same plan, run in a real OpenGL ES 2.0 context.

:func:`page_plan` writes a scene's whole frame as data, without GL: the state textures with their
start texels, every pass's expanded GLSL ES 1.00 source (the very text EGL compiles, generated
interface included) with its inputs and uniforms, the point renderer, the post stages
(``post.post_stages``) and the page's sliders. :func:`write_page` puts that data, the executor
(``webpage/executor.js``) and the page around it into one HTML file that needs no network.

WebGL 1 is ES 2.0: RGBA8 is the only format it must render to, and a float target, or blending
into one, comes only with extensions. The page sums the density in the first way its context
offers (``DENSITY_PATHS``; ``?density=NAME`` in the page's address forces one):

- ``float``: additive points into RGBA32F (WEBGL_color_buffer_float + EXT_float_blend), as EGL;
- ``half``: batches of points into RGBA16F (EXT_color_buffer_half_float), each batch added to an
  exact whole count in RGBA8 (``density/add.frag``, ``lib/counts.glsl``);
- ``bytes``: the same with RGBA8 batches, one code per hit, a quarter of each batch per channel
  (colour masks) so a channel holds 255 hits; nothing beyond ES 2.0.

A batch channel that fills to its top sets a flag in the count; the page's
``es2particles.density()`` counts the flagged pixels.
"""

import base64
import json
import re
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..gl.bindings import (check_writes, generated_values, pass_interface, stage_interface,
                       uniform_value)
from ..errors import CapabilityError, ParameterError, check_range
from ..frame.pipeline import SeededRandom, check_render_reads, parse_size
from ..render.post import post_stages
from ..render.ramps import load_ramp
from ..render.points import point_uniforms
from ..gl.shaders import expand
from ..frame.simulation import check_rounding, draw_defines, fill_box
from ..frame.state import Layout, encode_values, fill_texels, part_textures, zero_texels

DENSITY_PATHS = ("float", "half", "bytes")
# What one hit adds to a batch channel, and how many codes a full-strength hit is worth: a point
# that fades with its age (AGE_FADE) adds round(fade * levels) codes, so a fade keeps that many
# steps where a batch is counted in whole codes.
FADE_LEVELS = {"half": 64, "bytes": 8}
# Points per batch: a quarter per channel. A bytes channel holds 255 codes, a half float one
# 2048 exactly; a batch is a point draw plus a full-screen add, so fewer batches are faster.
BATCH_POINTS = {"half": 2 ** 18, "bytes": 2 ** 14}
# State and images larger than this need a context that says it can hold them; 4096 is what
# nearly every WebGL 1 device offers (the page checks its own limit and says so).
MAX_TEXTURE_SIZE = 4096
WEBPAGE = Path(__file__).resolve().parent / "webpage"


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
        return self._index[key], fs


class _Start:
    """What ``Scene.initialise`` sets, recorded as texels (the simulation's calls, no GL)."""

    def __init__(self, quantities, layout):
        self.quantities, self.layout, self.texels = quantities, layout, {}

    @property
    def count(self):
        return self.layout.count

    def _quantity(self, name):
        if name not in self.quantities:
            raise ParameterError(f"the start sets quantity {name!r}, which is not in the plan "
                                 f"(has: {', '.join(self.quantities)})")
        return self.quantities[name]

    def fill_uniform(self, name, lo, hi, rng):
        q = self._quantity(name)
        lo, span = fill_box(name, lo, hi, q.components)
        self.texels[name] = fill_texels(q, self.layout, lo, span, rng, "rgba8")

    def upload(self, name, values):
        self.texels[name] = encode_values(self._quantity(name), self.layout, values, "rgba8")


def _flat(value):
    """A uniform's value as a flat list of floats (what uniform*fv takes)."""
    return [float(v) for v in np.asarray(value, dtype=np.float64).ravel()]


def _bytes(array):
    return base64.b64encode(np.ascontiguousarray(array).tobytes()).decode("ascii")


def _texels(quantity, layout, texels):
    """Each part's whole texture (spare texels zero) as base64."""
    texels = np.asarray(texels, np.uint8).reshape(layout.count, quantity.parts("rgba8"), 4)
    return [_bytes(full) for full in part_textures(texels, layout, "rgba8")]


def page_plan(scene, particles=None, size=(1024, 1024), point_size=None, intensity=1.0,
              exposure=4.0, gradient="inferno", bloom=None, seed=0, rounding=None, steps=None):
    """A density scene's whole frame as JSON-ready data for the WebGL page (see the module's
    docstring); the parameters are :class:`~es2particles.frame.pipeline.Pipeline`'s, defaults
    resolved the same way. The state is RGBA8 (the ES 2.0 baseline)."""
    if scene.render != "density":
        raise CapabilityError(f"export draws density scenes (dejong, clifford, collision); "
                              f"{scene.name!r} draws 3D sprites, which the page does not have yet")
    defaults = scene.defaults
    size = parse_size(size, MAX_TEXTURE_SIZE)
    seed = int(check_range("seed", seed, 0, 2 ** 63 - 1, integer=True))
    steps = int(check_range("steps", defaults.steps if steps is None else steps, 0, 10 ** 6,
                            integer=True))
    rounding = check_rounding(defaults.rounding if rounding is None else rounding)
    point_size = check_range("point_size", defaults.point_size if point_size is None
                             else point_size, 1, 64)
    intensity = check_range("intensity", intensity, 0, 1e6)
    graph = scene.graph()
    check_render_reads(scene, graph)
    plan = graph.plan(scene.render_reads)
    layout = Layout.for_count(defaults.particles if particles is None else particles,
                              MAX_TEXTURE_SIZE)
    for name, q in plan.quantities.items():
        if q.format_in("rgba8") != "rgba8":
            raise CapabilityError(f"quantity {name!r} is pinned to {q.storage}; the page keeps "
                                  "every quantity in rgba8")
    programs = _Programs()

    start = _Start(plan.quantities, layout)
    scene.initialise(start, SeededRandom(seed))
    quantities = {}
    for name, buffers in plan.buffers.items():
        q = plan.quantities[name]
        entry = {"buffers": buffers}
        if name in start.texels:
            entry["parts"] = _texels(q, layout, start.texels[name])
        else:  # what StateBuffer clears to: one texel a part
            entry["clear"] = np.asarray(zero_texels(q, "rgba8"), np.uint8).tolist()
        quantities[name] = entry

    textures = {}
    for name, data in plan.textures.items():
        if not isinstance(data, np.ndarray):
            raise CapabilityError(f"scene texture {name!r} is ASTC-compressed; WebGL 1 has no "
                                  "ASTC without an extension, and the page does not ask for it")
        h, w = data.shape[:2]
        kind = "bytes" if data.dtype == np.uint8 else "float"
        textures[name] = {"width": w, "height": h, "type": kind,
                          "data": _bytes(data.astype(np.uint8 if kind == "bytes" else np.float32))}

    passes = []
    for spec, part, _ in plan.draws("rgba8"):
        interface = pass_interface(spec, graph.quantities, "rgba8", part)
        stage = spec.stage(part)
        index, source = programs.add(stage, "lib/fullscreen.vert", spec.frag,
                                     draw_defines(spec, rounding),
                                     fragment_prelude=interface.lines,
                                     fragment_epilogue=interface.epilogue)
        check_writes(source, interface, stage)
        uniforms = generated_values(interface, layout)
        uniforms.update({name: uniform_value(name, value, interface.uniforms[name])
                         for name, value in spec.uniforms.items()})
        passes.append({"name": stage, "program": index, "writes": list(interface.writes),
                       "inputs": {s: list(v) for s, v in interface.samplers.items()},
                       "uniforms": {k: _flat(v) for k, v in uniforms.items()}})

    reads = {q: plan.quantities[q] for q in scene.render_reads}
    own = point_uniforms(scene.view, point_size, size)
    interface = stage_interface(tuple(reads), reads, "rgba8", own)
    defines = {"AGE_FADE": None} if "life" in reads else {}
    index, _ = programs.add("the point renderer", "points.vert", "points.frag", defines,
                            vertex_prelude=interface.lines)
    points = {"program": index, "fade": "life" in reads,
              "inputs": {s: list(v) for s, v in interface.samplers.items()},
              "uniforms": {k: _flat(v) for k, v in {**generated_values(interface, layout),
                                                    **own}.items()}}

    background = scene.background()
    mean = layout.count * intensity / (size[0] * size[1])
    post = []
    for spec in post_stages(size, mean, exposure, gradient is not None, bloom,
                            background is not None):
        stage = {"name": spec.name, "size": list(spec.size), "inputs": spec.inputs,
                 "uniforms": {k: _flat(v) for k, v in spec.uniforms.items()}}
        stage["program"], _ = programs.add(f"post stage {spec.name}", "lib/fullscreen.vert",
                                           spec.frag, spec.defines)
        if spec.frag == "post/tonemap.frag":  # the variant that reads a whole count
            stage["program_counts"], _ = programs.add(
                f"post stage {spec.name} (counts)", "lib/fullscreen.vert", spec.frag,
                {**spec.defines, "DENSITY_COUNTS": None})
        post.append(stage)
    fixed = {}
    if gradient is not None:
        fixed["ramp"] = {"width": 256, "height": 1, "type": "bytes", "linear": True,
                         "data": _bytes(np.asarray(load_ramp(gradient), np.uint8))}
    if background is not None:
        h, w = background.shape[:2]
        fixed["background"] = {"width": w, "height": h, "type": "bytes", "linear": True,
                               "data": _bytes(np.asarray(background, np.uint8))}
    add, _ = programs.add("density add", "lib/fullscreen.vert", "density/add.frag")
    present, _ = programs.add("present", "lib/fullscreen.vert", "post/present.frag")

    return {"scene": scene.name, "title": (scene.__doc__ or scene.name).strip().splitlines()[0],
            "layout": {"count": layout.count, "width": layout.width, "height": layout.height},
            "size": list(size), "steps": steps, "seed": seed, "rounding": rounding,
            "intensity": intensity, "quantities": quantities, "textures": textures,
            "passes": passes, "swap": [q for q, n in plan.buffers.items() if n == 2],
            "points": points, "post": post, "fixed": fixed,
            "density": {"paths": list(DENSITY_PATHS), "fade_levels": FADE_LEVELS,
                        "batch": BATCH_POINTS, "add": add},
            "present": present, "programs": programs.sources,
            "controls": [asdict(c) for c in scene.controls()]}


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

