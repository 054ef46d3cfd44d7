"""A run as data: which scene with which of its own options, the frame settings, and the frames.

It sits above the scenes and the frame (it names a scene and makes its pipeline) and below what
takes runs: the command line, the WebGL export, the shares of a large still and the cluster.

:class:`Run` is what the command line makes of its arguments (once, in ``cli.py``) and what
everything below it takes: the pipeline, the WebGL export, the shares of a large still and the
Dask tasks, which receive a run, never argv to parse again. It pickles, so a cluster's workers
build exactly the pipeline one process would.
"""

from argparse import Namespace
from dataclasses import dataclass, field, replace

from .errors import ParameterError, check_range
from .frame.settings import FrameSettings

MAX_FRAMES = 100000
MAX_STEPS_PER_FRAME = 10 ** 6


@dataclass(frozen=True)
class Run:
    """A run: ``scene`` (its registered name) made from ``options`` (its own options, by name,
    as the scene's ``from_args`` reads them), with ``settings`` for its frame, drawing ``frames``
    frames ``steps_per_frame`` steps apart at ``fps`` frames a second."""

    scene: str
    options: dict = field(default_factory=dict)
    settings: FrameSettings = FrameSettings()
    frames: int = 1
    steps_per_frame: int = 1
    fps: float = 30.0

    def __post_init__(self):
        object.__setattr__(self, "frames", int(check_range("frames", self.frames, 1, MAX_FRAMES,
                                                           integer=True)))
        object.__setattr__(self, "steps_per_frame", int(check_range(
            "steps-per-frame", self.steps_per_frame, 1, MAX_STEPS_PER_FRAME, integer=True)))
        object.__setattr__(self, "fps", check_range("fps", self.fps, 0.1, 1000))

    def scene_class(self):
        from .scenes import scene_class

        cls = scene_class(self.scene)
        if cls is None:
            raise ParameterError(f"no scene is registered as {self.scene!r}")
        return cls

    def make_scene(self):
        """The scene of this run."""
        return self.scene_class().from_args(Namespace(**self.options))

    def check(self):
        """The scene of this run, made (its options checked), with the run's settings checked
        against it: everything that needs no GL context, so bad input fails before one is
        opened."""
        from .frame.settings import check_settings

        scene = self.make_scene()
        check_settings(self.settings, scene)
        return scene

    def pipeline(self, ctx, scene=None, **changes):
        """(scene, :class:`~es2particles.frame.pipeline.Pipeline`) of this run on ``ctx`` (the
        ``scene`` made already, or made here), with ``changes`` to its settings (a share of a
        still: its particles, its share, intensity 1)."""
        from .frame.pipeline import Pipeline

        scene = self.make_scene() if scene is None else scene
        return scene, Pipeline(ctx, scene, settings=replace(self.settings, **changes))

    def with_settings(self, **changes):
        return replace(self, settings=replace(self.settings, **changes))
