"""The figures of a GPU run (issue 47), each written to RESULTS.md and results.json as soon as it
is measured, so a run cut short still leaves what it measured.

Run by ``benchmarks/gpu.sh`` (which sets up the machine first); alone: ``python
benchmarks/gpu_figures.py --out DIR [--dry-run] [--budget SECONDS]``. ``--dry-run`` measures
the same figures at sizes a CPU rasteriser finishes in minutes, and marks every figure so.

Each time is the median of a few frames or steps after a warm-up, with ``ctx.finish()`` inside
the timing: de Jong's frames a second at 2^20 and 2^24 particles, every scene's frame at its
defaults and at 2^20, the wind field's steps a second at 256^2 and 512^2 cells with 2^20
particles, sprites a second (the fountain at 2^20), the sort (the smoke's frame with and
without it), and the bytes a de Jong step reads and writes a second against the card's
memory bandwidth (a device-to-device copy through PyTorch where it is installed). A figure
that would outrun ``--budget`` seconds (predicted from the one before it) is left out, and
said so.
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from es2particles import open_context  # noqa: E402
from es2particles.errors import ContextError, Es2ParticlesError  # noqa: E402
from es2particles.frame.graph import scene_graph  # noqa: E402
from es2particles.frame.pipeline import Pipeline  # noqa: E402
from es2particles.frame.settings import DEFAULT  # noqa: E402
from es2particles.report.measure import median_time  # noqa: E402
from es2particles.scenes import BUILT_IN, scene_class  # noqa: E402

GOALS = {"dejong 2^20 frames/s": 1000, "dejong 2^24 frames/s": 60,
         "wind 256^2 2^20 steps/s": 240, "liquid 2^16 frames/s": 60}


class Results:
    """RESULTS.md and results.json in ``folder``, rewritten after every figure."""

    def __init__(self, folder, dry_run, header):
        self.folder, self.dry_run = Path(folder), dry_run
        self.folder.mkdir(parents=True, exist_ok=True)
        self.header, self.figures, self.notes = header, [], []
        self.write()

    def add(self, name, value, unit, how=""):
        goal = None if self.dry_run else GOALS.get(f"{name} {unit}")
        met = None if goal is None or value is None else value >= goal
        self.figures.append({"name": name, "value": value, "unit": unit, "how": how,
                             "goal": goal, "met": met})
        shown = "-" if value is None else f"{value:.4g}"
        print(f"{name}: {shown} {unit}" + (f" (goal {goal}: {'met' if met else 'not met'})"
                                           if goal is not None and value is not None else "")
              + (f" [{how}]" if how else ""), flush=True)
        self.write()

    def note(self, line):
        print(line, flush=True)
        self.notes.append(line)
        self.write()

    def write(self):
        mark = " (DRY RUN: llvmpipe-sized figures, not a GPU's)" if self.dry_run else ""
        lines = [f"# GPU results{mark}", ""] + [f"- {k}: {v}" for k, v in self.header.items()]
        lines += ["", "| figure | value | unit | goal | how |", "|---|---|---|---|---|"]
        for f in self.figures:
            goal = "" if f["goal"] is None else (f"{f['goal']} ({'met' if f['met'] else 'not met'})"
                                                 if f["met"] is not None else str(f["goal"]))
            value = "-" if f["value"] is None else f"{f['value']:.4g}"
            lines.append(f"| {f['name']} | {value} | {f['unit']} | {goal} | {f['how']} |")
        if self.notes:
            lines += ["", "Notes:", ""] + [f"- {n}" for n in self.notes]
        (self.folder / "RESULTS.md").write_text("\n".join(lines) + "\n")
        (self.folder / "results.json").write_text(json.dumps(
            {"dry_run": self.dry_run, "header": self.header, "figures": self.figures,
             "notes": self.notes}, indent=1) + "\n")


def log2(count):
    return f"2^{count.bit_length() - 1}"


def frame_seconds(ctx, scene, particles, size, repeats, steps=1, **settings):
    """Seconds of one frame: ``steps`` steps and a render, finished; ``settings``: Pipeline's."""
    with Pipeline(ctx, scene, particles=particles, size=size, steps=0, **settings) as pipeline:
        pipeline.begin(1)

        def frame():
            pipeline.step(steps)
            pipeline.render()
        return median_time(frame, ctx.finish, repeats)


def keeps_state(scene):
    """Whether ``scene`` keeps particles or grids (the noise flame keeps neither)."""
    return bool(scene.rendering().reads or scene_graph(scene, None).quantities)


def step_seconds(ctx, scene, particles, size, repeats):
    with Pipeline(ctx, scene, particles=particles, size=size, steps=0) as pipeline:
        pipeline.begin(1)
        return median_time(lambda: pipeline.step(1), ctx.finish, repeats)


def bandwidth():
    """The card's device-to-device copy rate, bytes a second (read + written), by PyTorch where
    it is installed and sees a GPU; None otherwise."""
    try:
        import torch
    except ImportError:
        return None
    if not torch.cuda.is_available():
        return None
    x = torch.empty(2 ** 30, dtype=torch.uint8, device="cuda")
    y = torch.empty_like(x)
    y.copy_(x)
    torch.cuda.synchronize()
    start = time.perf_counter()
    for _ in range(10):
        y.copy_(x)
    torch.cuda.synchronize()
    return 2 * 10 * x.numel() / (time.perf_counter() - start)


MAP = """
    vec2 p = (gl_FragCoord.xy - 0.5) * 1e-3;
    for (int i = 0; i < u_n; i++)
        p = vec2(sin(u_k.x * p.y) - cos(u_k.y * p.x), sin(u_k.z * p.x) - cos(u_k.w * p.y));
"""


def shader_rates(mgl, side, repeats, iterations=64):
    """Fragment against compute on this card: the same de Jong map ``iterations`` times a texel
    of a ``side``^2 rgba32f target, in a full-screen fragment pass and in a compute shader (GL
    4.3), and the fill rate of a pass that only writes. A plain GL 4.3 probe, outside the
    framework: it says what the card's fragment stage can do at all. Returns {name: seconds}."""
    head = "#version 430\nuniform int u_n; uniform vec4 u_k;\n"
    fragment = mgl.program(
        vertex_shader="#version 430\nin vec2 a; void main() { gl_Position = vec4(a, 0.0, 1.0); }",
        fragment_shader=head + "out vec4 color;\nvoid main() {" + MAP
        + "    color = vec4(p, 0.0, 1.0);\n}\n")
    compute = mgl.compute_shader(
        head + "layout(local_size_x = 16, local_size_y = 16) in;\n"
        "layout(rgba32f, binding = 0) writeonly uniform image2D u_out;\nvoid main() {"
        + MAP.replace("gl_FragCoord.xy - 0.5", "vec2(gl_GlobalInvocationID.xy)")
        + "    imageStore(u_out, ivec2(gl_GlobalInvocationID.xy), vec4(p, 0.0, 1.0));\n}\n")
    target = mgl.texture((side, side), 4, dtype="f4")
    fbo = mgl.framebuffer([target])
    vbo = mgl.buffer(np.array([-1, -1, 3, -1, -1, 3], "f4").tobytes())
    vao = mgl.vertex_array(fragment, [(vbo, "2f", "a")])
    for program in (fragment, compute):
        program["u_k"].value = (1.4, -2.3, 2.4, -2.1)
    seconds = {}
    try:
        for n in (0, iterations):
            fragment["u_n"].value = compute["u_n"].value = n

            def draw():
                fbo.use()
                fbo.viewport = (0, 0, side, side)
                vao.render()

            def dispatch():
                target.bind_to_image(0, read=False, write=True)
                compute.run(side // 16, side // 16)
            seconds[("fragment", n)] = median_time(draw, mgl.finish, repeats)
            seconds[("compute", n)] = median_time(dispatch, mgl.finish, repeats)
    finally:
        for thing in (vao, vbo, fbo, target, fragment, compute):
            thing.release()
    return seconds


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "benchmarks"))
    parser.add_argument("--dry-run", action="store_true")
    parser.add_argument("--budget", type=float, default=60.0)
    args = parser.parse_args(argv)
    dry = args.dry_run
    big, huge = (2 ** 14, 2 ** 16) if dry else (2 ** 20, 2 ** 24)
    size = (256, 256) if dry else (1024, 1024)
    repeats = 3 if dry else 7
    with open_context() as ctx:
        caps = ctx.caps
        commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                                capture_output=True, text=True).stdout.strip() or "unknown"
        changed = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain",
                                  "--untracked-files=no"], capture_output=True, text=True).stdout
        if changed.strip():  # a copied tree whose .git lags it (the device tool's) says so
            commit += " (the working tree differs from it)"
        header = {"renderer": caps.renderer, "GL version": getattr(caps, "version", ""),
                  "CPU cores": os.cpu_count(), "commit": commit,
                  "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                  "sizes": f"{size[0]}x{size[1]} frames; particles {big} and {huge}"}
        results = Results(args.out, dry, header)
        from es2particles.scenes.dejong import DeJong

        for count in (big, huge):
            seconds = frame_seconds(ctx, DeJong(), count, size, repeats)
            results.add(f"dejong {log2(count)}", 1 / seconds, "frames/s",
                        f"{count} particles, a step and a frame (density, tone map, bloom)")
        step = step_seconds(ctx, DeJong(), big, size, repeats)
        results.add(f"dejong step at {log2(big)}", step * 1e3, "ms a step",
                    f"{big} particles, 3 map iterations, rgba8 packed (the frame less its render)")
        bare = frame_seconds(ctx, DeJong(), big, size, repeats, bloom=None)
        results.add(f"dejong {log2(big)} without bloom", 1 / bare, "frames/s",
                    f"{big} particles, a step and a frame (density, tone map)")
        side = 1024 if dry else 4096
        try:
            rates = shader_rates(ctx.mgl, side, repeats)
        except Exception as error:  # noqa: BLE001 - a probe the card may not run (GL < 4.3)
            results.note(f"no fragment/compute probe: {type(error).__name__}: {error}")
        else:
            texels, work = side * side, side * side * 64
            results.add("fill, a fragment pass that only writes", texels / rates[("fragment", 0)]
                        / 1e9, "Gtexels/s", f"{side}^2 rgba32f, GL 4.3 outside the framework")
            results.add("fill, a compute shader that only writes", texels / rates[("compute", 0)]
                        / 1e9, "Gtexels/s", f"{side}^2 rgba32f image stores")
            frag = work / rates[("fragment", 64)]
            comp = work / rates[("compute", 64)]
            results.add("de Jong map in a fragment pass", frag / 1e9, "G maps/s",
                        f"64 iterations a texel, {side}^2 texels")
            results.add("de Jong map in a compute shader", comp / 1e9, "G maps/s",
                        f"the same arithmetic, {side}^2 invocations")
            results.note(f"the fragment stage runs the de Jong map at {frag / comp:.1%} of the "
                         "compute rate on this card (es2particles uses only fragment passes, "
                         "the ES 2.0 model)")
        scenes = [(name, scene_class(name), {}) for name in BUILT_IN]
        scenes.append(("flame from smoke", scene_class("flame"), {"source": "smoke"}))
        for name, cls, params in scenes:
            scene = cls(**params)
            if not keeps_state(scene):  # the noise flame: a frame has no count to vary
                seconds = frame_seconds(ctx, scene, DEFAULT, size, repeats)
                results.add(f"{name} frame", seconds * 1e3, "ms a frame",
                            "no particles or grid (its field is computed in the march)")
                continue
            defaults = min(scene.defaults.particles, huge if not dry else big)
            for count, label in ((defaults, "defaults"), (big, log2(big))):
                start = time.perf_counter()
                try:
                    seconds = frame_seconds(ctx, cls(**params), count, size, repeats)
                except Es2ParticlesError as refused:  # sph's count follows its spacing; a
                    results.note(f"{name} at {label}: {refused}")  # grid's keys bound cells
                    continue
                results.add(f"{name} frame at {label}", seconds * 1e3, "ms a frame",
                            f"{count} particles, a step and a frame")
                if time.perf_counter() - start > args.budget:
                    results.note(f"{name}: the next size would outrun the budget; left out")
                    break
        from es2particles.scenes.wind import Wind

        for cells in ((64, 128) if dry else (256, 512)):
            seconds = step_seconds(ctx, Wind(grid=f"{cells}x{cells}"), big, size, repeats)
            results.add(f"wind {cells}^2 {log2(big)}", 1 / seconds, "steps/s",
                        f"{cells}^2 cells, 40 pressure iterations, {big} particles")
        from es2particles.scenes.flame import Flame

        for cells in ((16, 32) if dry else (64, 128)):  # the wind flame's 3D air
            seconds = step_seconds(ctx, Flame(source="wind", cells=cells), DEFAULT, size,
                                   repeats)
            results.add(f"wind flame {cells}^3", 1 / seconds, "steps/s",
                        f"{cells}^3 cells of 3D air and its fire, 40 pressure iterations")
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from sampling import ours as sample_ms

        for dims in (2, 3):  # a grid's samples by hand and by the hardware's LINEAR filter
            points = np.random.default_rng(1).uniform(0, 64, (big, dims))
            hand, hardware = (sample_ms(ctx, dims, "rgba32f", s, points, repeats)
                              for s in ("hand", "hardware"))
            results.add(f"{dims}D samples hand / hardware", hand / hardware, "x",
                        f"{big} samples of a rgba32f grid: {hand:.2f} ms by hand, "
                        f"{hardware:.2f} ms by the hardware")
        from es2particles.scenes.liquid import Liquid

        seconds = frame_seconds(ctx, Liquid(), 2 ** 16, size, repeats)
        results.add(f"liquid {log2(2 ** 16)}", 1 / seconds, "frames/s",
                    "65536 particles, a step (two neighbour grids) and a frame")
        from es2particles.scenes.fountain import Fountain

        seconds = frame_seconds(ctx, Fountain(), big, size, repeats, steps=0)
        results.add("fountain sprites", big / seconds, "sprites/s", f"{big} sprites a frame")
        from es2particles.scenes.smoke import Smoke

        with_sort = frame_seconds(ctx, Smoke(), big // 4, size, repeats)
        results.add("smoke with its sort", with_sort * 1e3, "ms a frame",
                    f"{big // 4} particles, a step and a sorted frame")
        try:  # the OpenGL ES back-end against desktop GL, in this process (docs/backends.md)
            with open_context(backend="gles") as es:
                for name, scene, count in (("dejong", DeJong(), big),
                                           ("fountain", Fountain(), big // 4)):
                    on_gl = frame_seconds(ctx, scene, count, size, repeats)
                    on_es = frame_seconds(es, scene, count, size, repeats)
                    results.add(f"{name} frame ES / GL", on_es / on_gl, "x",
                                f"{count} particles, a step and a frame on each back-end")
        except ContextError as error:
            results.note(f"no OpenGL ES context, no ES / GL figures: {error}")
        step = step_seconds(ctx, DeJong(), huge, size, repeats)
        moved = huge * 4 * 2  # a position texel of 4 bytes (RGBA8), read and written
        rate = moved / step
        results.add("dejong step bytes", rate / 1e9, "GB/s", f"{huge} particles' state read "
                    "and written a step")
        copy = None if dry else bandwidth()
        if copy:
            results.add("device copy", copy / 1e9, "GB/s", "PyTorch device-to-device copy")
            results.note(f"the de Jong step moves its state at {rate / copy:.1%} of the copy rate")
        else:
            results.note("no device copy rate (no PyTorch with a GPU here)")


if __name__ == "__main__":
    main()
