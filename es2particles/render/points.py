"""Drawing particles: one GL point per particle, its position fetched in the vertex shader.

A static buffer of texel coordinates (made once; ES 1.00 has no gl_VertexID) names each
particle's texel; ``points.vert`` fetches and unpacks the position there and ``points.frag`` adds a
constant into the accumulation target with additive blending, so the target holds density. Only
the ``count`` particles are in the buffer: spare texels are never drawn.
"""

import moderngl
import numpy as np

from ..gl.bindings import compile_checked, generated_values, stage_interface
from ..gl.context import ProgramValues, bytes_per_texel
from ..errors import CapabilityError, ParameterError, check_range
from ..frame.graph import format_bytes
from ..gl.shaders import expand

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


def choose_accumulation(ctx):
    """The first format that can take additive blending, and why it was taken."""
    for fmt in ACCUMULATION_FORMATS:
        if ctx.caps.blendable.get(fmt):
            note = "" if fmt != "rgba8" else " (fallback: no float target can be blended into)"
            return fmt, f"{fmt}{note}"
    raise CapabilityError(f"no format can be blended into on {ctx.caps.renderer}")


class ParticleStage:
    """The program of a renderer that draws one point per particle, its vertex shader reading
    quantities at the particle's texel: the generated interface (``bindings.stage_interface``),
    the checked compile, the renderer's uniform values (kept per user: the context's cache may
    share the program), sampler units by name, and the buffer of texel coordinates that names
    each particle (ES 1.00 has no gl_VertexID) with its vertex array. Shared by the density
    points, the 3D sprites and the shadow map's pass."""

    def __init__(self, group, vertex, fragment, stage, quantities, state_format, layout, uniforms,
                 defines=None, texels=None):
        ctx = group.ctx
        self.interface = stage_interface(tuple(quantities), quantities, state_format, uniforms)
        self.program = compile_checked(
            lambda: ctx.program(vertex, fragment, defines, vertex_prelude=self.interface.lines),
            expand(vertex, defines, self.interface.lines), self.interface, f"{stage} ({vertex})")
        self.state = ProgramValues(ctx, self.program)
        self.units = {name: unit for unit, name in enumerate(self.interface.samplers)}
        self.set_many({**self.units, **generated_values(self.interface, layout), **uniforms})
        # Each vertex's texel: the particle's own, or (``texels``) a slot of an order texture.
        texels = layout.texel_uv() if texels is None else np.asarray(texels, np.float32)
        self.texels = group.buffer(texels.tobytes())
        self.vao = group.vertex_array(self.program, [(self.texels, "2f", "a_texel")])

    def set_many(self, values):
        """Set uniforms the program uses (others, dropped by the driver, are skipped)."""
        for name, value in values.items():
            if name in self.program:
                self.state.set(name, value)

    def bind(self, buffers):
        """Bind each read quantity's front textures (``buffers``: name -> StateBuffer) and make
        the program hold this renderer's values."""
        for name, (_, q, part, _) in self.interface.samplers.items():
            buffers[q].fronts[part].use(self.units[name])
        self.state.current()


class PointRenderer:
    """Renders the particles of a simulation as additive points into a density texture.

    Parameters
    ----------
    ctx : Context
    quantities : mapping
        The quantities the renderer reads (name -> Quantity): ``position`` (2 components), and
        ``life`` (age, lifetime) to fade each particle by 1 - age/lifetime and skip unborn and
        dead ones. These are the render stage's reads in the frame's plan.
    layout : Layout
        Where the particles sit in the state textures.
    size : (int, int)
        Width and height of the density target in pixels.
    view : (x0, y0, x1, y1)
        The world rectangle that fills the target.
    state_format : str
        The simulation's storage format (the vertex shader decodes it).
    point_size : float
        Point diameter in pixels, within the context's point size range.
    intensity : float
        What one particle adds to its pixel (density units).
    draw_slice : int or None
        Points per draw call, each followed by a flush; None: ``SOFTWARE_DRAW_SLICE`` on a CPU
        rasteriser, the whole count in one call otherwise.

    Points are not sprites: in the compatibility profile that :func:`open_context` asks for first,
    they follow the legacy rules, where a point of size s covers a square of round(s) pixels.
    """

    READS = ("position", "life")  # what it can read; position is required

    def __init__(self, ctx, quantities, layout, size, view, state_format="rgba8", point_size=1.0,
                 intensity=1.0, draw_slice=None):
        if ctx.caps.max_vertex_texture_units < 1:
            raise CapabilityError("no support for vertex shader textures "
                                  "(GL_MAX_VERTEX_TEXTURE_IMAGE_UNITS is 0): cannot draw particles")
        unknown = [q for q in quantities if q not in self.READS]
        if "position" not in quantities or unknown:
            raise ParameterError(f"the point renderer reads position and optionally life, got "
                                 f"{list(quantities)}")
        ctx.make_current()
        lo, hi = ctx.caps.point_size_range
        self.point_size = check_range("point_size", point_size, lo, hi)
        # Above ~1e6 per particle the tone curve maps every lit pixel to its top: a one-colour
        # image with exit 0 (--intensity 1e39 did that).
        self.intensity = check_range("intensity", intensity, 0, 1e6)
        x0, y0, x1, y1 = (float(v) for v in view)
        if not (x1 > x0 and y1 > y0):
            raise ParameterError(f"view must have x1 > x0 and y1 > y0, got {view}")
        self.ctx, self.layout, self.size = ctx, layout, tuple(size)
        self.reads = tuple(quantities)
        if draw_slice is None:
            draw_slice = SOFTWARE_DRAW_SLICE if ctx.caps.software_rasteriser else layout.count
        self.draw_slice = check_range("draw_slice", draw_slice, 1, integer=True)
        self.format, self.format_note = choose_accumulation(ctx)
        # An 8-bit target saturates at 1: count in steps of 1/255 there, and say so in `scale`.
        self.scale = 1.0 if self.format != "rgba8" else 1.0 / 255.0
        defines = {}
        if "life" in quantities:
            defines["AGE_FADE"] = None
        uniforms = point_uniforms(view, self.point_size, self.size)
        self.group = ctx.group()
        try:
            self.stage = ParticleStage(self.group, "points.vert", "points.frag",
                                       "the point renderer", quantities, state_format, layout,
                                       uniforms, defines)
            self.stage.set_many({"u_colour": (self.intensity * self.scale,) * 4})
            self.density = self.group.texture(self.size, self.format, filter_nearest=False)
            self.framebuffer = self.group.framebuffer(self.density)
        except Exception:
            self.group.release()
            raise

    def describe(self):
        w, h = self.size
        return (f"render: {self.layout.count} points, vertex texture fetch of "
                f"{' and '.join(self.reads)}, additive blend -> density {self.format_note} "
                f"{w}x{h} ({format_bytes(w * h * bytes_per_texel(self.format))})")

    @property
    def mean_density(self):
        """Density of a pixel if the particles were spread evenly (target units)."""
        return self.layout.count * self.intensity * self.scale / (self.size[0] * self.size[1])

    def order_by_tiles(self, positions, view, tile=64):
        """Reorder the draw so particles come tile by tile (``tile`` pixels square), from their
        world ``positions`` (count, 2). Rasterising points in framebuffer order cuts the draw on
        llvmpipe by ~10% (2^20 reseeded de Jong points in slices: 68 -> 61 ms; before the draw
        was sliced, 190 -> 120-150 ms). It pays where positions repeat from frame to frame, as in
        reseeded de Jong, and is done once, outside the per-frame loop. (Before each still of a
        chaotic stateful run, the readback and sort cost more than they save.)"""
        x0, y0, x1, y1 = view
        w, h = self.size
        px = np.clip(((positions[:, 0] - x0) / (x1 - x0) * w).astype(np.int64), 0, w - 1)
        py = np.clip(((positions[:, 1] - y0) / (y1 - y0) * h).astype(np.int64), 0, h - 1)
        key = ((py // tile) * (-(-w // tile)) + px // tile).astype(np.uint16)
        order = np.argsort(key, kind="stable")  # radix sort on 16-bit keys: ~8 ms at 2^20
        self.stage.texels.write(self.layout.texel_uv()[order].tobytes())

    def draw(self, buffers, clear=True):
        """Draw every particle into the density target, cleared first unless ``clear`` is False
        (accumulation: the densities of several steps add up); ``buffers`` maps each read
        quantity to its StateBuffer."""
        self.ctx.make_current()
        self.stage.bind(buffers)
        with self.ctx.scope(self.framebuffer, blend="add", point_size=True):
            if clear:
                self.framebuffer.clear(0.0, 0.0, 0.0, 0.0)
            count, step = self.layout.count, self.draw_slice
            for first in range(0, count, step):
                self.stage.vao.render(moderngl.POINTS, vertices=min(step, count - first), first=first)
                if step < count:
                    self.ctx.flush()
        return self.density

    def release(self):
        self.group.release()
