"""The ``es2particles`` command: ``info``, ``plan SCENE`` and ``run SCENE``.

Errors of the package (bad parameters, no GL, a shader that fails) are printed as one line with the
exit status 2, not as a traceback.
"""

import argparse
import re
import sys

from .errors import Es2ParticlesError


def build_parser(argv=None):
    """The command line's parser: every installed scene has its run and plan commands. Where
    ``argv`` runs or plans a built-in scene, that scene alone is imported and given its options
    (the others' imports and the package metadata cost ~45 ms of a run's start-up)."""
    parser = argparse.ArgumentParser(prog="es2particles",
                                     description="GPU particle systems, OpenGL ES 2.0 style, headless.")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    info = commands.add_parser("info", help="print the GL context's capabilities")
    info.set_defaults(handler=_info)
    _add_scene_commands(commands, argv or ())
    report = commands.add_parser("report", help="error against run time, and the stability suite")
    report.add_argument("--quick", action="store_true",
                        help="a small sweep (about 35 s on a 2-core CPU without a GPU)")
    report.add_argument("--out", default="out/report",
                        help="folder for REPORT.md and charts (default out/report)")
    report.set_defaults(handler=_report)
    return parser


def main(argv=None):
    argv = _join_negative_values(sys.argv[1:] if argv is None else argv)
    args = build_parser(argv).parse_args(argv)
    restore = _terminate_as_interrupt()
    try:
        return args.handler(args) or 0
    except Es2ParticlesError as error:
        print(f"es2particles: error: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        if isinstance(error, BrokenPipeError):  # `| head` closed the pipe: nothing to say
            sys.stderr.close()
            return 0
        # a full disk, a read-only place, a name too long: after the work, said in one line
        where = f" {error.filename!r}" if error.filename else ""
        print(f"es2particles: error: cannot write{where}: {error.strerror or error}",
              file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("es2particles: interrupted", file=sys.stderr)
        return 130
    finally:
        restore()


def console_main():
    """The ``es2particles`` program: :func:`main`, then out without the interpreter's teardown.
    Everything is written, closed and released by the time main returns, and what is left, the
    unloading of the GL driver and LLVM, took ~20 ms of a ~0.45 s command here; standard output
    and error are flushed first. In-process callers use :func:`main`, which returns."""
    import gc
    import os

    # Start-up makes ~10^5 objects that live as long as the process (numpy, the GL binding, the
    # parser): collecting while they are being made is wasted (~14 ms of ~0.4 s). _run collects
    # again once its modules are in, _report from its start; info and plan are short.
    gc.disable()
    status = main()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):  # a closed pipe (`| head`) or stream: nothing left to say
        pass
    os._exit(status)


MAX_IMAGE_FRAMES = 900  # WebP/GIF/APNG: each spilled frame is an open file while pillow encodes


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
    if per_pixel < 0.25:
        print(f"es2particles: note: {pipeline.sim.count} particles on {pipeline.size[0]}x"
              f"{pipeline.size[1]} pixels is {per_pixel:.2g} a pixel: the picture will be "
              "sparse; raise --particles (or --point-size)", file=sys.stderr)


def _note_static_animation(args, frames):
    """A hint where an animation would show nothing change (one line on stderr)."""
    if frames > 1 and getattr(args, "animate_to", "absent") is None:
        print("es2particles: note: --frames without --animate-to keeps the coefficients; the "
              "frames differ only as particles move" + (" (reseeded: not at all)"
                                                        if getattr(args, "reseed", False) else "")
              + "; give --animate-to A,B,C,D to animate them", file=sys.stderr)


def _terminate_as_interrupt():
    """SIGTERM unwinds like Ctrl-C while the command runs, so partly written files are removed
    (an animation's hidden .part file stayed behind after a kill); returns what restores the
    previous handler."""
    import signal
    import threading

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    previous = signal.signal(signal.SIGTERM, interrupt)
    return lambda: signal.signal(signal.SIGTERM, previous)


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

    with open_context() as ctx:
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
    with open_context() as ctx:
        path = run(ctx, out, quick=args.quick)
    print(f"wrote {path}")


def _add_scene_commands(commands, argv):
    from .scenes import BUILT_IN, installed_scenes, scene_class

    named = argv[1] if len(argv) >= 2 and argv[0] in ("run", "plan", "export") else None
    scenes_found = {named: scene_class(named)} if named in BUILT_IN else installed_scenes()
    names = ", ".join(scenes_found)
    handlers = {"run": _run, "plan": _plan, "export": _export}
    for command, text in (("run", "simulate a scene and write an image or animation"),
                          ("plan", "print the stages a scene's frame runs and what it leaves "
                                   "out"),
                          ("export", "write a scene as one WebGL 1 page that runs it in a "
                                     "browser (no network)")):
        parser = commands.add_parser(command, help=f"{text} (scenes: {names})",
                                     description=f"{text}. Installed scenes: {names}.")
        scenes = parser.add_subparsers(dest="scene", required=True, metavar="SCENE")
        for name, scene in scenes_found.items():
            summary = (scene.__doc__ or name).strip().splitlines()[0].replace("``", "")
            sub = scenes.add_parser(name, help=summary, description=summary)
            _add_common_arguments(sub, command)
            common = {action.dest for action in sub._actions}
            scene.add_arguments(sub)
            own = [a.dest for a in sub._actions if a.dest not in common]
            sub.set_defaults(handler=handlers[command], scene_class=scene, scene_options=own)


def _add_common_arguments(parser, command):
    """The frame settings every scene takes. Each defaults to None, "not given": the scene's
    default, or the framework's, is resolved once when the frame is planned, and a setting the
    scene's frame does not use is refused there, naming the option."""
    add = parser.add_argument
    add("--particles", type=int, default=None,
        help="particle count (default: the scene's; 2^20 for the attractors, 2^17 for collision)")
    add("--size", default=None, help="image size WxH (default 1024x1024)")
    add("--format", default=None, choices=["rgba8", "rgba16f", "rgba32f", "auto"],
        help="state storage format (default rgba8: 16-bit packed; auto: the most precise one "
             "the context can render to)")
    add("--rounding", default=None, choices=["nearest", "dither"],
        help="rounding of packed state (default: dither for stateful de Jong and collision, "
             "nearest for reseeded de Jong)")
    add("--gradient", default=None,
        help="ramp: a name (inferno, ice, viridis, gold, grey), colours '#000,#f80,#fff', a PNG "
             "path, or 'none' to switch the gradient map off (default inferno)")
    add("--no-bloom", action="store_true", help="switch bloom off")
    add("--bloom-threshold", type=float, default=None,
        help="bloom luminance threshold [0, 1] (default 0.2)")
    add("--bloom-radius", type=float, default=None, help="bloom blur sigma [0.5, 4] (default 3)")
    add("--bloom-intensity", type=float, default=None,
        help="bloom strength [0, 10] (default 0.8)")
    add("--exposure", type=float, default=None, help="tone curve brightness (default 4)")
    add("--point-size", type=float, default=None,
        help="point diameter in pixels (default: the scene's; 1 for the attractors, 2 for "
             "collision)")
    add("--intensity", type=float, default=None,
        help="density each particle adds, in [0, 1e6] (default 1)")
    add("--seed", type=int, default=None, help="seed of the starting state (default 0)")
    add("--steps", type=int, default=None,
        help="simulation steps before the (first) frame (default: the scene's)")
    add("--accumulate", type=int, default=None,
        help="samples summed into each image of a density scene: this step's density and the "
             "next K-1 steps' (reseeded attractors shift their grid for each); smoother, "
             "1 / sqrt(K) the noise (default 1)")
    if command == "export":
        add("--out", required=True, help="the page: an .html file")
    if command == "run":
        add("--out", required=True,
            help="output: .png image, or with --frames .webp/.gif/.png, or .mp4 (the video extra)")
        add("--frames", type=int, default=1, help="frames of an animation (default 1: a still)")
        add("--steps-per-frame", type=int, default=1, help="steps between frames (default 1)")
        add("--fps", type=float, default=30.0, help="animation frame rate (default 30)")
        add("--save-state", default=None, help="also write the decoded state to this .npz")
        add("--workers", type=int, default=None,
            help="run on a new local Dask cluster of this many worker processes, one GL context "
                 "each (the distributed extra): an animation's frames, or a still's shares of "
                 "particles, as tasks; the same bytes as one process")
        add("--scheduler", default=None,
            help="run on the Dask cluster of this scheduler address (tcp://host:8786), as "
                 "--workers does")


def run_of(args):
    """The :class:`~es2particles.run.Run` of the parsed arguments: the scene's own options,
    and only the frame settings the user typed (the others are the scene's or the framework's
    defaults, resolved once when the frame is planned)."""
    from .frame.settings import FrameSettings
    from .run import Run
    from .render.post import Bloom

    settings = {"particles": args.particles, "size": args.size, "format": args.format,
                "rounding": args.rounding, "steps": args.steps, "point_size": args.point_size,
                "intensity": args.intensity, "exposure": args.exposure,
                "accumulate": args.accumulate, "seed": args.seed}
    settings = {name: value for name, value in settings.items() if value is not None}
    if args.gradient is not None:
        settings["gradient"] = None if args.gradient == "none" else args.gradient
    bloom = (args.bloom_threshold, args.bloom_radius, args.bloom_intensity)
    if args.no_bloom:
        given = [name for name, value in zip(("--bloom-threshold", "--bloom-radius",
                                               "--bloom-intensity"), bloom) if value is not None]
        if given:
            from .errors import ParameterError

            raise ParameterError(f"--no-bloom switches bloom off: leave out {', '.join(given)}")
        settings["bloom"] = None
    elif any(value is not None for value in bloom):
        d = Bloom()
        settings["bloom"] = Bloom(*(d_value if value is None else value for value, d_value in
                                    zip(bloom, (d.threshold, d.radius, d.intensity))))
    options = {name: getattr(args, name) for name in args.scene_options}
    frames = dict(frames=args.frames, steps_per_frame=args.steps_per_frame, fps=args.fps) \
        if hasattr(args, "frames") else {}
    return Run(args.scene, options, FrameSettings(**settings), **frames)


def _plan(args):
    from .gl.egl import open_context

    run = run_of(args)
    scene = run.check()
    with open_context() as ctx:
        scene, pipeline = run.pipeline(ctx, scene)
        with pipeline:
            print(pipeline.describe())


def _export(args):
    from .errors import ParameterError
    from .export.page import page_plan, write_page
    from .io.output import check_output

    out = check_output(args.out, "--out", {".html": "HTML"})
    if getattr(args, "animate_to", None) is not None:
        raise ParameterError("--animate-to: a page has no frame count to animate over; move "
                             "its sliders instead")
    run = run_of(args)
    plan = page_plan(run.check(), run.settings)
    write_page(plan, out)
    passes = sum(1 for s in plan["stages"] if s["step"])
    print(f"wrote {out} ({out.stat().st_size / 2 ** 20:.1f} MiB: {run.scene}, "
          f"{plan['layout']['count']} particles, {passes} pass draws a step, "
          f"{len(plan['stages']) - passes} stages a frame; open it in a browser)")


def _run(args):
    import gc
    import time

    from .cluster import shares
    from .errors import ParameterError
    from .frame.settings import MAX_SIZE, parse_size
    from .gl.egl import open_context
    from .io.output import (ANIMATION_SUFFIXES, IMAGE_SUFFIXES, AnimationWriter, check_output,
                            check_video, save_image, save_state)
    from .io.progress import progress

    gc.enable()  # console_main pauses collection while the modules come in
    start = time.perf_counter()
    run = run_of(args)
    frames = run.frames
    out = check_output(args.out, "--out", ANIMATION_SUFFIXES if frames > 1 else IMAGE_SUFFIXES)
    if frames > MAX_IMAGE_FRAMES and out.suffix.lower() != ".mp4":
        raise ParameterError(f"frames must be at most {MAX_IMAGE_FRAMES} for {out.suffix} "
                             f"(pillow holds every frame's file open); got {frames}: write .mp4 "
                             "for longer animations")
    state_path = None if args.save_state is None else check_output(args.save_state, "--save-state",
                                                                   {".npz": "NPZ"})
    _note_static_animation(args, frames)
    scene = run.check()
    if frames > 1:  # before any work: the video extra, even sides
        check_video(out, parse_size(run.settings.get("size", (1024, 1024)), MAX_SIZE))
    sizes = shares.share_sizes(run, save_state=args.save_state is not None)
    if args.workers is not None or args.scheduler is not None:
        where = _run_on_cluster(args, run, out, sizes)
        print(f"wrote {out} ({args.size or 'default size'}, {frames} frame(s)"
              + (f", {args.particles} particles in {len(sizes)} shares" if sizes else "")
              + f") in {time.perf_counter() - start:.2f} s {where}")
        return
    with open_context() as ctx:
        if sizes is not None:
            save_image(shares.still(ctx, run, sizes), out)
            print(f"wrote {out} ({args.size or 'default size'}, {args.particles} particles in "
                  f"{len(sizes)} shares of at most {shares.SHARE}) in "
                  f"{time.perf_counter() - start:.2f} s")
            return
        scene, pipeline = run.pipeline(ctx, scene)
        with pipeline:
            _note_sparse(pipeline)
            drawn = pipeline.frames(frames, run.steps_per_frame, warm_up=_warm_up)
            if frames == 1:
                next(drawn)
                save_image(pipeline.image(), out)
            else:
                with AnimationWriter(out, run.fps) as writer:  # frames stream out: bounded memory
                    for _ in progress(drawn, frames, "frames"):
                        writer.add(pipeline.image())
                    if out.suffix.lower() != ".mp4":  # the assembly takes a while: say so
                        print(f"es2particles: assembling {frames} frames into {out}",
                              file=sys.stderr)
                    writer.close()
            if state_path is not None:
                save_state(pipeline.state(), state_path)
            has_density = "density" in pipeline.plan.resources
            print(f"wrote {out} ({pipeline.size[0]}x{pipeline.size[1]}, {pipeline.sim.count} "
                  f"particles, {pipeline.sim.steps_done} steps, {frames} frame(s)) in "
                  f"{time.perf_counter() - start:.2f} s"
                  + (f"; density target {pipeline.plan.resources['density'].format}"
                     if has_density else ""))


def _run_on_cluster(args, run, out, sizes):
    """Run the command on Dask (``cluster/tasks.py``), a still in shares of ``sizes`` particles
    (None: one pipeline); returns where it ran, for the last line."""
    from .cluster import tasks
    from .errors import CapabilityError, ParameterError, check_range

    if args.workers is not None and args.scheduler is not None:
        raise ParameterError("give --workers (a new local cluster) or --scheduler (a running "
                             "one), not both")
    if args.workers is not None:
        check_range("workers", args.workers, 1, 1024, integer=True)
    if args.save_state is not None:
        raise ParameterError("--save-state writes one process's state: leave out --workers and "
                             "--scheduler to save it")
    missing = tasks.available()
    if missing:
        raise CapabilityError(missing)
    client = tasks.connect(workers=args.workers, scheduler=args.scheduler)
    try:
        count = tasks.workers(client)
        if run.frames == 1:
            tasks.still(client, run, out, sizes)
        else:
            tasks.animation(client, run, out)
    finally:
        tasks.close(client)
    return (f"on {count} local worker(s)" if args.scheduler is None
            else f"on {count} worker(s) of {args.scheduler}")


if __name__ == "__main__":
    console_main()
