"""A scene's frames, end to end: the frame plan made real, its start applied, and one frame loop.

:class:`Pipeline` plans the frame (:func:`~es2particles.frame.plan.plan_frame`), makes every GL
object once (an :class:`~es2particles.frame.executor.Executor` of the plan), applies the scene's
start, and then only draws. :meth:`Pipeline.frames` is the one frame loop: the command line, the
cluster's tasks, the shares of a large still and a notebook iterate it. :class:`Renderer` draws a
rendering declaration from a simulation someone else made (tools and tests).
"""

import warnings

import numpy as np

from ..errors import (Es2ParticlesError, FaintWarning, NothingDrawnWarning, ParameterError,
                      check_range)
from ..io.nesting import check_nesting
from . import memory
from .executor import Executor
from .plan import PlanBuilder, Resource, plan_frame, plan_picture
from .settings import (DEFAULT, Defaults, FrameSettings, check_bloom, frames_independent,
                       parse_size, resolve)
from .simulation import Simulation

STEPS_LIMIT = 2 ** 53  # a saved step count beyond any run's (float64 counts it exactly)


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


# Pipeline arguments whose None means "the scene's default" (for the others, gradient and bloom,
# None switches the feature off).
_NONE_IS_DEFAULT = ("particles", "size", "format", "rounding", "steps", "point_size",
                    "intensity", "exposure", "accumulate", "seed")


def settings_of(settings=None, **given):
    """A :class:`FrameSettings` from ``settings`` and keyword settings (``fmt`` is ``format``;
    None is DEFAULT except for ``gradient`` and ``bloom``, where it switches them off)."""
    if "fmt" in given:
        given["format"] = given.pop("fmt")
    out = {}
    for name, value in given.items():
        if name not in FrameSettings.__dataclass_fields__:
            raise ParameterError(f"unknown setting {name!r} (settings: "
                                 f"{', '.join(FrameSettings.__dataclass_fields__)})")
        out[name] = DEFAULT if value is None and name in _NONE_IS_DEFAULT else value
    if settings is None:
        return FrameSettings(**out)
    if not isinstance(settings, FrameSettings):
        raise ParameterError(f"settings must be a FrameSettings, got {type(settings).__name__}")
    from dataclasses import replace

    return replace(settings, **out)


def _check_kinds(ctx, scene):
    """One line where the library is given the wrong kind of context or scene."""
    from ..gl.context import Context

    if not isinstance(ctx, Context):
        raise ParameterError(f"ctx must be a Context (es2particles.open_context()), got "
                             f"{type(ctx).__name__}")
    # what a plan asks of a scene (the frame layer does not import the scenes above it)
    if not all(callable(getattr(scene, name, None)) for name in ("graph", "rendering", "start")):
        raise ParameterError(f"scene must be a Scene (es2particles.scenes), got "
                             f"{type(scene).__name__}: to run one by name, "
                             "es2particles.scenes.scene_class(name)()")


class Pipeline:
    """A scene's whole frame on one context: simulation, render and post stages, one plan.

    Every setting left out takes the scene's default (``scene.defaults``) or the framework's,
    resolved once when the plan is made; the renderer's reads are outputs of the simulation's
    plan, so a quantity the renderer needs and no pass writes is an error before any GL work, and
    so is a setting the scene's frame does not use.

    Parameters
    ----------
    ctx : Context
    scene : Scene
    particles, size, fmt, point_size, intensity, exposure, gradient, bloom, seed, rounding,
    steps, accumulate, vertex_fetch, trails, share
        The :class:`~es2particles.frame.settings.FrameSettings` (``fmt`` is its ``format``), as
        keywords; or ``settings``, a FrameSettings. ``gradient`` None is grey and ``bloom``
        None is off; any other None is the default. ``accumulate``: samples summed into each
        image of a density scene (the particles' density after this step and after each of the
        next ``accumulate - 1`` steps; reseeded attractors shift their grid for each), tone-mapped
        once. ``share``: which share of a larger still this pipeline draws
        (``cluster/shares.py``): share 0 is a plain run; share s > 0 starts from the seed (seed,
        s) and, reseeded, from the grid shifted by samples s * accumulate onwards.
    animation : (frames, suffix), optional
        The animation its frames are written to (``.webp``, ``.gif``, ``.png``, ``.mp4``), so
        the memory check counts what the writer holds; None: a still.

    Before anything is made, the run's memory (``frame/memory.py``) is checked against what the
    machine has: a run that cannot fit is refused in one line naming what to lower; ``memory``
    keeps the :class:`~es2particles.frame.memory.Estimate`.
    """

    def __init__(self, ctx, scene, particles=DEFAULT, size=DEFAULT, fmt=DEFAULT,
                 point_size=DEFAULT, intensity=DEFAULT, exposure=DEFAULT, gradient=DEFAULT,
                 bloom=DEFAULT, seed=DEFAULT, rounding=DEFAULT, steps=DEFAULT,
                 accumulate=DEFAULT, vertex_fetch=DEFAULT, trails=DEFAULT, share=None,
                 settings=None, animation=None):
        self.executor = self.sim = None
        given = {name: value for name, value in dict(
            particles=particles, size=size, format=fmt, point_size=point_size,
            intensity=intensity, exposure=exposure, gradient=gradient, bloom=bloom, seed=seed,
            rounding=rounding, steps=steps, accumulate=accumulate,
            vertex_fetch=vertex_fetch, trails=trails).items()
            if value is not DEFAULT}
        if share is not None:
            given["share"] = share
        self.settings = settings_of(settings, **given)
        _check_kinds(ctx, scene)
        self.ctx, self.scene = ctx, scene
        ctx.make_current()
        self.plan = plan_frame(scene, self.settings, ctx.caps)
        # Before the executor's textures and the start's arrays: a run that cannot fit is one
        # line, not a MemoryError seconds in.
        self.memory = memory.check(self.plan, animation)
        self.size, self.steps = self.plan.size, self.plan.steps
        self.accumulate, self.share = self.plan.accumulate, self.settings.share
        seed = self.plan.settings["seed"]
        try:
            self.executor = Executor(ctx, self.plan)
            self.sim = Simulation.over(self.executor)
            scene.initialise(self.sim, SeededRandom(seed if not self.share
                                                    else (seed, self.share)))
            if self.share:
                self._set(self.plan.samples[0])  # the share's own first grid
        except Exception:
            self.release()
            raise
        self.final = self._read = None
        # Points drawn from texels read back each frame keep texel order (the read is in it).
        points = [s for s in self.plan.frame_stages if s.kind == "points"]
        self._ordered = (not points or not scene.positions_repeat
                         or any(s.attributes for s in points))
        self._drawn = False  # a first frame was drawn: ordering pays from the second one on
        # Sprites drawn straight to the picture: the first frame checks that one lit a pixel
        # (where the device draws: a recording device's pictures are empty).
        sprites = [s for s in self.plan.frame_stages if s.kind == "sprites"]
        self._unlit_check = sprites[0] if sprites and ctx.device.draws and \
            sprites[0].target.resource == self.plan.present else None
        self._faint_check = self.plan.camera is not None  # the first frame's, by its camera

    # -- the frame loop ----------------------------------------------------------------------------

    def frames(self, frames=1, steps_per_frame=1, wanted=None, warm_up=None):
        """The one frame loop: set the scene's uniforms of the first frame, run the steps before
        it (``warm_up(pipeline)``, if given, runs them instead: a progress bar), then for each
        frame of ``frames`` set its uniforms, run ``steps_per_frame`` steps (none before the
        first) and draw it; yields each frame's number once it is drawn (``image()`` reads it).

        ``wanted``: the frames a caller needs (None: all). A stateless scene's frames need
        nothing before them (without trails), so only those are drawn; any other's need every step
        and frame before them, so those up to the last wanted one are run and only the wanted
        ones yielded."""
        frames = int(check_range("frames", frames, 1, None, integer=True))
        wanted = range(frames) if wanted is None else sorted(wanted)
        if len(wanted) and not 0 <= wanted[0] <= wanted[-1] < frames:
            raise ParameterError(f"wanted frames must lie in [0, {frames - 1}], got "
                                 f"{wanted[0]}..{wanted[-1]}")
        scene = self.scene
        self.begin(frames, warm_up)
        visit = wanted if frames_independent(scene, self.settings) else range(
            (wanted[-1] + 1) if len(wanted) else 0)
        keep = set(wanted)
        for frame in visit:
            if frame:
                self._set(self._animation[frame])
                self.step(steps_per_frame)
            self.render(frame, frames)
            if frame in keep:
                yield frame

    def _use(self):
        """Refuse in one line once released (its textures are gone)."""
        if self.executor is None:
            raise Es2ParticlesError("this Pipeline was released; make a new one")

    def begin(self, frames=1, warm_up=None):
        """Before the first of ``frames`` frames: set its uniforms and run the steps before it
        (``warm_up(pipeline)``, if given, runs them instead)."""
        self._use()
        self._animation = self.plan.animation_table(frames)
        self._set(self._animation[0])
        if warm_up is None:
            self.warm_up()
        else:
            warm_up(self)

    def step(self, steps=1):
        self._use()
        self.sim.run(steps)

    def warm_up(self):
        """Run the steps before the first frame."""
        self.sim.run(self.steps)

    def camera(self, frame=0, frames=1):
        """The scene's camera of frame ``frame`` of ``frames`` (None for a 2D scene)."""
        return None if self.plan.camera is None else self.plan.camera(frame, frames)

    def render(self, frame=0, frames=1, camera=None, drag=None):
        """Draw frame ``frame`` of ``frames`` (the camera of a 3D scene moves with it): every
        stage of the frame, the density accumulated over the run's samples; returns the final
        texture. ``camera`` (a live view's) replaces the scene's camera of the frame; ``drag``
        (3 floats) moves its moving object's rest offset (a hand's grip)."""
        self._use()
        env = self.executor.frame(camera or self.camera(frame, frames), drag)
        if self._faint_check:
            self._faint_check = False
            for message in self.plan.rendering.warnings(env.camera, self.size):
                warnings.warn(message, FaintWarning, stacklevel=2)
        self._read = None
        bare = self._draw_without_sprites(env) if self._unlit_check is not None else None
        self._order_points()
        self.final = self.executor.render(env)
        if bare is not None:
            self._unlit_check = None
            self._read = read_rgb(self.ctx, self.final)  # image() gives it: one read a frame
            if np.array_equal(bare, self._read):
                warnings.warn(f"frame {frame}: " + self.plan.rendering.unlit_message(
                    resolve(self.settings, self.scene.defaults, "point_size"), self.size,
                    env.camera),
                    NothingDrawnWarning, stacklevel=2)
        return self.final

    def _draw_without_sprites(self, env):
        """The picture of ``env`` without its sprites (meshes and background): what the
        first frame is compared with, to warn where no sprite lit a pixel. The sort's stages
        are left out (their place in a spread sort moves on with each run)."""
        sprites = self._unlit_check
        before = self.plan.frame_stages[:self.plan.frame_stages.index(sprites)]
        for stage in before:
            if stage.kind not in ("sort key", "sort merge"):
                self.executor.run(stage, env)
        if not any(s.target == sprites.target for s in before):
            self.executor.clear(sprites)
        return read_rgb(self.ctx, self.executor.front(self.plan.present))

    def density(self):
        """Draw this step's density (and, accumulating, the next ``accumulate - 1`` steps') into
        the density target, without the post stages; returns the density texture."""
        self._use()
        self._order_points()
        self.executor.render(self.executor.frame(), [self.plan.stage("points")])
        return self.executor.front("density")

    def _order_points(self):
        """Points drawn in tile order from the second frame on: positions repeat from frame to
        frame, so the order pays its readback and sort (~75 ms at 2^20) back over the frames
        that follow; a still, which draws once, is spared them (see render/points.py)."""
        if self._drawn and not self._ordered:
            stage = self.plan.stage("points")
            order = tile_order(self.sim.download("position"), self.plan.rendering.view,
                               self.size)
            self.executor.write_vertices(stage.vertices, self.sim.layout.texel_uv()[order])
            self._ordered = True
        self._drawn = True

    def _set(self, uniforms):
        """Set a frame's or a sample's uniforms (the plan's tables) on the simulation."""
        if uniforms:
            self.sim.set_uniforms(uniforms)

    # -- results -----------------------------------------------------------------------------------

    def image(self):
        """The last rendered frame as an (h, w, 3) uint8 array, top row first."""
        self._use()
        if self.final is None:
            self.render()
        if self._read is not None:
            return self._read.copy()
        return read_rgb(self.ctx, self.final)

    def picture(self):
        """The last rendered frame as a :class:`~es2particles.io.notebook.Picture`: a notebook
        cell shows it."""
        from ..io.notebook import Picture

        return Picture(self.image())

    def state(self):
        """Every simulated quantity, decoded to world units: name -> (N, components) float64;
        a grid quantity's (H, W, components), row 0 at the bottom, values at cell centres."""
        self._use()
        return {name: self.sim.download(name) for name in self.sim.buffers}

    def save_state(self, path):
        """Write the state to ``path`` (.npz): each quantity decoded to world units, float64
        (N, components), under its name (a grid quantity's (H, W, components), row 0 at the
        bottom); and what a run resumes from, byte for byte: each
        part's texels as stored (``texels.NAME.PART``) and the scene, count, format, steps done
        and, where the scene steps by a ``dt``, the simulated time (``meta``, JSON)."""
        import json

        from ..io.output import save_arrays

        arrays = {name: values for name, values in self.state().items()}
        arrays.update(self.scene.derived(dict(arrays), self.sim.count))
        for name, buffer in self.sim.buffers.items():
            for part, texels in enumerate(np.moveaxis(buffer.read_texels(), 1, 0)):
                arrays[f"texels.{name}.{part}"] = texels
        meta = {"scene": self.scene.name, "particles": self.sim.count, "format": self.sim.fmt,
                "steps_done": self.sim.steps_done,
                "quantities": {n: b.parts for n, b in self.sim.buffers.items()}}
        dt = self.plan.dt
        if isinstance(dt, float):  # the simulated time, where the scene steps by a dt
            meta["time"] = self.sim.steps_done * dt
        arrays["meta"] = np.array(json.dumps(meta))
        return save_arrays(arrays, path)

    def load_state(self, path):
        """Take the state from a file :meth:`save_state` wrote: each quantity's texels as they
        were stored and the steps done, so the run goes on as the one that saved it would. A
        file of another scene, count or format, or not a state file, is one line saying so."""
        import json
        import zipfile

        self._use()
        where = f"--load-state {str(path)!r}"
        try:
            data = np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as error:
            raise ParameterError(f"{where} is not a state file ({error})") from None
        if not isinstance(data, np.lib.npyio.NpzFile):
            raise ParameterError(f"{where} is a single .npy array, not a state file (an .npz "
                                 "archive that --save-state writes)")
        # Sizes first, from the archive's directory: a zip bomb inflated for minutes before
        # anything said no. A state of this run holds each quantity decoded (float64) and as
        # texels, a few times its textures' bytes; anything far beyond that is not one.
        largest = 8 * sum(b.layout.count * 4 * 8 * b.parts for b in self.sim.buffers.values())
        largest += 2 ** 20
        with data:
            for info in data.zip.infolist():
                if info.file_size > largest:
                    data.close()
                    raise ParameterError(
                        f"{where}: its member {info.filename!r} inflates to {info.file_size} "
                        f"bytes; a state of this run holds at most {largest}")
            try:
                arrays = {k: data[k] for k in data.files}
            except (OSError, ValueError, EOFError, zipfile.BadZipFile, MemoryError) as error:
                raise ParameterError(f"{where} is not a state file "
                                     f"({type(error).__name__}: {error})") from None
        if "meta" not in arrays:
            raise ParameterError(f"{where} holds no run's state (no 'meta': write one with "
                                 "--save-state)")
        try:
            text = str(arrays["meta"])
            check_nesting(text, "a state's meta")
            meta = json.loads(text)
        except ValueError as error:
            raise ParameterError(f"{where}: its 'meta' is not JSON ({error})") from None
        if not isinstance(meta, dict):
            raise ParameterError(f"{where}: its 'meta' must be a JSON object (what --save-state "
                                 f"writes), got {type(meta).__name__}")
        want = {"scene": self.scene.name, "particles": self.sim.count, "format": self.sim.fmt}
        differ = [f"{k} {meta.get(k)!r} (this run: {v!r})" for k, v in want.items()
                  if meta.get(k) != v]
        if differ:
            raise ParameterError(f"{where} is the state of another run: {'; '.join(differ)}")
        for name, buffer in self.sim.buffers.items():
            parts = [arrays.get(f"texels.{name}.{part}") for part in range(buffer.parts)]
            shape = (buffer.layout.count, 4)  # a grid quantity's cells, or the particles
            if any(p is None or p.shape != shape or p.dtype != buffer.read_texels().dtype
                   for p in parts):
                raise ParameterError(f"{where} lacks quantity {name!r} as this run stores it "
                                     f"({buffer.parts} part(s) of {shape} {buffer.fmt})")
            buffer.write_texels(np.stack(parts, axis=1))
        steps = meta.get("steps_done")
        if not isinstance(steps, int) or not 0 <= steps <= STEPS_LIMIT:
            shown = repr(steps) if len(repr(steps)) <= 40 else repr(steps)[:37] + "..."
            raise ParameterError(f"{where}: steps_done must be a whole number in [0, 2^53], "
                                 f"got {shown}")
        self.sim.steps_done = steps

    def describe(self):
        """The printable plan of a frame: simulation passes, render and post stages, the memory
        of each texture, and what was left out (with the scene's measured lines)."""
        return "\n".join(self.plan.describe(self.scene.measured(self.ctx)))

    def release(self):
        if self.executor is not None:
            self.executor.release()
        self.executor = self.sim = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()


def tile_order(positions, view, size, tile=64):
    """The draw order that puts particles tile by tile (``tile`` pixels square) of an image of
    ``size`` over ``view``, from their world ``positions`` (count, 2). Rasterising points in
    framebuffer order cuts the draw on llvmpipe by ~10% (2^20 reseeded de Jong points in slices:
    68 -> 61 ms; before the draw was sliced, 190 -> 120-150 ms). It pays where positions repeat
    from frame to frame, as in reseeded de Jong, and is done once, outside the per-frame loop.
    (Before each still of a chaotic stateful run, the readback and sort cost more than they
    save.)"""
    x0, y0, x1, y1 = view
    w, h = size
    px = np.clip(((positions[:, 0] - x0) / (x1 - x0) * w).astype(np.int64), 0, w - 1)
    py = np.clip(((positions[:, 1] - y0) / (y1 - y0) * h).astype(np.int64), 0, h - 1)
    key = ((py // tile) * (-(-w // tile)) + px // tile).astype(np.uint16)
    return np.argsort(key, kind="stable")  # radix sort on 16-bit keys: ~8 ms at 2^20


def read_rgb(ctx, texture):
    """An RGBA8 texture as an (h, w, 3) uint8 image, top row first (GL's first row is the
    bottom)."""
    w, h = texture.size
    # Read as RGB by the driver, then the rows flipped whole: 2 ms at 1024x1024 where taking
    # RGB out of RGBA in numpy took 5.
    pixels = np.frombuffer(ctx.read(texture, components=3), dtype=np.uint8).reshape(h, w, 3)
    return pixels[::-1].copy()


class Renderer:
    """A rendering declaration (:class:`~es2particles.render.points.Density`,
    :class:`~es2particles.render.sprites.Sprites`) drawn from the state of a
    :class:`Simulation` someone else made: its stages planned over the simulation's quantities
    and made real, the simulation's textures read as they are.

    ``settings`` (a FrameSettings, or keywords as :class:`Pipeline` takes them) give the size,
    point size, intensity and post settings; ``defaults`` the scene defaults (point size) where
    a setting is left out. ``motion``: a :class:`~es2particles.frame.motion.Motion` of the moving
    meshes (or pass ``model`` to :meth:`draw`).
    """

    def __init__(self, ctx, rendering, sim, settings=None, defaults=None, motion=None,
                 **given):
        self.executor = None
        self.ctx, self.rendering, self.sim = ctx, rendering, sim
        settings = settings_of(settings, **given)
        defaults = defaults or Defaults()
        b = PlanBuilder("rendering", settings, ctx.caps, rendering, defaults)
        b.graph_plan, b.layout, b.format = sim.plan, sim.layout, sim.fmt
        b.format_note, b.rounding = sim.format_note, sim.rounding
        b.size = parse_size(b.setting("size"), ctx.caps.max_texture_size)
        for name, buffer in sim.buffers.items():
            q = buffer.quantity
            b.resource(Resource(name, "state", sim.layout.size, buffer.fmt, parts=buffer.parts,
                                buffers=len(buffer.textures[0]), quantity=q))
        missing = [q for q in rendering.reads if q not in sim.buffers]
        if missing:
            raise ParameterError(f"the renderer reads {', '.join(missing)}, which the "
                                 f"simulation does not hold (it holds {', '.join(sim.buffers)})")
        # The simulation is made: of the frame settings, a renderer takes the size, the post
        # chain's gradient map and bloom, and those its rendering declares (the particles,
        # format, steps and seed are the simulation's; trails need an animation's frames).
        uses = {"size", "gradient", "bloom", *rendering.settings}
        unused = [n for n in settings.given() if n not in uses]
        if unused:
            raise ParameterError(f"{', '.join(unused)}: a renderer over a simulation does not "
                                 f"use {'it' if len(unused) == 1 else 'them'} (it takes size, "
                                 f"gradient, bloom and "
                                 f"{', '.join(rendering.settings) or 'nothing else'}: "
                                 f"{rendering.kind})")
        rendering.check_settings({n: getattr(settings, n) for n in settings.given()
                                  if n in rendering.settings})
        if "accumulate" in settings.given() and settings.accumulate > 1:
            # its samples are steps, and the steps are the simulation's
            raise ParameterError(f"accumulate {settings.accumulate}: a renderer over a simulation "
                                 "does not step it, and an accumulated image's samples are steps; "
                                 "draw it through Pipeline, which steps between the samples")
        check_bloom(settings.bloom)
        present = plan_picture(b, rendering, defaults)
        self.plan = b.finish(present=present, size=b.size, motion=motion)
        self.size = b.size
        self.executor = Executor(ctx, self.plan, external=dict(sim.buffers))
        self.final = None

    def draw(self, camera=None, drag=None):
        """Draw the frame seen from ``camera`` (3D), the moving meshes placed by the motion after
        the simulation's steps, its rest offset moved by ``drag`` (3 floats; None: none), through
        the executor's one frame path. Returns the presented texture."""
        if self.executor is None:
            raise Es2ParticlesError("this Renderer was released; make a new one")
        if self.sim.executor is None:
            raise Es2ParticlesError("the Simulation this Renderer draws was released: release "
                                    "the renderer first, or draw before the simulation goes")
        self.final = self.executor.render(self.executor.frame(camera, drag, self.sim.steps_done))
        return self.final

    def read(self, name=None):
        """The presented image (h, w, 3) uint8 top row first, or resource ``name``'s latest
        texels as an (h, w, channels) array of its format (row 0 at the bottom; RGBA8 as bytes)."""
        if name is None:
            return read_rgb(self.ctx, self.final if self.final is not None else self.draw())
        from ..gl.context import TEXTURE_FORMATS, numpy_dtype

        resource = self.plan.resources[name]
        w, h = resource.size
        raw = np.frombuffer(self.executor.read(name), numpy_dtype(resource.format))
        return raw.reshape(h, w, TEXTURE_FORMATS[resource.format][0]).copy()

    def describe(self):
        return "\n".join(self.plan.describe())

    def release(self):
        if self.executor is not None:
            self.executor.release()
        self.executor = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()
