"""Post passes that turn a density texture into the final image: tone map with a gradient map,
then bloom. Each is optional: a switched-off pass makes no texture and never runs.

- Tone map (+ gradient map): log curve of density, then a colour ramp (``ramps.py``) or grey.
- Bloom: bright pass at half resolution, separable Gaussian blur at 1/2 and 1/4 resolution,
  composite onto the image.
"""

from dataclasses import dataclass

import numpy as np

from .command import FullscreenCommand
from .context import read_rgb
from .errors import check_range
from .graph import format_bytes
from .ramps import load_ramp


@dataclass(frozen=True)
class Bloom:
    """Bloom settings: luminance threshold in [0, 1], blur radius (sigma in [0.5, 4] texels of the
    half-resolution level; the quarter level doubles it), and how much glow is added."""

    # 0.2: the article's glow shows (21% of the de Jong still's pixels change, 0.6% saturate);
    # at 0.6, above 99.9% of the pixels, bloom changed 0.04% and the glow was invisible.
    threshold: float = 0.2
    radius: float = 3.0
    intensity: float = 0.8

    def __post_init__(self):
        check_range("bloom threshold", self.threshold, 0, 1)
        check_range("bloom radius", self.radius, 0.5, 4)  # 12 taps in blur.frag cover 3 sigma
        check_range("bloom intensity", self.intensity, 0, 10)


def blur_taps(sigma, taps=12):
    """(centre weight, [(offset, weight)] * taps/2) of a normalised Gaussian of ``taps`` texels
    each side, with neighbouring taps paired into one linearly filtered fetch (numpy twin of
    what ``post/blur.frag`` sums)."""
    x = np.arange(taps + 1, dtype=np.float64)
    w = np.exp(-0.5 * x ** 2 / sigma ** 2)
    w /= w[0] + 2 * w[1:].sum()
    pairs = []
    for i in range(1, taps + 1, 2):
        weight = w[i] + w[i + 1]
        pairs.append(((i * w[i] + (i + 1) * w[i + 1]) / weight, weight))
    return float(w[0]), pairs


class _Stage:
    """One full-screen post pass: its command and the texture it renders into (``output``)."""

    def __init__(self, group, frag, size, name, defines=None, fmt="rgba8"):
        self.command = FullscreenCommand(group, frag, f"post stage {name}", defines)
        self.output = group.texture(size, fmt, filter_nearest=False)
        self.framebuffer = group.framebuffer(self.output)

    def set(self, **uniforms):
        self.command.set_many(uniforms)

    def run(self, **textures):
        """Draw with ``textures`` bound by sampler name; returns the output texture."""
        self.command.draw(self.framebuffer, textures)
        return self.output


class PostChain:
    """Tone map (with optional gradient map) and optional bloom, at ``size`` pixels.

    Parameters
    ----------
    ctx : Context
    size : (int, int)
    mean_density : float
        The density of an evenly covered pixel, which the tone curve is relative to.
    exposure : float
        Brightness of the tone curve (> 0).
    gradient : str or None
        Ramp spec for the gradient map (see ``ramps.load_ramp``); None for grey.
    bloom : Bloom or None
    background : (h, w, 4) uint8 array, optional
        An image drawn under the particles (a scene's objects), stretched over the frame.
    """

    def __init__(self, ctx, size, mean_density, exposure=1.0, gradient="inferno", bloom=Bloom(),
                 background=None):
        self.ctx, self.size = ctx, tuple(size)
        ctx.make_current()
        exposure = check_range("exposure", exposure, 1e-3, 1e3)
        self.gradient, self.bloom = gradient, bloom
        ramp = load_ramp(gradient) if gradient is not None else None  # bad ramps fail before GL
        self.group = ctx.group()
        self.stages = []
        self.inputs = {}  # fixed textures of the tone map, by sampler name
        try:
            defines = {}
            if ramp is not None:
                self.inputs["u_ramp"] = self.group.texture((256, 1), "rgba8", data=ramp.tobytes(),
                                                           filter_nearest=False)
                defines["GRADIENT"] = None
            if background is not None:
                h, w = background.shape[:2]
                self.inputs["u_background"] = self.group.texture(
                    (w, h), "rgba8", data=np.ascontiguousarray(background, np.uint8).tobytes(),
                    filter_nearest=False)
                defines["BACKGROUND"] = None
            self.tonemap = self._stage("post/tonemap.frag", self.size, "tone map", defines)
            self.tonemap.set(u_mean=float(max(mean_density, 1e-12)), u_exposure=exposure)
            if bloom is not None:
                self._make_bloom(bloom)
        except Exception:
            self.release()
            raise

    def _stage(self, frag, size, name, defines=None):
        stage = _Stage(self.group, frag, size, name, defines)
        self.stages.append(stage)
        return stage

    def _make_bloom(self, bloom):
        w, h = self.size
        self.levels = []
        for div in (2, 4):
            size = (max(1, w // div), max(1, h // div))
            bright = self._stage("post/bright.frag", size, f"bloom bright 1/{div}")
            bright.set(u_threshold=bloom.threshold)
            blur_x = self._stage("post/blur.frag", size, f"bloom blur x 1/{div}")
            blur_y = self._stage("post/blur.frag", size, f"bloom blur y 1/{div}")
            # Sigma is in texels of each level, so the quarter level glows twice as wide.
            centre, pairs = blur_taps(bloom.radius)
            blur_x.set(u_direction=(1 / size[0], 0.0), u_centre=centre, u_taps=pairs)
            blur_y.set(u_direction=(0.0, 1 / size[1]), u_centre=centre, u_taps=pairs)
            self.levels.append((bright, blur_x, blur_y))
        self.composite = self._stage("post/composite.frag", self.size, "bloom composite")
        self.composite.set(u_intensity=bloom.intensity / 2)

    def describe(self):
        """Lines for the printed plan: what runs, with its textures."""
        w, h = self.size
        ramp = f"gradient map '{self.gradient}'" if self.gradient is not None else "grey (no gradient map)"
        under = " over the scene's objects" if "u_background" in self.inputs else ""
        lines = [f"tone map (log) + {ramp}{under} -> colour rgba8 {w}x{h} ({format_bytes(4 * w * h)})"]
        if self.bloom is not None:
            b = self.bloom
            level_bytes = sum(3 * 4 * max(1, w // d) * max(1, h // d) for d in (2, 4))
            lines.append(f"bloom: bright pass (threshold {b.threshold:g}) + blur x/y at "
                         f"{w // 2}x{h // 2} and {w // 4}x{h // 4} (sigma {b.radius:g}), "
                         f"composite (intensity {b.intensity:g}); rgba8 targets "
                         f"{format_bytes(level_bytes + 4 * w * h)}")
        return lines

    def left_out(self):
        out = []
        if self.gradient is None:
            out.append("gradient map (switched off)")
        if self.bloom is None:
            out.append("bloom (switched off)")
        return out

    def apply(self, density):
        """Run the chain on the density texture; returns the final RGBA8 texture."""
        self.ctx.make_current()
        image = self.tonemap.run(u_density=density, **self.inputs)
        if self.bloom is None:
            return image
        blurred = []
        for bright, blur_x, blur_y in self.levels:
            half = bright.run(u_source=image)
            blurred.append(blur_y.run(u_source=blur_x.run(u_source=half)))
        return self.composite.run(u_source=image, u_bloom0=blurred[0], u_bloom1=blurred[1])

    def read(self, texture):
        """An RGBA8 texture as an (h, w, 3) uint8 image, top row first."""
        self.ctx.make_current()
        return read_rgb(texture)

    def release(self):
        self.group.release()
        self.stages, self.inputs = [], {}
