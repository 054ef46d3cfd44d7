"""How a frame's cost grows, stage by stage, for every scene (issue #29, item 4).

Run: ``python benchmarks/growth.py`` (or ``python benchmarks/bench.py --scenes growth``).
Options: ``--scenes dejong,smoke`` (default: the seven built-in scenes), ``--quick`` (three
small points a sweep), ``--repeats 3``, ``--budget 60`` (seconds one particle count may take,
predicted from the counts before it; half of it for an image or sprite size), ``--plots
docs/benchmarks`` (a figure per scene, written there), ``--load out/bench/growth.json``
(tables and plots from a run's numbers, nothing measured; of several files, comma-separated,
each scene's from the last that has it).

For each scene, through the public :class:`~es2particles.frame.pipeline.Pipeline` with the
scene's defaults otherwise, one frame is timed stage by stage: the simulation step, each kind
of frame stage the plan has (sort, shadow map, meshes, points, sprites or quads, post) and the
readback of the picture, each with ``ctx.finish()`` inside the timing, the median of
``--repeats`` after a warm-up (one after it, for a stage whose warm-up took over 2 s), the
stages timed in turn, round by round. Three sweeps:

- particles, 2^10 to 2^24 in steps of 4x, at the scene's default image size;
- image size, 256x256 to 4096x4096, at 2^16 particles (a sprite's size is given per 1024 rows,
  so sprites grow with the image and the picture keeps its look);
- point or sprite size (``point_size``), 1 to 64, at 2^16 particles and 1024x1024, for the
  scenes that have one (the confetti's quads have none).

A sweep stops where the next size would need more than 3 GiB (the plan's memory estimate) or
more than its budget (``--budget`` seconds for a particle count, half for an image or sprite
size; predicted as the last size's time, grown as from the size before it), and the output
says which sizes were left out and why.

The particles are in their steady state when timed: the attractors run their 20 warm-up
steps; the 2D collision is seeded by ``collision_steady`` (every particle alive,
spread over the scene; its candidates drawn 2^20 at a time, where bench's one draw peaks at
5.3 GiB at 2^24); an emitter scene (fountain, collision3d, confetti, smoke) runs its own
warm-up (one longest lifetime) once at 2^16 particles, and every count takes that state's
texels, repeated (2^22 particles are 64 copies of each warmed one) or cut, with its step
number: the 240 warm-up steps at 2^22 alone would take minutes here.

Each curve is fitted in log-log (:func:`fit`): its exponent (the slope of one line) and a
two-segment fit whose bend is reported where it is clearly better (:data:`BEND_RULE`). Tables
are printed and written as Markdown to ``out/bench/growth.md``, the numbers to
``out/bench/growth.json``. Timings are benchmark output: no test holds them to a threshold.
"""

import argparse
import json
import sys
import time
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

SCENES = ("dejong", "clifford", "collision", "fountain", "collision3d", "confetti", "smoke")
MID = 2 ** 16  # the particles of the image and sprite sweeps, and the emitters' warmed state
SWEEPS = {  # name -> (axis label, the values, the quick run's)
    "particles": ("particles (1024x1024)", [2 ** k for k in range(10, 25, 2)],
                  [2 ** 10, 2 ** 12, 2 ** 14]),
    "image": ("image side, px (2^16 particles)", [256, 512, 1024, 2048, 4096], [256, 512, 1024]),
    "sprite": ("point_size, px (2^16, 1024x1024)", [1, 2, 4, 8, 16, 32, 64], [1, 4, 16]),
}
TITLES = {"particles": "Against particles, at 1024x1024",
          "image": "Against the image side, at 2^16 particles",
          "sprite": "Against point_size, at 2^16 particles and 1024x1024"}
MEMORY_CAP = 3 * 2 ** 30
# Stage kinds (plan.py: Stage.kind) timed together under one name; the others under their own.
KIND_NAMES = {"sort key": "sort", "sort merge": "sort", "shadow map": "shadow"}
TOTAL = "frame (sum)"

# --- fitting (pure numpy: tests/test_growth_fit.py runs it with no GL) --------------------------

# A bend is reported only where the curve grows and one line clearly misses it while two
# segments do not: the exponent is at least 0.2 (a flat curve, a fixed cost, has no growth to
# bend: its wiggles are noise, 20-40% on a stage of a millisecond or two here), the line's RMS
# residual is at least 10% (above the run-to-run noise of these medians), the two segments cut
# the residual sum of squares at least 4-fold (RMS halved), and the slopes differ by at least
# 0.3. Five points at least: fewer leave the two segments' four numbers no test.
BEND_RULE = dict(exponent=0.2, line_rms=0.10, rss_ratio=4.0, slope_change=0.3, points=5)


@dataclass
class Fit:
    """A curve's fit in log-log: ``exponent``, the slope of one least-squares line; ``bend``
    (None where :data:`BEND_RULE` finds none), the x where two joined segments meet, with
    their slopes ``before`` and ``after`` (given where there is a bend); ``line_rms`` and
    ``hinge_rms``, the RMS residuals (natural log) of the line and of the two segments."""

    exponent: float
    bend: float = None
    before: float = None
    after: float = None
    line_rms: float = 0.0
    hinge_rms: float = None


def hinge(x, y, candidates=2001):
    """The best two-segment line joined at a knot (continuous, in the logs ``x``, ``y``): the
    knot is searched on a grid between the second and the second-to-last x, so each segment
    holds two points at least. Returns (knot, before, after, residual sum of squares)."""
    best = None
    for knot in np.linspace(x[1], x[-2], candidates):
        a = np.column_stack([np.ones_like(x), np.minimum(x - knot, 0), np.maximum(x - knot, 0)])
        coef = np.linalg.lstsq(a, y, rcond=None)[0]
        rss = float(np.sum((a @ coef - y) ** 2))
        if best is None or rss < best[3]:
            best = (float(knot), float(coef[1]), float(coef[2]), rss)
    return best


def fit(xs, times, rule=BEND_RULE):
    """The :class:`Fit` of ``times`` against ``xs`` (both positive) in log-log."""
    x, y = np.log(np.asarray(xs, float)), np.log(np.asarray(times, float))
    slope, intercept = np.polyfit(x, y, 1)
    rss_line = float(np.sum((intercept + slope * x - y) ** 2))
    result = Fit(exponent=float(slope), line_rms=float(np.sqrt(rss_line / len(x))))
    if len(x) < rule["points"]:
        return result
    knot, before, after, rss = hinge(x, y)
    result.hinge_rms = float(np.sqrt(rss / len(x)))
    if (slope >= rule["exponent"] and result.line_rms >= rule["line_rms"]
            and rss_line >= rule["rss_ratio"] * max(rss, 1e-300)
            and abs(after - before) >= rule["slope_change"]):
        result.bend, result.before, result.after = float(np.exp(knot)), before, after
    return result


# --- measuring ----------------------------------------------------------------------------------

@dataclass
class Curve:
    """One scene's stage against one sweep: ``xs`` and the median (min, max) seconds."""

    scene: str
    stage: str
    sweep: str
    xs: list
    times: list
    low: list
    high: list

    def fit(self):
        return fit(self.xs, self.times)


def stage_groups(plan):
    """(name, kinds) of the frame's stage kinds, in the plan's order (sort key and merge are one
    'sort')."""
    groups = {}
    for stage in plan.frame_stages:
        groups.setdefault(KIND_NAMES.get(stage.kind, stage.kind), []).append(stage.kind)
    return [(name, tuple(dict.fromkeys(kinds))) for name, kinds in groups.items()]


def collision_steady(p, rng, chunk=2 ** 20):
    """Every particle alive, spread over the scene outside its shapes, with emission-like speeds
    and ages: the steady fountain's cost without the minutes of warm-up it takes at 2^22 on a
    CPU rasteriser. Candidate positions are drawn and tested ``chunk`` at a time (bench.py
    draws 3N at once; at 2^24 particles that peaks at 5.3 GiB of host memory)."""
    sim, scene = p.sim, p.scene
    n = sim.count
    kept, have = [], 0
    while have < n:
        x = rng.uniform(-0.95, 0.95, (chunk, 2))
        x = x[scene.field.exact_distance(x) > 0.01][: n - have]
        kept.append(x)
        have += len(x)
    angle = rng.uniform(0, 2 * np.pi, n)
    speed = rng.uniform(0.5, 3.0, n)
    life = rng.uniform(*scene.params.lifetime, n)
    sim.upload("position", np.concatenate(kept))
    sim.upload("velocity", np.stack([np.cos(angle), np.sin(angle)], 1) * speed[:, None])
    sim.upload("life", np.stack([rng.uniform(0, 1, n) * life, life], 1))


class Steady:
    """Puts a pipeline's particles in the scene's steady state (see the module's docstring)."""

    def __init__(self, ctx, name):
        self.ctx, self.name, self.texels, self.steps = ctx, name, None, 0
        self.emitter = name not in ("dejong", "clifford", "collision")

    def how(self):
        if not self.emitter:
            return ("its 20 warm-up steps" if self.name != "collision"
                    else "seeded by collision_steady (every particle alive), its "
                    "candidates drawn 2^20 at a time")
        return (f"its warm-up ({self.steps} steps) at 2^16, whose texels every count repeats "
                "or cuts")

    def apply(self, p):
        from es2particles.frame.pipeline import Pipeline
        from es2particles.scenes import scene_class

        if not self.emitter:
            if self.name == "collision":
                collision_steady(p, np.random.default_rng(0))
            else:
                p.warm_up()
            return
        if self.texels is None:
            with Pipeline(self.ctx, scene_class(self.name)(), MID) as warm:
                warm.warm_up()
                self.steps = warm.sim.steps_done
                self.texels = {q: b.read_texels() for q, b in warm.sim.buffers.items()}
        rows = np.arange(p.sim.count) % MID
        for q, buffer in p.sim.buffers.items():
            buffer.write_texels(self.texels[q][rows])
        p.sim.steps_done = self.steps


LONG = 2.0  # seconds: a stage whose warm-up call takes longer is timed once after it


def timed_rounds(parts, repeats):
    """{name: (median, min, max) seconds} of ``parts`` ((name, function, finish), ``finish``
    run inside each timing): a warm-up call of each, then ``repeats`` rounds of one call of
    each in turn, so that a burst of another process's work on this shared machine spoils one
    round of every part rather than every call of one. A part whose warm-up took over
    :data:`LONG` seconds is timed in the first round only (its noise is small against its
    time, and a sweep goes further in the same minutes)."""
    def clock(function, finish):
        start = time.perf_counter()
        function()
        finish()
        return time.perf_counter() - start

    first = {name: clock(function, finish) for name, function, finish in parts}
    times = {name: [] for name, _, _ in parts}
    for round_ in range(repeats):
        for name, function, finish in parts:
            if round_ == 0 or first[name] <= LONG:
                times[name].append(clock(function, finish))
    return {name: (float(np.median(t)), min(t), max(t)) for name, t in times.items()}


def measure(ctx, name, steady, repeats, **settings):
    """{stage: (median, min, max) seconds} of a frame of scene ``name`` under ``settings``, and
    the warnings the frame gave."""
    from bench import stages
    from es2particles.frame.pipeline import Pipeline, read_rgb
    from es2particles.scenes import scene_class

    finish = ctx.finish
    with warnings.catch_warnings(record=True) as caught, \
            Pipeline(ctx, scene_class(name)(), **settings) as p:
        warnings.simplefilter("always")
        steady.apply(p)
        camera = p.camera(0, 1)
        parts = [("step", lambda: p.step(1), finish)]
        parts += [(label, stages(p, *kinds, camera=camera), finish)
                  for label, kinds in stage_groups(p.plan)]
        # What Pipeline.image reads, the picture the stages drew: no whole frame more.
        parts.append(("readback", lambda: read_rgb(ctx, p.executor.front(p.plan.present)),
                      lambda: None))
        rows = timed_rounds(parts, repeats)
    return rows, sorted({str(w.message).split(":")[0] for w in caught})


def memory_need(ctx, name, **settings):
    """The plan's memory estimate (bytes) of scene ``name`` under ``settings``, made with no GL
    objects."""
    from es2particles.frame import memory
    from es2particles.frame.pipeline import settings_of
    from es2particles.frame.plan import plan_frame
    from es2particles.scenes import scene_class

    return memory.estimate(plan_frame(scene_class(name)(), settings_of(**settings),
                                      ctx.caps)).total


def sweep(ctx, name, steady, which, values, repeats, budget, log=print):
    """Curves of scene ``name`` along sweep ``which``, and lines saying what was left out."""
    def settings(x):
        if which == "particles":
            return {"particles": x}
        if which == "image":
            return {"particles": MID, "size": (x, x)}
        return {"particles": MID, "size": (1024, 1024), "point_size": float(x)}

    done, walls, left_out = {}, [], []
    for i, x in enumerate(values):
        if len(walls) >= 2:
            predicted = walls[-1] * max(walls[-1] / walls[-2], 1.0)
            if predicted > budget:
                left_out.append(f"{label(which, x)} and up: predicted {predicted:.0f} s "
                                f"(the last size's {walls[-1]:.1f} s grown as from the one "
                                f"before it) > {budget:.0f} s")
                break
        need = memory_need(ctx, name, **settings(x))
        if need > MEMORY_CAP:
            left_out.append(f"{label(which, x)} and up: the plan's memory estimate "
                            f"{need / 2 ** 30:.1f} GiB > {MEMORY_CAP / 2 ** 30:.0f} GiB")
            break
        start = time.perf_counter()
        rows, said = measure(ctx, name, steady, repeats, **settings(x))
        walls.append(time.perf_counter() - start)
        done[x] = rows
        log(f"  {name} {which} {label(which, x)}: {walls[-1]:.1f} s, peak "
            f"{peak_memory() / 2 ** 30:.1f} GiB; "
            + ", ".join(f"{k} {v[0] * 1e3:.1f}" for k, v in rows.items())
            + (f" (warned: {'; '.join(said)})" if said else ""))
        if said:
            left_out.append(f"{label(which, x)} warned: {'; '.join(said)}")
    curves = []
    if done:
        xs = list(done)
        names = list(dict.fromkeys(k for rows in done.values() for k in rows))
        for stage in names:
            t = [done[x][stage] for x in xs]
            curves.append(Curve(name, stage, which, xs, [v[0] for v in t], [v[1] for v in t],
                                [v[2] for v in t]))
        total = [sum(done[x][s][0] for s in names) for x in xs]
        curves.append(Curve(name, TOTAL, which, xs, total, total, total))
    return curves, left_out


def peak_memory():
    """This process's peak resident memory so far, bytes."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def label(which, x):
    if which == "particles":
        return f"2^{int(np.log2(x))}"
    return f"{x}" if which == "sprite" else f"{x}^2"


def run(ctx, scenes, quick, repeats, budget, log=print):
    """Every sweep of every scene in ``scenes``: (curves, {scene: notes})."""
    from es2particles.frame.pipeline import Pipeline
    from es2particles.scenes import scene_class

    curves, notes = [], {}
    for name in scenes:
        start = time.perf_counter()
        steady = Steady(ctx, name)
        with Pipeline(ctx, scene_class(name)(), 2 ** 10) as p:
            sized = "point_size" in p.plan.rendering.settings
        scene_notes = []
        for which, (_, values, quick_values) in SWEEPS.items():
            if which == "sprite" and not sized:
                scene_notes.append("sprite: no point_size (the rendering takes none)")
                continue
            found, left = sweep(ctx, name, steady, which, quick_values if quick else values,
                                repeats, budget if which == "particles" else budget / 2, log)
            curves += found
            scene_notes += [f"{which}: {line}" for line in left]
        scene_notes.insert(0, f"steady state: {steady.how()}; "
                              f"{time.perf_counter() - start:.0f} s for the scene")
        notes[name] = scene_notes
        log(f"{name}: {time.perf_counter() - start:.0f} s")
    return curves, notes


# --- tables and plots ---------------------------------------------------------------------------

def fmt_x(which, x):
    if which == "particles":
        return f"2^{np.log2(x):.1f}".replace(".0", "") if x else "-"
    return f"{x:.0f}" if which == "sprite" else f"{x:.0f}^2"


def fmt_ms(t):
    ms = t * 1e3
    return f"{ms:.3g}" if ms < 100 else f"{ms:.0f}"


def tables(curves, notes, emit=print):
    """Markdown: a table per scene and sweep (milliseconds at each x, the exponent, the bend and
    the slopes either side), then the scene's notes."""
    for name in dict.fromkeys(c.scene for c in curves):
        emit(f"### {name}")
        emit()
        for which in SWEEPS:
            mine = [c for c in curves if c.scene == name and c.sweep == which]
            if not mine:
                continue
            xs = mine[0].xs
            emit(f"{TITLES[which]}, ms:")
            emit()
            emit("| stage | " + " | ".join(label(which, x) for x in xs)
                 + " | exponent | bend | slopes |")
            emit("|---" * (len(xs) + 4) + "|")
            for c in mine:
                f = c.fit()
                bend = "-" if f.bend is None else fmt_x(which, f.bend)
                slopes = "-" if f.bend is None else f"{f.before:.2f} -> {f.after:.2f}"
                emit(f"| {c.stage} | " + " | ".join(fmt_ms(t) for t in c.times)
                     + f" | {f.exponent:.2f} | {bend} | {slopes} |")
            emit()
        for line in notes.get(name, []):
            emit(f"- {line}")
        emit()


def summary(curves, emit=print):
    """Markdown: one row per curve that grows (exponent >= 0.2, or with a bend): its exponent
    and bend."""
    emit("| scene | stage | sweep | exponent | bend | slopes | top ms |")
    emit("|---|---|---|---|---|---|---|")
    for c in curves:
        f = c.fit()
        if f.exponent < 0.2 and f.bend is None:
            continue
        bend = "-" if f.bend is None else fmt_x(c.sweep, f.bend)
        slopes = "-" if f.bend is None else f"{f.before:.2f} -> {f.after:.2f}"
        emit(f"| {c.scene} | {c.stage} | {c.sweep} | {f.exponent:.2f} | {bend} | {slopes} | "
             f"{fmt_ms(c.times[-1])} at {label(c.sweep, c.xs[-1])} |")


# A stage's colour in every figure (the particles' draw, whatever its kind, in one).
COLOURS = {"step": "C0", "sort": "C1", "shadow": "C2", "mesh": "C7", "points": "C3",
           "sprites": "C3", "quads": "C3", "post": "C4", "readback": "C5", TOTAL: "black"}


def plots(curves, folder):
    """A figure per scene, written to ``folder/<scene>.png``: log-log, a panel per sweep, a line
    per stage (the frame's sum dashed), each bend marked."""
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for name in dict.fromkeys(c.scene for c in curves):
        sweeps = [w for w in SWEEPS if any(c.scene == name and c.sweep == w for c in curves)]
        fig, axes = plt.subplots(1, len(sweeps), figsize=(3.0 * len(sweeps), 2.6), dpi=80,
                                 sharey=True, squeeze=False)
        for ax, which in zip(axes[0], sweeps):
            for c in (c for c in curves if c.scene == name and c.sweep == which):
                ms = np.array(c.times) * 1e3
                colour = COLOURS.get(c.stage, "C6")
                ax.plot(c.xs, ms, marker="o", markersize=2.5, linewidth=1.2, color=colour,
                        linestyle="--" if c.stage == TOTAL else "-", label=c.stage)
                f = c.fit()
                if f.bend is not None:
                    ax.plot([f.bend], [np.exp(np.interp(np.log(f.bend), np.log(c.xs),
                                                        np.log(ms)))],
                            marker="x", markersize=6, color=colour)
            ax.set_xscale("log", base=2)
            if which != "particles":
                ax.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(
                    lambda v, _: f"{v:g}"))
            ax.set_yscale("log")
            ax.set_xlabel(SWEEPS[which][0].replace("2^16", "$2^{16}$"), fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(True, which="major", linewidth=0.3)
        axes[0][0].set_ylabel("ms", fontsize=8)
        handles, labels = axes[0][0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="upper center", ncol=len(labels), fontsize=7,
                   frameon=False)
        fig.suptitle(name, x=0.01, ha="left", fontsize=9)
        fig.tight_layout(rect=(0, 0, 1, 0.9))
        path = folder / f"{name}.png"
        fig.savefig(path, dpi=80)
        plt.close(fig)
        written.append(path)
    return written


# --- entry points -------------------------------------------------------------------------------

def write(curves, notes, wall, emit_lines):
    out = Path("out/bench")
    out.mkdir(parents=True, exist_ok=True)
    (out / "growth.md").write_text("\n".join(emit_lines) + "\n")
    (out / "growth.json").write_text(json.dumps(
        {"curves": [asdict(c) for c in curves], "notes": notes, "wall_s": wall}, indent=1))


def report(curves, notes, emit):
    emit("Exponents (log-log slope) and bends of every curve that grows (bend rule: "
         + ", ".join(f"{k} {v}" for k, v in BEND_RULE.items()) + "):")
    emit()
    summary(curves, emit)
    emit()
    tables(curves, notes, emit)


def growth_section(ctx, emit, quick=False, repeats=3, scenes=SCENES, budget=60.0):
    """The section ``bench.py --scenes growth`` runs: every sweep, its tables emitted and
    written to out/bench/growth.md (and the numbers to growth.json)."""
    import os

    start = time.perf_counter()
    lines = []

    def both(line=""):
        emit(line)
        lines.append(line)

    both(f"Renderer: {ctx.caps.renderer}; {os.cpu_count()} CPU cores; median of {repeats} "
         f"after a warm-up (1 where the warm-up took over {LONG:g} s), ctx.finish() inside "
         "each timing; ms")
    both()
    curves, notes = run(ctx, scenes, quick, repeats, budget,
                        log=lambda line: print(line, file=sys.stderr, flush=True))
    wall = time.perf_counter() - start
    report(curves, notes, both)
    both(f"Wall time of the measurements: {wall:.0f} s; the process's peak resident memory "
         f"{peak_memory() / 2 ** 30:.1f} GiB")
    write(curves, notes, wall, lines)
    return curves


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--budget", type=float, default=60.0)
    parser.add_argument("--plots", metavar="FOLDER")
    parser.add_argument("--load", metavar="JSON")
    args = parser.parse_args(argv)
    scenes = [s for s in args.scenes.split(",") if s]
    unknown = [s for s in scenes if s not in SCENES]
    if unknown:
        parser.error(f"unknown scene(s) {', '.join(unknown)} (scenes: {', '.join(SCENES)})")
    if args.load:
        # Several runs' numbers: each scene's from the last file that has it.
        curves, notes = {}, {}
        for path in args.load.split(","):
            data = json.loads(Path(path).read_text())
            for name, lines in data["notes"].items():
                curves[name] = [Curve(**c) for c in data["curves"] if c["scene"] == name]
                notes[name] = lines
        curves = [c for name in scenes for c in curves.get(name, [])]
        lines = [f"Tables from {args.load} (nothing measured):", ""]
        report(curves, notes, lambda line="": lines.append(line))
        print("\n".join(lines))
        out = Path("out/bench")
        out.mkdir(parents=True, exist_ok=True)
        (out / "growth.md").write_text("\n".join(lines) + "\n")
    else:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from es2particles import open_context

        with open_context() as ctx:
            curves = growth_section(ctx, print, args.quick, args.repeats, scenes, args.budget)
    if args.plots:
        for path in plots(curves, args.plots):
            print(f"wrote {path} ({path.stat().st_size / 1024:.0f} KiB)")


if __name__ == "__main__":
    main()
