"""Post passes that turn a density texture into the final image: tone map with a gradient map,
then bloom. Each is optional: a switched-off pass makes no texture and never runs.

- Tone map (+ gradient map): log curve of density, then a colour ramp (``ramps.py``) or grey.
- Bloom: bright pass at half resolution, separable Gaussian blur at 1/2 and 1/4 resolution,
  composite onto the image.
"""

from dataclasses import dataclass, field

import numpy as np

from ..gl.command import FullscreenCommand
from ..gl.context import read_rgb
from ..errors import check_range
from ..frame.graph import format_bytes
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
        pairs.append((float((i * w[i] + (i + 1) * w[i + 1]) / weight), float(weight)))
    return float(w[0]), pairs


@dataclass(frozen=True)
class PostStage:
    """One full-screen post pass as data: its shader and defines, target size, own uniforms, and
    where each sampler's texture comes from: ``density`` (the renderer's target), ``ramp`` or
    ``background`` (the chain's fixed textures) or an earlier stage's name. ``PostChain`` draws
    these on EGL; ``export.py`` writes the same list into a WebGL page."""

    name: str
    frag: str
    size: tuple
    uniforms: dict
    inputs: dict
    defines: dict = field(default_factory=dict)


def post_stages(size, mean_density, exposure, gradient=True, bloom=None, background=False):
    """The post chain's stages in drawing order (the last one's output is the image):
    tone map, with the gradient map where ``gradient`` and the scene's objects under it where
    ``background``, then bloom's bright, blur x, blur y at 1/2 and 1/4 size and its composite."""
    exposure = check_range("exposure", exposure, 1e-3, 1e3)
    w, h = size
    defines, inputs = {}, {"u_density": "density"}
    if gradient:
        defines["GRADIENT"], inputs["u_ramp"] = None, "ramp"
    if background:
        defines["BACKGROUND"], inputs["u_background"] = None, "background"
    stages = [PostStage("tone map", "post/tonemap.frag", (w, h),
                        {"u_mean": float(max(mean_density, 1e-12)), "u_exposure": exposure},
                        inputs, defines)]
    if bloom is None:
        return stages
    blurred = []
    for div in (2, 4):
        level = (max(1, w // div), max(1, h // div))
        # Sigma is in texels of each level, so the quarter level glows twice as wide.
        centre, pairs = blur_taps(bloom.radius)
        names = [f"bloom {what} 1/{div}" for what in ("bright", "blur x", "blur y")]
        stages += [
            PostStage(names[0], "post/bright.frag", level, {"u_threshold": bloom.threshold},
                      {"u_source": "tone map"}),
            PostStage(names[1], "post/blur.frag", level,
                      {"u_direction": (1 / level[0], 0.0), "u_centre": centre, "u_taps": pairs},
                      {"u_source": names[0]}),
            PostStage(names[2], "post/blur.frag", level,
                      {"u_direction": (0.0, 1 / level[1]), "u_centre": centre, "u_taps": pairs},
                      {"u_source": names[1]})]
        blurred.append(names[2])
    stages.append(PostStage("bloom composite", "post/composite.frag", (w, h),
                            {"u_intensity": bloom.intensity / 2},
                            {"u_source": "tone map", "u_bloom0": blurred[0],
                             "u_bloom1": blurred[1]}))
    return stages


class _Stage:
    """One post stage made real: its command and the texture it renders into (``output``)."""

    def __init__(self, group, spec):
        self.spec = spec
        self.command = FullscreenCommand(group, spec.frag, f"post stage {spec.name}",
                                         spec.defines)
        self.command.set_many(spec.uniforms)
        self.output = group.texture(spec.size, "rgba8", filter_nearest=False)
        self.framebuffer = group.framebuffer(self.output)

    def run(self, textures):
        """Draw with the stage's inputs looked up in ``textures`` (source name -> texture);
        returns the output texture."""
        self.command.draw(self.framebuffer, {sampler: textures[source]
                                             for sampler, source in self.spec.inputs.items()})
        return self.output


class PostChain:
    """Tone map (with optional gradient map) and optional bloom, at ``size`` pixels: the stages
    of :func:`post_stages`, made real.

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
        self.gradient, self.bloom = gradient, bloom
        ramp = load_ramp(gradient) if gradient is not None else None  # bad ramps fail before GL
        self.group = ctx.group()
        self.stages = []
        self.inputs = {}  # the chain's fixed textures, by source name
        try:
            if ramp is not None:
                self.inputs["ramp"] = self.group.texture((256, 1), "rgba8", data=ramp.tobytes(),
                                                         filter_nearest=False)
            if background is not None:
                h, w = background.shape[:2]
                self.inputs["background"] = self.group.texture(
                    (w, h), "rgba8", data=np.ascontiguousarray(background, np.uint8).tobytes(),
                    filter_nearest=False)
            for spec in post_stages(self.size, mean_density, exposure, ramp is not None, bloom,
                                    background is not None):
                self.stages.append(_Stage(self.group, spec))
        except Exception:
            self.release()
            raise

    def describe(self):
        """Lines for the printed plan: what runs, with its textures."""
        w, h = self.size
        ramp = f"gradient map '{self.gradient}'" if self.gradient is not None else "grey (no gradient map)"
        under = " over the scene's objects" if "background" in self.inputs else ""
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
        textures = {**self.inputs, "density": density}
        for stage in self.stages:
            textures[stage.spec.name] = stage.run(textures)
        return self.stages[-1].output

    def read(self, texture):
        """An RGBA8 texture as an (h, w, 3) uint8 image, top row first."""
        self.ctx.make_current()
        return read_rgb(texture)

    def release(self):
        self.group.release()
        self.stages, self.inputs = [], {}
