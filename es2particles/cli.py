"""The ``es2particles`` command: ``info``, ``plan SCENE`` and ``run SCENE``.

Errors of the package (bad parameters, no GL, a shader that fails) are printed as one line with the
exit status 2, not as a traceback.
"""

import argparse
import re
import sys
from contextlib import contextmanager

from .errors import Es2ParticlesError


class _Parser(argparse.ArgumentParser):
    """argparse's parser, whose errors are one line (the package's error) with where to look."""

    typed = None  # the command and scene typed, where argv has them: the help to point at

    def error(self, message):
        from .errors import ParameterError

        raise ParameterError(f"{message} (see {self.typed or self.prog} --help)")


def build_parser(argv=None):
    """The command line's parser: every installed scene has its run and plan commands. Where
    ``argv`` runs or plans a built-in scene, that scene alone is imported and given its options
    (the others' imports and the package metadata cost ~45 ms of a run's start-up)."""
    parser = _Parser(prog="es2particles",
                                     description="GPU particle systems, OpenGL ES 2.0 style, headless.")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    info = commands.add_parser("info", help="print the GL context's capabilities")
    info.add_argument("--json", action="store_true",
                      help="print them as one JSON object (for scripts)")
    _add_backend(info)
    info.set_defaults(handler=_info)
    _add_scene_commands(commands, argv or ())
    if argv and len(argv) >= 2 and argv[0] in SCENE_COMMANDS \
            and not argv[1].startswith("-"):
        parser.typed = f"es2particles {argv[0]} {argv[1]}"
    report = commands.add_parser("report", help="error against run time, and the stability suite")
    report.add_argument("--quick", action="store_true",
                        help="a small sweep (about 35 s on a 2-core CPU without a GPU)")
    _add_backend(report)
    report.add_argument("--out", default="out/report",
                        help="folder for REPORT.md and charts (default out/report)")
    report.set_defaults(handler=_report)
    return parser


def main(argv=None):
    argv = _join_negative_values(sys.argv[1:] if argv is None else argv)
    restore = _terminate_as_interrupt()
    shown = _warnings_as_lines()
    try:
        argv = with_config_scene(argv)
        args = build_parser(argv).parse_args(argv)
        return args.handler(args) or 0
    except Es2ParticlesError as error:
        print(f"es2particles: error: {_capped(str(error))}", file=sys.stderr)
        return 2
    except OSError as error:
        if isinstance(error, BrokenPipeError):  # `| head` closed the pipe: nothing to say
            sys.stderr.close()
            return 0
        # a full disk, a read-only place, a name too long: after the work, said in one line
        where = f" {error.filename!r}" if error.filename else ""
        print(_capped(f"es2particles: error: cannot write{where}: {error.strerror or error}"),
              file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("es2particles: interrupted", file=sys.stderr)
        return 130
    except MemoryError:
        # What the memory estimate (frame/memory.py) did not foresee: one line, and the outputs
        # are removed as for any other failure on the way out.
        print("es2particles: error: out of memory: lower --particles, --size or "
              "--field-resolution", file=sys.stderr)
        return 1
    except Exception as error:
        # An interrupt inside an import can come out wrapped: Python 3.11 makes one raised in a
        # class's __set_name__ (a dataclass being defined) a RuntimeError caused by it.
        if not _caused_by_interrupt(error):
            raise
        print("es2particles: interrupted", file=sys.stderr)
        return 130
    finally:
        restore()
        shown()


def _capped(message, longest=160):
    """``message`` with each run of more than ``longest`` characters without a space (a value
    echoed back: a 100,000-character --shape was printed whole) cut to its start and its
    length."""
    return re.sub(rf"\S{{{longest + 1},}}",
                  lambda m: f"{m.group(0)[:longest // 2]}... ({len(m.group(0))} characters)",
                  message)


def _caused_by_interrupt(error):
    """Whether a KeyboardInterrupt is in ``error``'s chain of causes and contexts."""
    seen = set()
    while error is not None and id(error) not in seen:
        if isinstance(error, KeyboardInterrupt):
            return True
        seen.add(id(error))
        error = error.__cause__ or error.__context__
    return False


def console_main():
    """The ``es2particles`` program: :func:`main`, then out without the interpreter's teardown.
    Everything is written, closed and released by the time main returns, and what is left, the
    unloading of the GL driver and LLVM, took ~20 ms of a ~0.45 s command here; standard output
    and error are flushed first. In-process callers use :func:`main`, which returns."""
    import gc
    import os

    # Start-up makes ~10^5 objects that live as long as the process (numpy, the GL binding, the
    # parser): collecting while they are being made is wasted (~14 ms of ~0.4 s). _run freezes
    # them out of later collections and collects again once its modules are in, _report
    # collects from its start; info and plan are short.
    gc.disable()
    _terminate_as_interrupt()  # for the whole process: main's own comes and goes inside it
    try:
        _import_held()
        status = main()
    except BaseException as error:  # an interrupt outside main's own handling: held back
        if not _caused_by_interrupt(error):  # through the imports, or between two lines
            raise
        print("es2particles: interrupted", file=sys.stderr)
        status = 130
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):  # a closed pipe (`| head`) or stream: nothing left to say
        pass
    os._exit(status)


def _import_held():
    """The libraries a command loads, imported with SIGINT and SIGTERM held back (delivered
    right after, as a KeyboardInterrupt in main): a SIGTERM inside numpy's import left it half
    made, and the next import said "PyCapsule_Import could not import module" (exit 1) where one
    line and exit 130 were due. Commands that print help only need none of them."""
    if len(sys.argv) < 2 or sys.argv[1] not in ("run", "plan", "export", "view", "info",
                                                 "report"):
        return
    from .io.signals import signals_held

    with signals_held():
        import numpy  # noqa: F401
        import moderngl  # noqa: F401


MAX_IMAGE_FRAMES = 900  # WebP/GIF/APNG: each spilled frame is an open file while pillow encodes
# A phase of a run still going this long is said (a 4M-particle smoke drew its frame in silence
# for 21 s after its warm-up's progress).
LONG_PHASE_SECONDS = 2.0


class _Phases:
    """Says the phase a run is in, on one line of stderr, once it has gone on for
    LONG_PHASE_SECONDS: from a timer, so a phase that ends sooner (or fails, with its own one
    line) says nothing. The warm-up and an animation's frames have their own progress."""

    def __init__(self, start):
        self.start, self.timer = start, None

    def __call__(self, what):
        """Begin phase ``what``, ending the one before; None ends it. With SIGINT and SIGTERM
        held back meanwhile: an interrupt raised inside the timer's cancel, between its lock's
        acquire and the ``with`` that releases it, left the lock taken, and the cancel on the
        way out waited for it for ever (1 run in 333 interrupted while writing, under load)."""
        import threading
        import time

        from .io.signals import signals_deferred, signals_held

        def say():
            print(f"es2particles: {what} ({time.perf_counter() - self.start:.1f} s into the run)",
                  file=sys.stderr, flush=True)
        with signals_deferred():
            if self.timer is not None:
                self.timer.cancel()
                self.timer = None
            if what is None:
                return
            self.timer = threading.Timer(LONG_PHASE_SECONDS, say)
            self.timer.daemon = True
            with signals_held():  # its thread never takes the process's signals: see there
                self.timer.start()


@contextmanager
def _ending(phase):
    """Ends ``phase``'s timer however the block ends (a timer left running would speak after
    the command, or, in a caller's process, in the middle of its next)."""
    try:
        yield
    finally:
        phase(None)


def _warm_up(pipeline):
    """The steps before the first frame, with progress when they take long (5 million silent
    steps at --dt 1e-6 once looked like a hang): a first chunk is timed, and if the rest would
    take more than two seconds the rest is shown."""
    import time

    from .io.progress import progress

    steps = pipeline.steps
    chunk = max(1, steps // 100)
    start = time.perf_counter()
    pipeline.step(min(chunk, steps))
    done = min(chunk, steps)
    if done == steps:  # nothing left to time: the GL goes on while the frame is set out
        return
    pipeline.ctx.finish()
    chunks = -(-(steps - done) // chunk)
    if (time.perf_counter() - start) * chunks <= 2.0:
        pipeline.step(steps - done)
        return
    for k in progress(range(chunks), chunks, "warm-up", unit="chunk"):
        pipeline.step(min(chunk, steps - done - k * chunk))


def _note_sparse(pipeline):
    """A hint where a density picture will be mostly empty (--size 4000x4000 with the default
    particles lit 5% of the pixels with no word)."""
    if "density" not in pipeline.plan.resources:
        return
    per_pixel = pipeline.sim.count / (pipeline.size[0] * pipeline.size[1])
    from .frame.settings import resolve

    point = float(resolve(pipeline.settings, pipeline.scene.defaults, "point_size"))
    if per_pixel * point * point < 0.25:  # the share of the pixels the points could cover
        print(f"es2particles: note: {pipeline.sim.count} particles of {point:g} pixels on "
              f"{pipeline.size[0]}x{pipeline.size[1]} pixels cover at most "
              f"{per_pixel * point * point:.2g} of them: the picture will be sparse; raise "
              "--particles (or --point-size)", file=sys.stderr)


def _note_static_animation(run, frames):
    """A hint where an attractor's animation would show nothing change (one line on stderr)."""
    params = run.scene_class().Params.declarations()
    if frames > 1 and "animate_to" in params and run.options.get("animate_to") is None:
        print("es2particles: note: --frames without --animate-to keeps the coefficients; the "
              "frames differ only as particles move" + (" (reseeded: not at all)"
                                                        if run.options.get("reseed") else "")
              + "; give --animate-to A,B,C,D to animate them", file=sys.stderr)


def _warnings_as_lines():
    """The package's warnings said as its errors are, one line each, while the command runs;
    returns what restores Python's way of showing them."""
    import warnings

    previous = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        print(f"es2particles: warning: {message}", file=sys.stderr)

    warnings.showwarning = show
    return lambda: setattr(warnings, "showwarning", previous)


def _in_finalizer(frame):
    """Whether ``frame`` runs where an exception would be swallowed or leave things half made:
    inside an object's finalizer (``__del__``, a weakref.finalize) or the import machinery
    (importlib's frozen bootstrap, whose module-lock callback printed "Exception ignored in
    _get_module_lock ... KeyboardInterrupt" and let a run go on to exit 0)."""
    while frame is not None:
        code = frame.f_code
        if code.co_name == "__del__" or (code.co_name == "__call__"
                                         and code.co_filename.endswith("weakref.py")) \
                or code.co_filename.startswith("<frozen importlib._bootstrap"):
            return True
        frame = frame.f_back
    return False


def _terminate_as_interrupt():
    """SIGTERM unwinds like Ctrl-C while the command runs, so partly written files are removed
    (an animation's hidden .part file stayed behind after a kill); returns what restores the
    previous handlers. A signal landing inside a finalizer (a GL object's ``__del__`` in a
    collection) or an import is delivered a few milliseconds later, once out of it: an exception
    raised there is printed and swallowed, and a run went on to exit 0 under a traceback."""
    import signal
    import threading

    pending = []

    def interrupt(signum, frame):
        if _in_finalizer(frame):
            pending.append(signum)
            signal.setitimer(signal.ITIMER_REAL, 0.005)
            return
        raise KeyboardInterrupt

    def again(signum, frame):
        if pending:
            interrupt(pending.pop(), frame)

    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    previous = {sig: signal.signal(sig, handler) for sig, handler in (
        (signal.SIGTERM, interrupt), (signal.SIGINT, interrupt), (signal.SIGALRM, again))}
    return lambda: [signal.signal(sig, handler) for sig, handler in previous.items()]


# A value that starts with '-' and looks like a number (-inf, -nan, -1e3, -5x5) but not like one
# to argparse (which knows only -12 and -1.5): it would take it for an option and fail with
# "expected one argument" instead of checking the value.
_NEGATIVE_VALUE = re.compile(r"^-(inf|infinity|nan|\d|\.\d)", re.IGNORECASE)
_ARGPARSE_NUMBER = re.compile(r"^-\d+$|^-\d*\.\d+$")


def _join_negative_values(argv):
    """``--option -value`` as ``--option=-value`` where the value looks like a number."""
    out = []
    for token in argv:
        if (out and out[-1].startswith("--") and "=" not in out[-1]
                and _NEGATIVE_VALUE.match(token) and not _ARGPARSE_NUMBER.match(token)):
            out[-1] = f"{out[-1]}={token}"
        else:
            out.append(token)
    return out


def _info(args):
    from .gl.egl import open_context

    with open_context(backend=args.backend) as ctx:
        if args.json:
            import json

            print(json.dumps(ctx.caps.as_dict(), indent=1))
        else:
            print(ctx.caps)


def _report(args):
    import gc
    from pathlib import Path

    gc.enable()  # a long run: console_main's pause of collection is for short start-ups

    from .gl.egl import open_context
    from .errors import ParameterError
    from .io.output import check_folder
    from .report import run

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"--out {args.out!r} is a file; it must be a folder")
    check_folder(out, "--out")  # made, with any missing parents, when the report is written
    if (out / "REPORT.md").is_dir():
        raise ParameterError(f"--out: {str(out / 'REPORT.md')!r} is a folder; the report would "
                             "go there")
    with open_context(backend=args.backend) as ctx:
        path = run(ctx, out, quick=args.quick)
    print(f"wrote {path}")


SCENE_COMMANDS = ("run", "plan", "export", "view")


def _add_scene_commands(commands, argv):
    from .scenes import BUILT_IN, installed_scenes, scene_class

    named = argv[1] if len(argv) >= 2 and argv[0] in SCENE_COMMANDS else None
    scenes_found = {named: scene_class(named)} if named in BUILT_IN else installed_scenes()
    names = ", ".join(scenes_found)
    handlers = {"run": _run, "plan": _plan, "export": _export, "view": _view}
    for command, text in (("run", "simulate a scene and write an image or animation"),
                          ("plan", "print the stages a scene's frame runs and what it leaves "
                                   "out"),
                          ("export", "write a scene as one WebGL 1 page that runs it in a "
                                     "browser (no network)"),
                          ("view", "show a scene live in a window (the view extra): keys and "
                                   "the mouse move the camera, the sphere, the coefficients")):
        parser = commands.add_parser(command, help=f"{text} (scenes: {names})",
                                     description=f"{text}. Installed scenes: {names}.")
        if named is not None and command != argv[0]:
            continue  # argv runs another command: this one is only listed (~1.5 ms a command)
        scenes = parser.add_subparsers(dest="scene", required=True, metavar="SCENE")
        for name, scene in scenes_found.items():
            summary = (scene.__doc__ or name).strip().splitlines()[0].replace("``", "")
            sub = scenes.add_parser(name, help=summary, description=summary)
            own = sub.add_argument_group(f"{name}'s parameters")
            _check_names(scene)
            scene.add_arguments(own)
            scene_options = [a.dest for a in own._group_actions]
            _add_settings(sub.add_argument_group("frame settings (defaults: this scene's)"),
                          scene)
            _add_run_options(sub, command)
            sub.set_defaults(handler=handlers[command], scene_class=scene,
                             scene_options=scene_options)


def _check_names(scene):
    """A scene's parameter named like a frame setting or a run option would take its option:
    say so, naming both, for the scene's author."""
    from .errors import GraphError
    from .frame.settings import SETTINGS
    from .run import RUN_OPTIONS

    taken = set(SETTINGS) | {"bloom", "no_bloom"} | set(RUN_OPTIONS)
    clash = [n for n in scene.Params.options() if n in taken]
    if clash:
        raise GraphError(f"scene {scene.name!r}: its parameter {clash[0]!r} has the name of a "
                         f"frame setting or run option (--{clash[0].replace('_', '-')}); rename "
                         "the parameter")


def _add_settings(parser, scene):
    """The frame settings ``scene`` uses, one option each (``frame/settings.py``), with this
    scene's default in the help. Each defaults to None, "not given": the default is resolved
    once when the frame is planned."""
    from .frame.settings import (BLOOM_PARTS, COMMON_SETTINGS, SETTINGS, Defaults,
                                 particles_setting)

    scene_defaults = set(Defaults.__dataclass_fields__)
    used = COMMON_SETTINGS + tuple(scene.renders.settings)
    # The settings it does not use are taken but not shown, so giving one is refused in one line
    # that names it and says why (check_settings), not argparse's "unrecognized arguments".
    for name in [n for n in SETTINGS if n not in used and n not in BLOOM_PARTS]:
        parser.add_argument(SETTINGS[name].flag_name, dest=name, default=None,
                            help=argparse.SUPPRESS)
    for name in used:
        if name == "bloom":
            # Bloom is over every rendering's picture, on by default where the rendering says
            # (the density's): the switch listed is the one that changes something here, and
            # the other is taken (a run file's value may be either).
            on = scene.renders.default_bloom is not None
            parser.add_argument("--no-bloom", action="store_true", default=None,
                                help="switch bloom off" if on else argparse.SUPPRESS)
            parser.add_argument("--bloom", dest="bloom_on", action="store_true", default=None,
                                help=argparse.SUPPRESS if on else
                                "switch bloom on over the picture (off by default here; a "
                                "--bloom-* value switches it on too)")
            for part in BLOOM_PARTS:
                d = SETTINGS[part]
                default = d.describe_value(getattr(scene.renders.bloom_parts, part[6:]))
                parser.add_argument(d.flag_name, dest=part, default=None, metavar="X",
                                    help=d.help_text(default_text=default))
            continue
        d = particles_setting(scene) if name == "particles" else SETTINGS[name]
        default = scene.default_text(name) if name in scene_defaults else None
        metavar = d.metavar or ("{" + ",".join(d.choices) + "}" if d.choices else
                                ("N" if d.integer else "X"))
        parser.add_argument(d.flag_name, dest=name, default=None, metavar=metavar,
                            help=d.help_text(default_text=default))


def _add_backend(parser):
    from .gl import BACKENDS

    parser.add_argument("--backend", default=None, choices=BACKENDS,
                        help="the GL to run on: gl (desktop OpenGL), gles (OpenGL ES through "
                             "EGL), or auto (desktop GL where it opens, else ES; default, or "
                             "the ES2PARTICLES_BACKEND environment variable)")


def _add_run_options(parser, command):
    add = parser.add_argument
    out = {"export": "the page: an .html file",
           "plan": None, "view": None,
           "run": "output: .png image, or with --frames .webp/.gif/.png, or .mp4 (the video "
                  "extra)"}[command]
    if out:
        add("--out", required=True, help=out)
    add("--config", default=None, metavar="RUN.toml",
        help="take the run from this file (written by --save-config); options given beside it "
             "override its values")
    if command == "view":
        add("--keys", default=None, metavar="KEYS.toml",
            help="key bindings over the standard ones: a [keys] table of action = \"key\"")
        add("--paused", action="store_true",
            help="start paused: space plays, . steps once")
        add("--exit-after", default=None, metavar="N",
            help="close the window after N frames (scripts and tests)")
        add("--screenshot", default=None, metavar="FILE.png",
            help="write the last frame shown to this file when the window closes")
    if command == "export":
        # run's other options, taken but not shown, so that each is refused in one line saying
        # why a page does without it (PAGE_REFUSES), not argparse's "unrecognized arguments".
        for name in PAGE_REFUSES:
            add("--" + name.replace("_", "-"), default=None, help=argparse.SUPPRESS)
        add("--frames", default=None, metavar="F",
            help="frames of the run's animation: the page sets each frame's animated uniforms "
                 "(--animate-to) as run does, then holds the last (default 1)")
        add("--steps-per-frame", default=None, metavar="S",
            help="steps between the page's frames (default 1)")
    if command == "plan":
        _add_backend(parser)
    if command != "run":
        return
    _add_backend(parser)
    add("--save-config", default=None, metavar="RUN.toml",
        help="also write the run, resolved (every parameter and setting this scene uses), to "
             "this file: --config gives the same run")
    add("--frames", default=None, metavar="F", help="frames of an animation (default 1: a still)")
    add("--steps-per-frame", default=None, metavar="S",
        help="steps between the frames of an animation (default 1)")
    add("--fps", default=None, metavar="X", help="an animation's frame rate (default 30)")
    add("--save-state", default=None, metavar="STATE.npz",
        help="also write the state after the last frame to this file: each quantity decoded, "
             "and what --load-state resumes from")
    add("--load-state", default=None, metavar="STATE.npz",
        help="start from the state a --save-state of this scene, count and format wrote (and "
             "its step count), then run --steps more before the first frame")
    add("--workers", default=None, metavar="N",
        help="run on a new local Dask cluster of this many worker processes, one GL context "
             "each (the distributed extra): an animation's frames, or a still's shares of "
             "particles, as tasks; the same bytes as one process")
    add("--scheduler", default=None, metavar="ADDRESS",
        help="run on the Dask cluster of this scheduler address (tcp://host:8786), as "
             "--workers does")
    add("--worker-timeout", default=None, metavar="SECONDS",
        help="with --workers or --scheduler: end the run, in one line, when the cluster has "
             "had no worker this long while tasks are left; an animation's frames made are "
             "kept for the same command to resume. 1 to 86400 (default 60)")


# run's options that a page does without, and why.
PAGE_REFUSES = {
    "fps": "a page plays at the browser's frame rate (one frame an animation frame)",
    "save_config": "export writes the page alone (run --save-config writes a run file, and "
                   "export --config makes its page)",
    "save_state": "a page's state lives in the browser (run --save-state writes one)",
    "load_state": "a page starts from the scene's own start (run --load-state resumes a state)",
    "workers": "a page runs in one browser, not on a cluster",
    "scheduler": "a page runs in one browser, not on a cluster",
    "worker_timeout": "a page runs in one browser, not on a cluster",
    "backend": "a page runs on the browser's WebGL, not on this machine's GL",
}


def with_config_scene(argv):
    """``argv`` with the scene of its ``--config`` file put after the command where no scene is
    typed (``es2particles run --config run.toml --out b.png``)."""
    if len(argv) < 2 or argv[0] not in SCENE_COMMANDS or not argv[1].startswith("-"):
        return argv
    for i, token in enumerate(argv):
        path = argv[i + 1] if token == "--config" and i + 1 < len(argv) else (
            token.split("=", 1)[1] if token.startswith("--config=") else None)
        if path is not None:
            from .run import read_run

            return [argv[0], read_run(path).scene, *argv[1:]]
    return argv


def run_of(args):
    """The :class:`~es2particles.run.Run` of the parsed arguments: the run file of
    ``--config``, if any, and over it the scene's options and the frame settings the user
    typed (the others are the file's, or the scene's or the framework's defaults, resolved once
    when the frame is planned)."""
    from dataclasses import replace

    from .errors import ParameterError
    from .frame.settings import BLOOM_PARTS, SETTINGS, typed_setting
    from .run import Run, read_run

    base = Run(args.scene)
    if args.config is not None:
        base = read_run(args.config)
        if base.scene != args.scene:
            raise ParameterError(f"--config {args.config!r} is a run of {base.scene}, not "
                                 f"{args.scene}")
    typed = {name: getattr(args, name) for name in SETTINGS
             if name not in BLOOM_PARTS and getattr(args, name, None) is not None}
    settings = {name: typed_setting(name, value, SETTINGS[name].flag_name, args.scene_class)
                for name, value in typed.items()}
    parts = {part: None if getattr(args, part, None) is None else SETTINGS[part].convert(
        getattr(args, part), SETTINGS[part].flag_name) for part in BLOOM_PARTS}
    if getattr(args, "no_bloom", None):
        given = ["--" + p.replace("_", "-") for p, v in parts.items() if v is not None]
        given += ["--bloom"] if getattr(args, "bloom_on", None) else []
        if given:
            raise ParameterError(f"--no-bloom switches bloom off: leave out {', '.join(given)}")
        settings["bloom"] = None
    elif getattr(args, "bloom_on", None) or any(value is not None for value in parts.values()):
        # the run file's bloom, else the parts this scene's rendering blooms with
        before = base.settings.get("bloom", None) or args.scene_class.renders.bloom_parts
        settings["bloom"] = replace(before, **{p[6:]: v for p, v in parts.items()
                                               if v is not None})
    options = {**base.options, **{name: getattr(args, name) for name in args.scene_options
                                  if getattr(args, name) is not None}}
    frames = {}
    for name in ("frames", "steps_per_frame", "fps"):
        value = getattr(args, name, None)
        if value is not None:
            frames[name] = _number(value, "--" + name.replace("_", "-"))
    run = Run(args.scene, options, replace(base.settings, **settings),
              **{"frames": base.frames, "steps_per_frame": base.steps_per_frame,
                 "fps": base.fps, **frames},
              backend=getattr(args, "backend", None) or base.backend)
    if run.frames == 1:
        still = [f"--{n.replace('_', '-')}" for n in ("steps_per_frame", "fps") if n in frames]
        if still:
            raise ParameterError(f"{', '.join(still)}: a still has one frame (give --frames "
                                 "for an animation)")
    return run


def _check_animation(run):
    """What moves over an animation's frames does nothing on a still: refused in one line."""
    from .errors import ParameterError

    if run.frames == 1 and run.options.get("animate_to") is not None:
        raise ParameterError("--animate-to animates over an animation's frames: give --frames "
                             "F (2 or more) with it; a still has none")
    if run.frames == 1 and run.options.get("camera") == "orbit":
        raise ParameterError("--camera orbit circles the target over an animation's frames: "
                             "give --frames F (2 or more) with it; a still has one camera")
    if run.frames == 1 and run.settings.get("trails", "off") != "off":
        raise ParameterError("--trails: a trail is the frames before a frame: give --frames F "
                             "(2 or more) with it; a still has none")


def _number(text, option):
    from .errors import ParameterError

    try:
        return float(text)
    except ValueError:
        raise ParameterError(f"{option} must be a number, got {text!r}") from None


def _plan(args):
    from .gl.egl import open_context

    run = run_of(args)
    scene = run.check()
    with open_context(backend=run.backend) as ctx:
        scene, pipeline = run.pipeline(ctx, scene)
        with pipeline:
            print(pipeline.describe())


def _export(args):
    from .errors import ParameterError
    from .export.page import page_plan, write_page
    from .io.output import check_output

    given = [name for name in PAGE_REFUSES if getattr(args, name, None) is not None]
    if given:
        raise ParameterError(f"--{given[0].replace('_', '-')}: {PAGE_REFUSES[given[0]]}")
    out = check_output(args.out, "--out", {".html": "HTML"})
    run = run_of(args)
    _check_animation(run)
    if run.options.get("camera") == "orbit":
        raise ParameterError("--camera orbit: a page's camera is the mouse's (drag to orbit)")
    plan = page_plan(run.check(), run.settings, frames=run.frames,
                     steps_per_frame=run.steps_per_frame)
    if run.frames > 1 and not plan["animation"]:
        raise ParameterError("--frames: nothing of this page moves over an animation's frames "
                             "(give --animate-to); a page plays until paused")
    write_page(plan, out)
    passes = sum(1 for s in plan["stages"] if s["step"])
    print(f"wrote {out} ({out.stat().st_size / 2 ** 20:.1f} MiB: {run.scene}, "
          f"{plan['layout']['count']} particles, {passes} pass draws a step, "
          f"{len(plan['stages']) - passes} stages a frame; open it in a browser)")


def _view(args):
    """``view SCENE``: the scene live in a window, until it closes (``live/window.py``)."""
    from .errors import check_range
    from .frame.settings import DEFAULT, MAX_SIZE, SETTINGS, parse_size
    from .io.output import check_output
    from .live.controls import Bindings
    from .live.view import LiveView
    from .live.window import Window

    bindings = Bindings.read(args.keys) if args.keys is not None else Bindings()
    exit_after = None if args.exit_after is None else int(check_range(
        "--exit-after", _number(args.exit_after, "--exit-after"), 1, 10 ** 9, integer=True))
    shot = None if args.screenshot is None else \
        check_output(args.screenshot, "--screenshot", {".png": "PNG"})
    run = run_of(args)
    scene = run.check()
    given = None if run.settings.size is DEFAULT else parse_size(run.settings.size, MAX_SIZE)
    with Window(given, f"es2particles: {run.scene}",
                default=parse_size(SETTINGS["size"].default, MAX_SIZE)) as window:
        run = run.with_settings(size="{}x{}".format(*window.size))
        scene, pipeline = run.pipeline(window.ctx, scene)
        with pipeline:
            view = LiveView(pipeline, bindings, paused=args.paused)
            frames, seconds, status = window.show(view, exit_after, shot)
            line = f"viewed {frames} frames in {seconds:.2f} s: {status}"
            if view.view is not None:
                camera = view.view.camera()
                line += (" | camera eye " + ",".join(f"{v:.6f}" for v in camera.eye)
                         + " target " + ",".join(f"{v:.6f}" for v in camera.target))
            if view.grip is not None:
                line += " | grip " + ",".join(f"{v:.6f}" for v in view.centre)
            for c in view.controls:
                line += f" | {c.label} {view.values[c.uniform][c.component]:.6f}"
            if shot is not None and frames:
                line += f" | wrote {shot}"
            print(line)


def _run(args):
    import gc
    import time

    from .cluster import shares
    from .errors import ParameterError
    from .frame.settings import MAX_SIZE, parse_size
    from .gl.egl import open_context
    from .io.images import check_input
    from .io.output import (ANIMATION_SUFFIXES, IMAGE_SUFFIXES, AnimationWriter, OutputGroup,
                            check_output, check_video, save_image)
    from .io.progress import progress
    from .run import write_run

    # console_main paused collection while the modules came in; what they made lives as long
    # as the process, so it is frozen out of later collections rather than walked by the first
    # ones (~9 ms of a still's start, in one young and one middle collection).
    gc.freeze()
    gc.enable()
    start = time.perf_counter()
    run = run_of(args)
    frames = run.frames
    _check_animation(run)
    out = check_output(args.out, "--out", ANIMATION_SUFFIXES if frames > 1 else IMAGE_SUFFIXES)
    if frames > MAX_IMAGE_FRAMES and out.suffix.lower() != ".mp4":
        raise ParameterError(f"frames must be at most {MAX_IMAGE_FRAMES} for {out.suffix} "
                             f"(pillow holds every frame's file open); got {frames}: write .mp4 "
                             "for longer animations")
    state_path = None if args.save_state is None else check_output(args.save_state, "--save-state",
                                                                   {".npz": "NPZ"})
    config_path = None if args.save_config is None else check_output(
        args.save_config, "--save-config", {".toml": "TOML"})
    load_path = None if args.load_state is None else check_input(args.load_state,
                                                                  "--load-state")
    scene = run.check()
    _note_static_animation(run, frames)  # after the checks: bad input is one line
    if frames > 1:  # before any work: the video extra, even sides
        check_video(out, parse_size(run.settings.get("size", (1024, 1024)), MAX_SIZE))
    sizes = shares.share_sizes(run, save_state=args.save_state is not None)
    # The run's files land together or not at all (an interrupt leaves none of them, and any
    # earlier ones at those paths as they were); the picture last, as the sign of a finished run.
    outputs = OutputGroup(state_path, config_path, out)
    if args.worker_timeout is not None and args.workers is None and args.scheduler is None:
        raise ParameterError("--worker-timeout is for a run on a cluster: give --workers or "
                             "--scheduler with it")
    if args.workers is not None or args.scheduler is not None:
        if load_path is not None:
            raise ParameterError("--load-state resumes one process's run: leave out --workers "
                                 "and --scheduler to load it")
        with outputs:
            where = _run_on_cluster(args, run, out, sizes)
            if config_path is not None:
                write_run(run, scene, config_path)
        print(f"wrote {out} ({args.size or 'default size'}, {frames} frame(s)"
              + (f", {args.particles} particles in {len(sizes)} shares" if sizes else "")
              + f") in {time.perf_counter() - start:.2f} s {where}")
        return
    with open_context(backend=run.backend) as ctx, outputs:
        if sizes is not None:
            save_image(shares.still(ctx, run, sizes), out)
            if config_path is not None:
                write_run(run, scene, config_path)
            said = (f"wrote {out} ({args.size or 'default size'}, {args.particles} particles in "
                    f"{len(sizes)} shares of at most {shares.SHARE})")
            density = ""
        else:
            animation = (frames, out.suffix.lower()) if frames > 1 else None
            particles = run.settings.get("particles", scene.defaults.particles)
            phase = _Phases(start)
            phase("compiling the passes" + (f" and setting out {particles} particles"
                                            if particles else ""))
            try:
                scene, pipeline = run.pipeline(ctx, scene, animation=animation)
            finally:
                phase(None)
            with pipeline, _ending(phase):
                _note_sparse(pipeline)
                if load_path is not None:
                    phase(f"loading {load_path}")
                    pipeline.load_state(load_path)

                def warm_up(pipeline):
                    phase(None)  # the warm-up shows its own progress
                    _warm_up(pipeline)
                    if frames == 1:
                        phase("drawing the picture")
                drawn = pipeline.frames(frames, run.steps_per_frame, warm_up=warm_up)
                if frames == 1:
                    next(drawn)
                    phase(f"writing {out}")
                    save_image(pipeline.image(), out)
                    phase(None)
                else:
                    with AnimationWriter(out, run.fps) as writer:  # frames stream out: bounded
                        for _ in progress(drawn, frames, "frames"):
                            writer.add(pipeline.image())
                        if out.suffix.lower() != ".mp4":  # the assembly takes a while: say so
                            print(f"es2particles: assembling {frames} frames into {out}",
                                  file=sys.stderr)
                        writer.close()
                if state_path is not None:
                    phase(f"saving the state to {state_path}")
                    pipeline.save_state(state_path)
                    phase(None)
                if config_path is not None:
                    write_run(run, scene, config_path)
                for line in scene.after_run(pipeline.sim):  # once a run: what it saw
                    print(f"es2particles: note: {line}", file=sys.stderr)
                said = (f"wrote {out} ({pipeline.size[0]}x{pipeline.size[1]}, "
                        + (f"{pipeline.sim.count} particles, " if pipeline.sim.count else "")
                        + f"{pipeline.sim.steps_done} steps, "
                        f"{frames} frame(s))")
                density = (f"; density target {pipeline.plan.resources['density'].format}"
                           if "density" in pipeline.plan.resources else "")
    print(f"{said} in {time.perf_counter() - start:.2f} s{density}")  # said once they landed


def _run_on_cluster(args, run, out, sizes):
    """Run the command on Dask (``cluster/tasks.py``), a still in shares of ``sizes`` particles
    (None: one pipeline); returns where it ran, for the last line."""
    from .cluster import tasks
    from .errors import CapabilityError, ParameterError, check_range

    if args.workers is not None and args.scheduler is not None:
        raise ParameterError("give --workers (a new local cluster) or --scheduler (a running "
                             "one), not both")
    workers = None
    if args.workers is not None:
        workers = int(check_range("workers", _number(args.workers, "--workers"), 1, 1024,
                                  integer=True))
    worker_timeout = tasks.WORKER_TIMEOUT
    if args.worker_timeout is not None:
        worker_timeout = check_range("--worker-timeout",
                                     _number(args.worker_timeout, "--worker-timeout"), 1,
                                     tasks.MAX_WORKER_TIMEOUT)
    if args.save_state is not None:
        raise ParameterError("--save-state writes one process's state: leave out --workers and "
                             "--scheduler to save it")
    missing = tasks.available()
    if missing:
        raise CapabilityError(missing)
    client = tasks.connect(workers=workers, scheduler=args.scheduler)
    try:
        count = tasks.workers(client)
        if run.frames == 1:
            tasks.still(client, run, out, sizes, worker_timeout)
        else:
            tasks.animation(client, run, out, worker_timeout)
    finally:
        tasks.close(client)
    return (f"on {count} local worker(s)" if args.scheduler is None
            else f"on {count} worker(s) of {args.scheduler}")


if __name__ == "__main__":
    console_main()
