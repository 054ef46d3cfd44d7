"""The liquid drawn as the article's author draws it (his repository's liquid demo): metaballs.
Each particle a white disc into a reduced buffer, blurred, a threshold (the metaball surface:
alpha 0.1), blurred twice more, then shaded at the picture's resolution over a background: a
normal from the surface's alpha gradient, the background refracted along it, Fresnel, a shadow
and a specular highlight (``metaballs/liquid.frag``). The disc's size and the blurs' reach are
the author's, in shares of the reduced buffer (his ``texture_size / 128``); the blurs are his
9-tap kernel, through ``post/blur.frag``.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range
from ..frame.plan import Ref, Rendering, Resource, Stage
from ..gl.bindings import generated_values, stage_interface
from ..gl.device import DrawState
from ..params import Params, param
from .points import point_uniforms, vertex_fetch
from .post import stage

THRESHOLD = 0.1  # the author's: alpha below it is not liquid
DISC = 2.5  # a particle's disc, pixels of a buffer 128 long (the author's particle size)
# The author's blurs: each a horizontal and a vertical pass of his 9-tap Gaussian (sigma 2.5,
# unnormalised: the taps sum to 0.93) at taps `strong` texels apart, in pixels of a buffer 128
# long: one before the threshold, two after.
BLUR_CENTRE = 0.159576912161
BLUR_WEIGHTS = (0.147308056121, 0.115876621105, 0.0776744219933, 0.0443683338718)
BLURS = {"discs": 0.75, "surface 1": 0.35, "surface 2": 0.25}


def author_taps(strong):
    """(centre weight, six (offset, weight) pairs) of the author's 9-tap blur with taps
    ``strong`` texels apart, as ``post/blur.frag`` takes them (the last two pairs weigh 0)."""
    pairs = [(float(k * strong), float(w)) for k, w in enumerate(BLUR_WEIGHTS, 1)]
    return BLUR_CENTRE, pairs + [(0.0, 0.0)] * 2


def liquid_background(size=256):
    """A (size, size, 4) uint8 background to refract: tiles of two greys under a cool vertical
    gradient, so the liquid's bending of it shows."""
    y, x = (np.mgrid[0:size, 0:size] + 0.5) / size
    checks = ((np.floor(x * 8) + np.floor(y * 8)) % 2)[..., None]
    top, bottom = np.array([0.16, 0.2, 0.27]), np.array([0.42, 0.45, 0.5])
    base = bottom + (top - bottom) * y[..., None]  # row 0 is the texture's bottom (not flipped)
    rgb = base * (0.8 + 0.2 * checks)
    grout = ((np.abs((x * 8) % 1 - 0.5) > 0.46) | (np.abs((y * 8) % 1 - 0.5) > 0.46))[..., None]
    rgb = np.where(grout, rgb * 0.7, rgb)
    rgba = np.concatenate([rgb, np.ones((size, size, 1))], -1)
    return (rgba * 255).round().astype(np.uint8)


@dataclass(frozen=True)
class MetaballLook(Params):
    """The metaballs' look, declared by the rendering (a scene drawn by :class:`Metaballs`
    takes these options)."""

    buffer: int = param(512, 64, 4096, integer=True, unit="pixels",
                        help="the reduced buffer's longer side, where the discs are drawn and "
                             "blurred (the author's: 348, 512 or 748)")
    colour: tuple = param((0.1, 0.45, 0.85, 0.45), 0.0, 1.0, count=4, metavar="R,G,B,A",
                          help="the liquid's colour, and how much of it covers the refracted "
                               "background")


@dataclass(frozen=True)
class Metaballs(Rendering):
    """A 2D scene's particles (``position``, 2 components, over the world rectangle ``view``)
    drawn as the author's metaball liquid into an RGBA8 picture: ``buffer`` the reduced
    buffer's longer side, ``colour`` (r, g, b, a) the liquid's."""

    view: tuple = (0.0, 0.0, 1.0, 1.0)
    buffer: int = 512
    colour: tuple = MetaballLook.__dataclass_fields__["colour"].default

    reads = ("position",)
    settings = ("vertex_fetch",)
    kind = "it draws the liquid as metaballs: no point size, tone map or accumulation"

    def __post_init__(self):
        x0, y0, x1, y1 = (float(v) for v in self.view)
        if not (x1 > x0 and y1 > y0):
            raise ParameterError(f"view must have x1 > x0 and y1 > y0, got {self.view}")
        check_range("buffer", self.buffer, 64, 4096, integer=True)
        if len(self.colour) != 4:
            raise ParameterError(f"colour is (r, g, b, a), got {self.colour}")
        for v in self.colour:
            check_range("colour", v, 0.0, 1.0)

    def buffer_size(self, size):
        """The reduced buffer's (w, h) for a picture of ``size``: its longer side ``buffer``,
        the picture's shape (as the author's ``size_reduction``)."""
        w, h = size
        long = int(self.buffer)
        return (long, max(1, round(long * h / w))) if w >= h else (max(1, round(long * w / h)),
                                                                   long)

    def plan(self, b, defaults):
        """The discs, the blurs, the threshold and the shading; returns the picture."""
        layout, size = b.layout, b.size
        fetch = vertex_fetch(b)
        bw, bh = self.buffer_size(size)
        scale = max(bw, bh) / 128  # the author's texture_size / 128
        quantities = {"position": b.graph_plan.quantities["position"]}
        own = point_uniforms(self.view, DISC * scale, (bw, bh))
        interface = stage_interface(("position",), quantities, b.format, own,
                                    attributes=not fetch)
        b.resource(Resource("discs", "target", (bw, bh), "rgba8", linear=True,
                            what="the particles' discs, reduced"))
        b.stage(Stage(
            "discs", "discs", "metaballs/disc.frag", "points.vert", vertex_interface=interface,
            inputs=b.state_inputs(interface), attributes=b.state_attributes(interface),
            target=Ref("discs"), vertices=b.particle_texels() if fetch else None,
            primitive="points", count=layout.count,
            state=DrawState(point_size=True, sprites=True), uniforms=own,
            generated=generated_values(interface, layout), clear=(0.0, 0.0, 0.0, 0.0),
            what=f"{layout.count} discs of {DISC * scale:.3g} pixels in {bw}x{bh}"))

        def blur(source, name):
            centre, pairs = author_taps(BLURS[name] * scale)
            for axis, direction in (("x", (1 / bw, 0.0)), ("y", (0.0, 1 / bh))):
                source = stage(b, f"blur {name} {axis}", "post/blur.frag", (bw, bh),
                               {"u_direction": direction, "u_centre": centre, "u_taps": pairs},
                               {"u_source": Ref(source)},
                               what=f"the author's 9 taps {BLURS[name] * scale:.3g} texels apart")
            return source

        surface = stage(b, "metaball threshold", "metaballs/threshold.frag", (bw, bh),
                        {"u_threshold": THRESHOLD}, {"u_source": Ref(blur("discs", "discs"))},
                        what=f"the surface: alpha >= {THRESHOLD:g}")
        surface = blur(blur(surface, "surface 1"), "surface 2")
        texture = liquid_background()
        b.resource(Resource("liquid background", "image", texture.shape[1::-1], "rgba8",
                            linear=True, data=texture, what="the background the liquid refracts"))
        return stage(b, "liquid", "metaballs/liquid.frag", size,
                     {"u_colour": tuple(float(v) for v in self.colour),
                      "u_texel": (1 / bw, 1 / bh)},
                     {"u_surface": Ref(surface), "u_background": Ref("liquid background")},
                     what="normal from the surface's gradient, refraction, Fresnel, a highlight")
