"""Where the seconds of one `es2particles run` go: run as a script with the command's arguments
(``python benchmarks/startup.py run dejong --reseed ... --out x.png``), it walks the path of
``es2particles.cli`` stage by stage and prints the seconds of each as JSON on stdout.

Stages: imports (the CLI module and what it imports), parser (the scene's options), context (EGL),
probe (the format probe), compiles (every shader program the pipeline links), set-up (the rest of
building the pipeline: textures, buffers, uniforms), steps, first frame (draw and post, finished),
readback and PNG. The interpreter's own start is timed by the bench around the process.
"""

import gc
import json
import sys
import time

marks = {}
clock = time.perf_counter()


def mark(stage):
    global clock
    now = time.perf_counter()
    marks[stage] = marks.get(stage, 0.0) + now - clock
    clock = now


def main(argv):
    gc.disable()  # as console_main: no collection while the modules come in
    import es2particles.cli as cli
    from es2particles.gl import context as context_module
    from es2particles.gl.egl import open_context
    from es2particles.io.output import save_image
    mark("imports")

    args = cli.build_parser(argv).parse_args(argv)
    mark("parser")

    compiled = [0.0]
    compile_program = context_module.compile_program

    def timed_compile(*a, **k):
        start = time.perf_counter()
        try:
            return compile_program(*a, **k)
        finally:
            compiled[0] += time.perf_counter() - start
    context_module.compile_program = timed_compile

    gc.freeze()  # as _run: what start-up made is frozen out of collection, which resumes
    gc.enable()
    run = cli.run_of(args)
    scene = run.check()
    with open_context() as ctx:
        mark("context")
        ctx.caps
        mark("probe")
        scene, pipeline = run.pipeline(ctx, scene)
        with pipeline:
            mark("set-up")
            marks["set-up"] -= compiled[0]
            marks["compiles"] = compiled[0]
            pipeline.begin(1, cli._warm_up)
            ctx.finish()
            mark("steps")
            pipeline.render()
            ctx.finish()
            mark("first frame")
            marks["compiles"] = compiled[0]  # a post program may link at its first use
            image = pipeline.image()
            mark("readback")
            save_image(image, args.out)
            mark("PNG")
    print(json.dumps(marks))


if __name__ == "__main__":
    main(sys.argv[1:])
