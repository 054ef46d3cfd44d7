"""2D particles as density: one GL point per particle, its position fetched in the vertex shader,
declared by a scene as :class:`Density` and planned as the points stage and the post chain.

A static buffer of texel coordinates (made once; ES 1.00 has no gl_VertexID) names each
particle's texel; ``points.vert`` fetches and unpacks the position there and ``points.frag`` adds a
constant into the density target with additive blending, so the target holds density. Only the
``count`` particles are in the buffer: spare texels are never drawn.
"""

from dataclasses import dataclass

from ..errors import CapabilityError, ParameterError, check_range
from ..frame.graph import format_bytes
from ..frame.plan import Ref, Rendering, Resource, Stage
from ..frame.settings import Bloom, setting
from ..gl.bindings import generated_values, stage_interface
from ..gl.device import DrawState

# Accumulation formats in order of preference: float ones do not saturate, and one channel is a
# quarter of the bytes to blend (r32f: 185 -> 156 ms for 2^20 points on llvmpipe).
ACCUMULATION_FORMATS = ("r32f", "rgba32f", "rgba16f", "rgba8")

# Points per slice of the draw on a CPU rasteriser. llvmpipe bins a whole draw into per-tile
# command lists before any rasterising, and the commands of 2^20 points (tens of MB) overflow
# every cache: rasterising them was mostly waiting on memory (perf: a third of the draw's samples on
# the first load of each point's command). Slices of 2^14 points, each followed by a flush, keep a
# slice's commands in cache and let the rasteriser threads work on one slice while the next is
# binned: 2^20 stateful de Jong points 177 -> 90 ms (2^13 to 2^15 are alike; larger slices lose
# the cache, smaller ones pay more thread wake-ups). The picture is bit-identical. On a GPU the
# draw is one call.
SOFTWARE_DRAW_SLICE = 2 ** 14


def point_uniforms(view, point_size, size):
    """The point renderer's own uniforms: the world rectangle ``view`` (x0, y0, x1, y1) as origin
    and size, the point size, and the target's size in pixels (``points.vert`` snaps each point
    to the pixel grid with it)."""
    x0, y0, x1, y1 = (float(v) for v in view)
    return {"u_view": (x0, y0, x1 - x0, y1 - y0), "u_point_size": float(point_size),
            "u_target_size": (float(size[0]), float(size[1]))}


def choose_accumulation(caps, channels=1):
    """The first format of at least ``channels`` channels a context of ``caps`` can blend into
    additively, and why it was taken."""
    for fmt in ACCUMULATION_FORMATS[channels > 1:]:
        if caps.blendable.get(fmt):
            note = "" if fmt != "rgba8" else " (fallback: no float target can be blended into)"
            return fmt, f"{fmt}{note}"
    raise CapabilityError(f"no format can be blended into on {caps.renderer}")


def vertex_fetch(b):
    """Whether the particles' vertex shader reads the state by vertex texture fetch, from the
    ``vertex_fetch`` setting of plan builder ``b`` (auto: where the context has vertex texture
    units); ``on`` without them is refused in one line."""
    fetch = setting("vertex_fetch", b.setting("vertex_fetch"))
    units = b.caps.max_vertex_texture_units
    if fetch == "on" and units < 1:
        raise CapabilityError("--vertex-fetch on: this context has no vertex texture units "
                              "(GL_MAX_VERTEX_TEXTURE_IMAGE_UNITS is 0); use off (or auto)")
    return fetch == "on" or (fetch == "auto" and units >= 1)


@dataclass(frozen=True)
class Density(Rendering):
    """A 2D scene's rendering: every particle one additive point of the run's point size
    (pixels) and intensity into a density target over the world rectangle ``view`` (x0, y0, x1,
    y1), then the tone map with the gradient map over the ``background`` image of the scene's
    objects, if any (and bloom, on by default here, as over any rendering's picture). ``reads``: ``position`` (2 components), and ``life``
    (age, lifetime) to fade each particle by 1 - age/lifetime and skip unborn and dead ones.
    ``hue``: (quantity, top): each point also adds its quantity's magnitude over [0, top] into a
    second channel, and the tone map colours a pixel by its points' mean of it along the gradient
    map (their speed, say), its brightness still the density's; None: the density picks the
    colour.
    ``draw_slice``: points per draw call, each followed by a flush; None:
    ``SOFTWARE_DRAW_SLICE`` on a CPU rasteriser, the whole count in one call otherwise.

    Points are not sprites: in the compatibility profile that :func:`open_context` asks for first,
    they follow the legacy rules, where a point of size s covers a square of round(s) pixels.
    """

    view: tuple = (-1.0, -1.0, 1.0, 1.0)
    reads: tuple = ("position",)
    background: object = None
    draw_slice: int = None
    hue: tuple = None

    settings = ("point_size", "intensity", "exposure", "accumulate", "vertex_fetch")
    own_gradient = True  # the tone map colours the density along it
    default_bloom = bloom_parts = Bloom()
    has_camera = False
    kind = "it draws 2D density points"

    def __post_init__(self):
        hue = ()
        if self.hue is not None:
            try:
                name, top = self.hue
                check_range("hue top", top, 1e-30)
            except (TypeError, ValueError):
                raise ParameterError(f"hue must be (quantity, top), got {self.hue!r}") from None
            if not (isinstance(name, str) and name.isidentifier()):
                raise ParameterError(f"hue must name a quantity, got {name!r}")
            hue = (name,)
        unknown = [q for q in self.reads if q not in ("position", "life")]
        if "position" not in self.reads or unknown:
            raise ParameterError(f"the point renderer reads position and optionally life, got "
                                 f"{list(self.reads)}")
        object.__setattr__(self, "reads", tuple(self.reads) + hue)
        x0, y0, x1, y1 = (float(v) for v in self.view)
        if not (x1 > x0 and y1 > y0):
            raise ParameterError(f"view must have x1 > x0 and y1 > y0, got {self.view}")
        if self.draw_slice is not None:
            check_range("draw_slice", self.draw_slice, 1, integer=True)

    def plan(self, b, defaults):
        """Add the points stage (accumulated over the run's samples) and the tone map to plan
        builder ``b``; returns the tone map's picture."""
        from .post import plan_post

        caps, layout, size = b.caps, b.layout, b.size
        fetch = vertex_fetch(b)
        lo, hi = caps.drawn_point_size_range
        point_size = check_range("point_size", setting(
            "point_size", b.setting("point_size")), lo, hi)
        intensity = setting("intensity", b.setting("intensity"))
        b.accumulate = setting("accumulate", b.setting("accumulate"))
        fmt, note = choose_accumulation(caps, 2 if self.hue else 1)
        # An 8-bit target saturates at 1: count in steps of 1/255 there.
        scale = 1.0 if fmt != "rgba8" else 1.0 / 255.0
        quantities = {q: b.graph_plan.quantities[q] for q in self.reads}
        own = point_uniforms(self.view, point_size, size)
        defines = {"AGE_FADE": None} if "life" in quantities else {}
        if self.hue:
            own["u_hue_top"] = float(self.hue[1])
            defines.update(HUE=None, HUE_READ=f"read_{self.hue[0]}")
        interface = stage_interface(tuple(quantities), quantities, b.format, own,
                                    attributes=not fetch)
        draw_slice = self.draw_slice
        if draw_slice is None:
            draw_slice = SOFTWARE_DRAW_SLICE if caps.software_rasteriser else None
        w, h = size
        b.resource(Resource("density", "target", size, fmt, linear=True,
                            what=f"additive points, {note}"))
        if fetch:
            how = f"vertex texture fetch of {' and '.join(quantities)}"
        else:
            texels = sum(q.parts(b.format) for q in quantities.values())
            per = 4 if b.format == "rgba8" else 16
            how = (f"no vertex texture fetch: {' and '.join(quantities)} read back each frame "
                   f"and uploaded as vertex attributes ({texels} texture read"
                   f"{'s' * (texels > 1)}, {format_bytes(texels * per * layout.count)} a frame)")
        b.stage(Stage(
            "points", "points", "points.frag", "points.vert", defines, vertex_interface=interface,
            inputs=b.state_inputs(interface), attributes=b.state_attributes(interface),
            target=Ref("density"),
            vertices=b.particle_texels() if fetch else None,
            primitive="points", count=layout.count,
            state=DrawState(blend="add", point_size=True),
            uniforms={**own, "u_colour": (intensity * scale,) * 4},
            generated=generated_values(interface, layout), clear=(0.0, 0.0, 0.0, 0.0),
            slice=draw_slice, samples=b.accumulate,
            what=f"{layout.count} points of {point_size:g} pixel{'s' * (point_size != 1)}, "
                 f"{how}" + (f"; each adds |{self.hue[0]}| / {self.hue[1]:g} in a second "
                             "channel: the colour" if self.hue else "")))
        # The tone map's reference: the density of an even spread at unit intensity, so that
        # --intensity brightens (relative to the density's own mean it cancelled out).
        mean = layout.count * scale / (w * h) * b.accumulate
        return plan_post(b, "density", mean, b.setting("exposure"), b.setting("gradient"),
                         self.background, hue=self.hue[0] if self.hue else None)
