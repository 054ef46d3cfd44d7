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
from .gl import BACKENDS
from .io.nesting import check_nesting

MAX_FRAMES = 100000
MAX_STEPS_PER_FRAME = 10 ** 6


@dataclass(frozen=True)
class Run:
    """A run: ``scene`` (its registered name) made from ``options`` (its own options, by name,
    as the scene's ``from_args`` reads them), with ``settings`` for its frame, drawing ``frames``
    frames ``steps_per_frame`` steps apart at ``fps`` frames a second, on the GL ``backend``
    chosen (gl, gles or auto; None: ES2PARTICLES_BACKEND's, else auto)."""

    scene: str
    options: dict = field(default_factory=dict)
    settings: FrameSettings = FrameSettings()
    frames: int = 1
    steps_per_frame: int = 1
    fps: float = 30.0
    backend: str = None

    def __post_init__(self):
        if self.backend is not None and self.backend not in BACKENDS:
            raise ParameterError(f"backend must be one of {', '.join(BACKENDS)}, got "
                                 f"{self.backend!r}")
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

    def pipeline(self, ctx, scene=None, animation=None, **changes):
        """(scene, :class:`~es2particles.frame.pipeline.Pipeline`) of this run on ``ctx`` (the
        ``scene`` made already, or made here), with ``changes`` to its settings (a share of a
        still: its particles, its share, intensity 1); ``animation``: (frames, suffix) of the
        animation it writes, whose writer's memory the pipeline's estimate counts."""
        from .frame.pipeline import Pipeline

        scene = self.make_scene() if scene is None else scene
        return scene, Pipeline(ctx, scene, settings=replace(self.settings, **changes),
                               animation=animation)

    def with_settings(self, **changes):
        return replace(self, settings=replace(self.settings, **changes))


# --- runs as files --------------------------------------------------------------------------

RUN_KEYS = ("scene", "frames", "steps_per_frame", "fps", "backend", "settings", "parameters")
# The command line's own options of a run (cli.py), which no scene parameter may be named.
RUN_OPTIONS = ("out", "config", "save_config", "frames", "steps_per_frame", "fps", "save_state",
               "load_state", "workers", "scheduler", "worker_timeout", "backend")
HEADER = "# An es2particles run: es2particles run --config {name} --out picture.png\n"


def read_run(path):
    """The :class:`Run` a TOML run file describes (``write_run`` writes one); any key the file
    should not hold, or a value of the wrong kind, is one line naming the file and the key."""
    where = str(path)
    data = read_toml(path, "--config", "a TOML run file")
    unknown = [k for k in data if k not in RUN_KEYS]
    if unknown:
        raise ParameterError(f"{where}: unknown key {unknown[0]!r} (a run file holds "
                             f"{', '.join(RUN_KEYS)})")
    scene = data.get("scene")
    if not isinstance(scene, str):
        raise ParameterError(f"{where}: 'scene' must name a scene, got {scene!r}")
    for table in ("settings", "parameters"):
        if not isinstance(data.get(table, {}), dict):
            raise ParameterError(f"{where}: [{table}] must be a table of values")
    backend = data.get("backend")
    if backend is not None and backend not in BACKENDS:
        raise ParameterError(f"{where}: 'backend' must be one of {', '.join(BACKENDS)}, got "
                             f"{backend!r}")
    run = Run(scene, dict(data.get("parameters", {})),
              settings_from_mapping(data.get("settings", {}), where, Run(scene).scene_class()),
              **{k: _number(data, k, where) for k in ("frames", "steps_per_frame", "fps")
                 if k in data}, backend=backend)
    declared = run.scene_class().Params.options()
    unknown = [k for k in run.options if k not in declared]
    if unknown:
        raise ParameterError(f"{where}: [parameters] {unknown[0]!r} is not a parameter of "
                             f"{scene} (its parameters: {', '.join(declared)})")
    options = {name: declared[name].from_file(value, f"{where}: [parameters] {name}")
               for name, value in run.options.items()}
    return replace(run, options=options)


def write_run(run, scene, path):
    """Write ``run`` of ``scene`` (made) to ``path`` as a TOML run file, resolved: every
    parameter and every frame setting the scene uses, with the value this run takes (its own,
    or the default), so the file alone makes the same run."""
    from .io.output import write_atomic

    from pathlib import Path

    data = {"scene": run.scene, "frames": run.frames, "steps_per_frame": run.steps_per_frame,
            "fps": run.fps, **({"backend": run.backend} if run.backend else {}),
            "settings": resolved_settings(run.settings, scene),
            "parameters": {name: value for name, value in scene.params.values().items()
                           if value is not None and name in scene.Params.options()}}
    text = HEADER.format(name=Path(path).name) + toml_dumps(data)
    return write_atomic(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def resolved_settings(settings, scene):
    """The frame settings ``scene`` uses, each its value in ``settings`` or its default, as a
    run file writes them (the gradient 'none' where it is off, bloom a table or false); the
    state settings only where the scene keeps state, each as the value that acts (a file naming
    another would be refused on reading)."""
    from .frame.settings import (COMMON_SETTINGS, STATE_SETTINGS, acting_state_settings,
                                 keeps_particles, keeps_state, resolve, scene_rendering)

    out = {}
    rendering = scene_rendering(scene, settings.particles)
    stateless = not keeps_state(scene, rendering)  # the flame's noise: its file would refuse them
    for name in COMMON_SETTINGS + tuple(rendering.settings):
        if stateless and name in STATE_SETTINGS:
            continue
        if name == "particles" and not stateless and not keeps_particles(scene):
            continue  # a state of grids alone (the wind flame's): the count is refused
        value = resolve(settings, scene.defaults, name, rendering)
        if name == "bloom":
            out["bloom"] = False if value is None else {
                "threshold": value.threshold, "radius": value.radius,
                "intensity": value.intensity}
            continue
        if name == "gradient" and value is None:
            value = "none"
        if name == "size" and not isinstance(value, str):
            value = f"{value[0]}x{value[1]}"
        out[name] = value
    return out if stateless else acting_state_settings(scene, out)


def settings_from_mapping(mapping, where, scene=None):
    """The :class:`FrameSettings` of a run file's [settings] table (for ``scene``, a scene
    class: the particle count's range is its own)."""
    from dataclasses import replace

    from .frame.settings import BLOOM_PARTS, SETTINGS, typed_setting
    from .frame.plan import Rendering

    # the parts a table leaves out, and true, are the parts the scene's rendering blooms with
    parts_of = (scene.renders if scene is not None else Rendering).bloom_parts
    known = [n for n in SETTINGS if n not in BLOOM_PARTS] + ["bloom"]
    given = {}
    for name, value in mapping.items():
        if name not in known:
            raise ParameterError(f"{where}: [settings] unknown key {name!r} (settings: "
                                 f"{', '.join(known)})")
        if name == "bloom":
            if value is False:
                given["bloom"] = None
            elif value is True:
                given["bloom"] = parts_of
            elif isinstance(value, dict):
                parts = {f"bloom_{k}": v for k, v in value.items()}
                bad = [k for k in parts if k not in BLOOM_PARTS]
                if bad:
                    raise ParameterError(f"{where}: [settings] bloom has no {bad[0][6:]!r} "
                                         "(bloom = {threshold, radius, intensity} or false)")
                given["bloom"] = replace(parts_of, **{
                    k[6:]: SETTINGS[k].convert(v, f"bloom {k[6:]}") for k, v in parts.items()})
            else:
                raise ParameterError(f"{where}: [settings] bloom must be a table "
                                     "{threshold, radius, intensity}, true or false")
        else:
            try:
                given[name] = typed_setting(name, value, f"[settings] {name}", scene)
            except ParameterError as error:
                raise ParameterError(f"{where}: {error}") from None
    return FrameSettings(**given)


def _number(data, key, where):
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParameterError(f"{where}: {key!r} must be a number, got {value!r}")
    return value


def read_toml(path, option, what="TOML"):
    """The tables of the TOML file at ``path`` given as ``option``: where it is not a file, or
    not ``what``, one line naming both."""
    from .io.images import open_input

    named = f"{option} {str(path)!r}"
    with open_input(path, option, named) as handle:  # a folder, FIFO or device: said as such
        data = handle.read()
    try:
        return _toml_loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as error:  # TOMLDecodeError is a ValueError
        raise ParameterError(f"{option} {str(path)!r} is not {what}: {error}") from None


def _toml_loads(text):
    """The tables of TOML ``text``; a document nested beyond any run's needs (the parser recurses
    once a level: thousands of levels ended in a RecursionError) is a ValueError."""
    try:
        import tomllib
    except ImportError:  # Python before 3.11
        import tomli as tomllib
    check_nesting(text, "a run or key file")
    try:
        return tomllib.loads(text)
    except RecursionError:
        raise ValueError("nested too deep to read") from None


def toml_dumps(data):
    """TOML text of ``data``: top-level values, then one table per nested mapping (values are
    numbers, booleans, text, tuples of numbers and, in a table, small inline tables)."""
    top = [f"{key} = {_toml_value(value)}" for key, value in data.items()
           if not isinstance(value, dict)]
    tables = [f"\n[{key}]\n" + "".join(f"{k} = {_toml_value(v)}\n" for k, v in value.items())
              for key, value in data.items() if isinstance(value, dict)]
    return "\n".join(top) + "\n" + "".join(tables)


def _toml_value(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value) if value == value and abs(value) != float("inf") else _bad(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(v)}" for k, v in value.items()) + "}"
    return _bad(value)


def _bad(value):
    raise ParameterError(f"a run file cannot hold {value!r}")
