"""Trails over an animation's frames (``--trails``), after whatever the rendering presents.

The fade (``fade:OPACITY``, webgl-wind's): each frame the brighter of the new picture and the
last frame's times OPACITY, less 0.6 of a code, kept in a pair of targets
(``post/trails.frag``).

Ribbons (``ribbons:K``): each particle's positions of the last K frames, kept in a history and
drawn as a strip, fading with age (Niagara's and VFX Graph's ribbons, in ES 2.0 passes).

The history is a float target of K bands, each the particle texture's size (W x H K): band k
holds every particle's position in rgb, and in alpha its age plus one where the scene has a
``life`` (0 where it was unborn or dead: no ribbon there), else 1. Each frame one band is
written (``ribbons/history.frag``: the band of this frame, the rest copied from the last
frame's pair), the bands taken in turn (a stage's repeat of K uniform sets, one drawn a frame).
The strip (``ribbons/ribbon.vert``): K - 1 segments a particle, four corners each, through an
index buffer; each corner fetches both ends of its segment from their bands (the newest band
first: a repeat in step with the history's), is pushed across the segment's screen direction by
half the width in pixels (camera-facing, as wide at any distance), and fades from 1 at the
newest position to 0 at the oldest. A segment is left out (its corners put outside the clip
volume) where either end is empty or behind the camera, or where the particle was born again
between its ends (the newer age is the smaller).
Ribbons glow (additive) over the picture, without a depth test.
"""

from functools import partial

import numpy as np

from ..errors import CapabilityError, ParameterError
from ..gl.bindings import generated_values, stage_interface
from ..gl.device import DrawState
from .parts import Ref, Resource, Stage, Vertices

WIDTH = 1.5  # pixels
COLOUR = (0.45, 0.32, 0.18)  # added over a 3D picture
# Added over a 2D density picture, whose particles follow each other along the flow: fainter.
COLOUR_2D = (0.09, 0.064, 0.036)
HISTORY_FORMATS = ("rgba32f", "rgba16f")


def plan_trails(b, present, kind, value, rendering):
    """Add the trails of ``kind`` ("fade", of opacity ``value``, or "ribbons", of ``value``
    positions) over the presented resource ``present`` of ``rendering`` to plan builder ``b``.
    Returns the new presented resource."""
    if kind == "fade":
        return plan_fade(b, present, value)
    return plan_ribbons(b, present, value, None if rendering.has_camera
                        else getattr(rendering, "view", None))


def plan_fade(b, present, opacity):
    """Screen-space trails over the presented picture: a pair of targets kept from frame to
    frame, each frame the brighter of the new picture and the last frame's times ``opacity``
    less 0.6 of a code (``post/trails.frag``). Returns the new presented resource."""
    w, h = b.resources[present].size
    b.resource(Resource("trails", "target", (w, h), "rgba8", buffers=2, swap="draw",
                        linear=True, what="the picture with the frames before it fading"))
    b.stage(Stage("trails", "post", "post/trails.frag",
                  inputs={"u_picture": Ref(present), "u_trail": Ref("trails")},
                  target=Ref("trails"), uniforms={"u_keep": float(opacity)},
                  what=f"the brighter of the picture and the last frame's times {opacity:g}"))
    return "trails"


def ribbon_vertices(count, width, height, k):
    """(count (K - 1) 4, 4) float32: for each particle's segment between ranks j and j + 1 (0
    newest), four corners: the particle's texel centre, the segment j, and the corner's end (0:
    rank j, 1: rank j + 1) and side (-1, 1); particle by particle, segment by segment."""
    x, y = np.arange(count) % width, np.arange(count) // width
    texel = np.stack([(x + 0.5) / width, (y + 0.5) / height], axis=1)
    out = np.empty((count, k - 1, 4, 4), np.float32)
    out[..., :2] = texel[:, None, None, :]
    out[..., 2] = np.arange(k - 1)[None, :, None]
    out[..., 3] = np.arange(4)  # end 0: sides -1 (0), 1 (1); end 1: -1 (2), 1 (3)
    return out.reshape(-1, 4)


def ribbon_indices(count, k):
    """Two triangles a segment, over its four corners."""
    base = np.arange(count * (k - 1)) * 4
    return (base[:, None] + np.array([0, 1, 2, 2, 1, 3])).astype(np.uint32).ravel()


def plan_ribbons(b, present, k, view=None):
    """Add the ribbons' history and strips to plan builder ``b``, drawn over the presented
    resource ``present`` (which stays the presented one). ``view``: a 2D scene's world
    rectangle (x0, y0, x1, y1); None: the 3D camera's view-projection. (A reseeded scene's
    particles make no path: check_settings refuses its ribbons.)"""
    layout, caps = b.layout, b.caps
    quantities = b.graph_plan.quantities if b.graph_plan is not None else {}
    if "position" not in quantities or layout.count == 0:
        raise ParameterError("--trails ribbons:K: this frame has no particle positions to "
                             "keep; use --trails fade:OPACITY")
    w, h = layout.size
    if h * k > caps.max_texture_size:
        raise ParameterError(f"--trails ribbons:{k}: the history is {k} bands of the particle "
                             f"texture's {h} rows, {h * k} in all, beyond this context's "
                             f"{caps.max_texture_size}; lower K to at most "
                             f"{caps.max_texture_size // h}, or the particle count")
    fmt = next((f for f in HISTORY_FORMATS if caps.renderable.get(f)), None)
    if fmt is None:
        raise CapabilityError("--trails ribbons:K keeps positions in a float target, which "
                              f"{caps.renderer} cannot render to; use --trails fade:OPACITY")
    if caps.max_vertex_texture_units < 1:
        raise CapabilityError("--trails ribbons:K: the strips fetch their positions in the "
                              "vertex shader; this context has no vertex texture units")
    position = quantities["position"]
    reads = ("position", "life") if "life" in quantities else ("position",)
    interface = stage_interface(reads, {q: quantities[q] for q in reads}, b.format,
                                {"u_bands": float(k)})
    defines = {"COMPONENTS": position.components}
    if "life" in reads:
        defines["LIFE"] = None
    b.resource(Resource("ribbon history", "target", (w, h * k), fmt, buffers=2, swap="draw",
                        what=f"each particle's positions of the last {k} frames, a band a "
                             "frame"))
    b.stage(Stage("ribbon history", "ribbons", "ribbons/history.frag", defines=defines,
                  interface=interface,
                  inputs={**b.state_inputs(interface), "u_history": Ref("ribbon history")},
                  target=Ref("ribbon history"), generated=generated_values(interface, layout),
                  uniforms={"u_bands": float(k)},
                  repeat=tuple({"u_band": float(j)} for j in range(k)), per_frame=1,
                  what=f"this frame's positions into band (frame mod {k}), the rest kept"))
    b.vertex_data(Vertices("ribbons", "data", 4 * (k - 1) * layout.count,
                           data=partial(ribbon_vertices, layout.count, w, h, k),
                           indices=partial(ribbon_indices, layout.count, k),
                           index_count=6 * (k - 1) * layout.count,
                           attributes=(("a_texel", 2), ("a_segment", 1), ("a_corner", 1))))
    size = b.size
    uniforms = {"u_bands": float(k), "u_half_width": (WIDTH / size[0], WIDTH / size[1]),
                "u_colour": COLOUR if view is None else COLOUR_2D}
    frame, draw_defines = {}, {}
    if view is None:
        frame["u_view_projection"] = ("view_projection",)
    else:
        x0, y0, x1, y1 = (float(v) for v in view)
        uniforms["u_view"] = (x0, y0, x1 - x0, y1 - y0)
        draw_defines["VIEW_2D"] = None
    b.stage(Stage("ribbons", "ribbons", "ribbons/ribbon.frag", "ribbons/ribbon.vert",
                  defines=draw_defines, inputs={"u_history": Ref("ribbon history")},
                  target=Ref(present), vertices="ribbons", primitive="triangles",
                  count=6 * (k - 1) * layout.count, state=DrawState(blend="add"),
                  uniforms=uniforms, frame_uniforms=frame,
                  repeat=tuple({"u_newest": float(j)} for j in range(k)), per_frame=1,
                  what=f"{layout.count} strips of {k} positions, {WIDTH:g} pixels wide, "
                       "fading with age, added"))
    return present
