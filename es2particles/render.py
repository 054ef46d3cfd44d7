"""Drawing particles: one GL point per particle, its position fetched in the vertex shader.

A static buffer of texel coordinates (made once; ES 1.00 has no gl_VertexID) names each
particle's texel; ``points.vert`` fetches and unpacks the position there and ``points.frag`` adds a
constant into the accumulation target with additive blending, so the target holds density. Only
the ``count`` particles are in the buffer: spare texels are never drawn.
"""

import moderngl
import numpy as np

from .errors import CapabilityError, ParameterError, check_range
from .simulation import FORMAT_DEFINES

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


def choose_accumulation(ctx):
    """The first format that can take additive blending, and why it was taken."""
    for fmt in ACCUMULATION_FORMATS:
        if ctx.caps.blendable.get(fmt):
            note = "" if fmt != "rgba8" else " (fallback: no float target can be blended into)"
            return fmt, f"{fmt}{note}"
    raise CapabilityError(f"no format can be blended into on {ctx.caps.renderer}")


class PointRenderer:
    """Renders the particles of a simulation as additive points into a density texture.

    Parameters
    ----------
    ctx : Context
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
    fade_by_life : bool
        Scale each particle by 1 - age/lifetime from the ``life`` quantity; dead ones are not drawn.
    draw_slice : int or None
        Points per draw call, each followed by a flush; None: ``SOFTWARE_DRAW_SLICE`` on a CPU
        rasteriser, the whole count in one call otherwise.

    Points are not sprites: in the compatibility profile that :func:`open_context` asks for first,
    they follow the legacy rules, where a point of size s covers a square of round(s) pixels.
    """

    def __init__(self, ctx, layout, size, view, state_format="rgba8", point_size=1.0,
                 intensity=1.0, fade_by_life=False, draw_slice=None):
        if ctx.caps.max_vertex_texture_units < 1:
            raise CapabilityError("no support for vertex shader textures "
                                  "(GL_MAX_VERTEX_TEXTURE_IMAGE_UNITS is 0): cannot draw particles")
        lo, hi = ctx.caps.point_size_range
        self.point_size = check_range("point_size", point_size, lo, hi)
        self.intensity = check_range("intensity", intensity, 0)
        x0, y0, x1, y1 = (float(v) for v in view)
        if not (x1 > x0 and y1 > y0):
            raise ParameterError(f"view must have x1 > x0 and y1 > y0, got {view}")
        self.ctx, self.layout, self.size = ctx, layout, tuple(size)
        if draw_slice is None:
            draw_slice = SOFTWARE_DRAW_SLICE if ctx.caps.software_rasteriser else layout.count
        self.draw_slice = check_range("draw_slice", draw_slice, 1, integer=True)
        self.format, self.format_note = choose_accumulation(ctx)
        # An 8-bit target saturates at 1: count in steps of 1/255 there, and say so in `scale`.
        self.scale = 1.0 if self.format != "rgba8" else 1.0 / 255.0
        defines = dict(FORMAT_DEFINES[state_format])
        if fade_by_life:
            defines["AGE_FADE"] = None
        self.fade_by_life = fade_by_life
        self.program = ctx.program("points.vert", "points.frag", defines)
        self.texels = ctx.buffer(layout.texel_uv().tobytes())
        self.vao = ctx.vertex_array(self.program, [(self.texels, "2f", "a_texel")])
        self.target = ctx.texture(self.size, self.format, filter_nearest=False)
        self.framebuffer = ctx.framebuffer(self.target)
        self.program["u_position"].value = 0
        if fade_by_life:
            self.program["u_life"].value = 1
        self.program["u_view"].value = (x0, y0, x1 - x0, y1 - y0)
        self.program["u_point_size"].value = self.point_size
        self.program["u_colour"].value = (self.intensity * self.scale,) * 4
        # Float state formats do not decode through the range: the driver drops the uniform.
        self._position_range = self.program.get("u_position_range", None)
        self._life_range = self.program.get("u_life_range", None) if fade_by_life else None
        self._ranges_for = None  # the quantities whose ranges the uniforms hold

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
        self.texels.write(self.layout.texel_uv()[order].tobytes())

    def draw(self, position, life=None):
        """Clear the target and draw every particle; ``position``/``life`` are StateBuffers."""
        mgl = self.ctx.mgl
        self.framebuffer.use()
        self.framebuffer.clear(0.0, 0.0, 0.0, 0.0)
        mgl.enable(moderngl.BLEND | moderngl.PROGRAM_POINT_SIZE)
        mgl.blend_func = moderngl.ONE, moderngl.ONE
        position.front.use(0)
        if self.fade_by_life:
            life.front.use(1)
        quantities = (position.quantity, life.quantity if self.fade_by_life else None)
        if quantities != self._ranges_for:  # set once, not every frame
            for handle, quantity in zip((self._position_range, self._life_range), quantities):
                if handle is not None and quantity is not None:
                    handle.value = tuple(quantity.range_vec4)
            self._ranges_for = quantities
        count, step = self.layout.count, self.draw_slice
        for first in range(0, count, step):
            self.vao.render(moderngl.POINTS, vertices=min(step, count - first), first=first)
            if step < count:
                self.ctx.flush()
        mgl.disable(moderngl.BLEND)
        return self.target

    def release(self):
        self.ctx.free(self.vao, self.texels, self.framebuffer, self.target)
        self.vao = self.texels = self.framebuffer = self.target = None
