"""One frame of a scene, end to end: simulation steps, point rendering, post passes, readback.

:class:`Pipeline` makes every GL object once (state, programs, the texel buffer, targets) and then
only draws. Its :meth:`plan` prints what a frame runs and what was left out.
"""

import numpy as np

from ..errors import GraphError, ParameterError, check_range
from ..render.post import PostChain
from ..render.points import PointRenderer
from .simulation import Simulation


def parse_size(text, max_size):
    """'WxH' (or an int pair) to (w, h), each in [1, max_size]."""
    if isinstance(text, str):
        parts = text.lower().split("x")
        if len(parts) != 2:
            raise ParameterError(f"size must be WxH, e.g. 1024x1024, got {text!r}")
        try:
            text = tuple(int(p) for p in parts)
        except ValueError:
            raise ParameterError(f"size must be WxH with whole numbers, got {text!r}") from None
    w, h = text
    return (int(check_range("size width", w, 1, max_size, integer=True)),
            int(check_range("size height", h, 1, max_size, integer=True)))


def check_render_reads(scene, graph):
    """Raise unless every quantity the scene's renderer reads is one a pass of ``graph``
    writes: the renderer's reads are outputs of the frame's plan."""
    for name in scene.render_reads:
        if name not in graph.quantities or graph.writer(name) is None:
            raise GraphError(f"the renderer reads {name!r}, which scene {scene.name!r} "
                             f"{'declares but no pass writes' if name in graph.quantities else 'does not declare'}"
                             f" (its quantities: {', '.join(graph.quantities) or 'none'})")


class SeededRandom:
    """numpy's random Generator for ``seed``, made when a scene first draws from it: a scene that
    draws nothing (reseeded de Jong) spares the command numpy.random's import, ~15 ms of its
    ~0.4 s. Everything else is the Generator's own."""

    def __init__(self, seed):
        self.seed, self._generator = seed, None

    def __getattr__(self, name):
        if self._generator is None:
            self._generator = np.random.default_rng(self.seed)
        return getattr(self._generator, name)


class Pipeline:
    """A scene's whole frame on one context: simulation, renderer and post chain, one plan.

    Every parameter left as None takes the scene's default (``scene.defaults``), resolved here
    once; the renderer's reads are outputs of the simulation's plan, so a quantity the renderer
    needs and no pass writes is an error before any GL work.

    Parameters
    ----------
    ctx : Context
    scene : Scene
    particles : int, optional
    size : (int, int) or str
        Image size; each side at most the context's max texture size.
    fmt : str
        State storage format.
    point_size : float, optional
    intensity, exposure : float
        Renderer and tone-curve settings.
    gradient : str or None
        Gradient-map ramp, or None to switch the gradient map off.
    bloom : Bloom or None
        Bloom settings, or None to switch bloom off.
    seed : int
        Seed of the starting state: the same arguments give the same image on the same driver.
    rounding : str, optional
        ``nearest`` or ``dither`` for packed state.
    steps : int, optional
        Simulation steps before the first frame (``warm_up`` runs them).
    accumulate : int
        Samples summed into each image of a density scene: the particles' density after this
        step and after each of the next ``accumulate - 1`` steps (reseeded attractors shift their
        grid for each, ``Scene.sample_uniforms``), tone-mapped once. A smoother picture from the
        same particles: the noise halves with each 4x the samples, down to the floor of the
        16-bit positions' grid (README: measured).
    share : int
        Which share of a larger image this pipeline draws (``shares.py``): share 0 is a plain
        run; share s > 0 starts from the seed (``seed``, s) and, reseeded, from the grid shifted
        by samples s * accumulate onwards of the R2 sequence, so no two shares draw the same
        particles.
    """

    def __init__(self, ctx, scene, particles=None, size=(1024, 1024), fmt="rgba8",
                 point_size=None, intensity=1.0, exposure=4.0, gradient="inferno", bloom=None,
                 seed=0, rounding=None, steps=None, accumulate=1, share=0):
        defaults = scene.defaults
        self.ctx, self.scene = ctx, scene
        self.size = parse_size(size, ctx.caps.max_texture_size)
        seed = int(check_range("seed", seed, 0, 2 ** 63 - 1, integer=True))
        steps = defaults.steps if steps is None else steps
        self.steps = int(check_range("steps", steps, 0, 10 ** 7, integer=True))
        self.accumulate = int(check_range("accumulate", accumulate, 1, 10 ** 6, integer=True))
        self.share = int(check_range("share", share, 0, 2 ** 40, integer=True))
        if self.accumulate > 1 and scene.render == "sprites":
            raise ParameterError(f"accumulate applies to density scenes; {scene.name!r} draws "
                                 "3D sprites (leave it at 1)")
        graph = scene.graph()
        check_render_reads(scene, graph)
        self.sim = self.renderer = self.post = None
        try:
            self.sim = Simulation(ctx, graph, defaults.particles if particles is None else particles,
                                  outputs=scene.render_reads, fmt=fmt,
                                  rounding=defaults.rounding if rounding is None else rounding)
            reads = {q: self.sim.plan.quantities[q] for q in scene.render_reads}
            point_size = defaults.point_size if point_size is None else point_size
            if scene.render == "sprites":  # 3D: meshes, then sprites; the image is final
                from ..render.sprites import SpriteRenderer

                self.renderer = SpriteRenderer(ctx, reads, self.sim.layout, self.size,
                                               self.sim.fmt, scene.meshes(), point_size=point_size,
                                               **scene.renderer_options())
            else:
                self.renderer = PointRenderer(ctx, reads, self.sim.layout, self.size, scene.view,
                                              self.sim.fmt, point_size, intensity)
                self.post = PostChain(ctx, self.size,
                                      self.renderer.mean_density * self.accumulate, exposure,
                                      gradient, bloom, scene.background())
            scene.initialise(self.sim, SeededRandom(seed if not share else (seed, share)))
            if share:
                self._sample(0, step=False)  # the share's own first grid
        except Exception:
            self.release()
            raise
        self.final = None
        self._ordered = not scene.positions_repeat
        self._drawn = False  # a first frame was drawn: ordering pays from the second one on

    def step(self, steps=1):
        self.sim.run(steps)

    def warm_up(self):
        """Run the steps before the first frame."""
        self.sim.run(self.steps)

    def render(self, frame=0, frames=1):
        """Draw frame ``frame`` of ``frames`` (the camera of a 3D scene moves with it): the
        particles, then the post passes of a 2D scene; returns the final texture."""
        if self.post is None:
            self.final = self.renderer.draw(self.sim.buffers, self.scene.camera_at(frame, frames),
                                            self.scene.model_at(self.sim.steps_done))
            return self.final
        self.final = self.post.apply(self.density())
        return self.final

    def density(self):
        """Draw this step's density (and, accumulating, the next ``accumulate - 1`` steps') into
        the renderer's target, without the post passes; returns the density texture."""
        if self._drawn and not self._ordered:
            # Once, before the second frame: positions repeat from frame to frame, so a draw in
            # tile order pays its readback and sort (~75 ms at 2^20) back over the frames that
            # follow; a still, which draws once, is spared them (see render.py).
            position = self.sim.buffers["position"]
            self.renderer.order_by_tiles(position.download(), self.scene.view)
            self._ordered = True
        self._drawn = True
        density = self.renderer.draw(self.sim.buffers)
        for sample in range(1, self.accumulate):
            self._sample(sample)
            self.renderer.draw(self.sim.buffers, clear=False)
        if self.accumulate > 1:
            self._sample(0, step=False)  # the next frame starts as a plain one would
        return density

    def _sample(self, sample, step=True):
        uniforms = self.scene.sample_uniforms(self.share * self.accumulate + sample,
                                              self.accumulate)
        if uniforms:
            self.sim.set_uniforms(uniforms)
        if step:
            self.sim.step()

    def image(self):
        """The last rendered frame as an (h, w, 3) uint8 array, top row first."""
        if self.final is None:
            self.render()
        return (self.post or self.renderer).read(self.final)

    def picture(self):
        """The last rendered frame as a :class:`~es2particles.io.notebook.Picture`: a notebook cell
        shows it."""
        from ..io.notebook import Picture

        return Picture(self.image())

    def state(self):
        """Every simulated quantity, decoded to world units: name -> (N, components) float64."""
        return {name: self.sim.download(name) for name in self.sim.buffers}

    def plan(self):
        """The printable plan of a frame: simulation passes, render and post stages, the memory
        of each texture, and what was left out."""
        sim = self.sim
        lines = [f"scene: {self.scene.name}; {sim.count} particles in {sim.layout.width}x"
                 f"{sim.layout.height} texels ({sim.layout.spare} spare, never drawn); "
                 f"state format {sim.format_note}"
                 + (f", {sim.rounding} rounding" if sim.fmt == "rgba8" else "")
                 + f"; {self.steps} steps before the first frame",
                 "simulation step:"]
        lines += ["  " + line for line in sim.describe()]
        lines += ["  " + line for line in self.scene.describe()]
        lines += ["  " + line for line in self.scene.measured(self.ctx)]
        lines.append("frame:")
        if self.accumulate > 1:
            lines.append(f"  accumulate: {self.accumulate} samples per image (this step's "
                         f"density and the next {self.accumulate - 1} steps', "
                         f"{self.accumulate * sim.count} points), one tone map")
        lines.append("  " + self.renderer.describe())
        if self.post is not None:
            lines += ["  " + line for line in self.post.describe()]
            left = self.post.left_out()
        else:
            left = ["tone map, gradient map and bloom (a 3D sprite image is final)"]
        lines.append("  left out: " + (", ".join(left) if left else "nothing"))
        return "\n".join(lines)

    def release(self):
        for part in (self.post, self.renderer, self.sim):
            if part is not None:
                part.release()
        self.post = self.renderer = self.sim = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()
