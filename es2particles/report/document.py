"""``es2particles report``: error against run time per scene and format, the collision scene's
error against time step, and the stability suite, written as REPORT.md with PNG charts.

``--quick`` runs a small sweep (about a minute on Mesa llvmpipe, 2 cores); the full sweep goes to
2^20 particles and dt = 2^-13 (tens of minutes there).
"""

import datetime
import os
import platform
from pathlib import Path

import numpy as np

from . import charts
from . import measure
from . import stability
from ..io.output import OutputGroup, make_folders, remove_made_folders, write_atomic
from ..io.progress import progress
from ..io.signals import signals_deferred

QUICK = {"dejong_n": (10, 14, 16), "collision_n": (10, 12), "dt_k": range(4, 11),
         "horizon": 0.25, "cycles": (2 ** 14, 400), "largest": False}
FULL = {"dejong_n": (10, 12, 14, 16, 18, 20), "collision_n": (10, 12, 14, 16), "dt_k": range(4, 14),
        "horizon": 0.5, "cycles": (2 ** 18, 2000), "largest": True}
STATE_CONFIGS = (("rgba8", "nearest"), ("rgba8", "dither"), ("rgba16f", "nearest"),
                 ("rgba32f", "nearest"))
# de Jong also as it runs: its position 32-bit packed in RGBA8 (the others keep it 16-bit there)
DEJONG_CONFIGS = STATE_CONFIGS + (("rgba8_32", "nearest"),)


def _series(fmt, rounding):
    return f"{fmt} {rounding}" if fmt == "rgba8" else fmt


def run(ctx, out, quick=True):
    """Run the sweeps and the suite; write REPORT.md and charts into ``out``; return its path.

    The folder is made at once (with any missing parents); the files land together at the end,
    REPORT.md last. Interrupted or failing, the report leaves nothing: no file of its own, and
    the folders it made are removed where empty (a folder that was there keeps what it held)."""
    out = Path(out)
    made = []
    try:
        with signals_deferred():  # an interrupt comes once made names the folders
            made = make_folders(out)
        with OutputGroup(out / "REPORT.md", folder=out):
            return _sweep_and_write(ctx, out, quick)
    except BaseException:
        remove_made_folders(made)
        raise


def _sweep_and_write(ctx, out, quick):
    settings = QUICK if quick else FULL
    configs = [(f, r) for f, r in STATE_CONFIGS if ctx.caps.renderable.get(f)]
    dejong_configs = [(f, r) for f, r in DEJONG_CONFIGS if ctx.caps.renderable.get(f)]
    jobs = ([("dejong", f, r, 2 ** n) for f, r in dejong_configs for n in settings["dejong_n"]]
            + [("collision", f, r, 2 ** n) for f, r in configs for n in settings["collision_n"]]
            + [("dt", f, r, k) for f, r in configs for k in settings["dt_k"]]
            + [("suite", None, None, None)])
    dejong_rows, collision_rows, dt_rows, cases = [], [], [], []
    for kind, fmt, rounding, size in progress(jobs, len(jobs), "report", unit="job"):
        if kind == "dejong":
            row = measure.dejong_row(ctx, fmt, size, rounding)
            dejong_rows.append({**row, "series": _series(fmt, rounding)})
        elif kind == "collision":
            row = measure.collision_row(ctx, fmt, size, rounding)
            collision_rows.append({**row, "series": _series(fmt, rounding)})
        elif kind == "dt":
            row = measure.collision_dt_row(ctx, fmt, rounding, size, settings["horizon"])
            dt_rows.append({**row, "series": _series(fmt, rounding)})
        else:
            cases, stiff_curves, cycles = _suite(ctx, settings)
    return _write(ctx, out, quick, dejong_rows, collision_rows, dt_rows, cases, stiff_curves, cycles)


def _suite(ctx, settings):
    cases = [stability.stiff_drag(ctx, k) for k in (0.1, 1.0, 10.0, 100.0)]
    cases += [stability.stiff_spring(ctx, w) for w in (0.1, 1.0, 10.0)]
    cases.append(stability.thin_wall(ctx))
    cases.append(stability.range_limits(ctx))
    cases += [stability.non_finite(ctx, f) for f in ("rgba16f", "rgba32f")
              if ctx.caps.renderable.get(f)]
    cases += [stability.dejong_extreme(ctx, c) for c in
              ((0.0, 0.0, 0.0, 0.0), (1e-6, -1e-6, 1e-6, -1e-6), (10.0, -10.0, 10.0, -10.0))]
    cases += stability.sizes(ctx, settings["largest"])
    cycle_cases, figures, floor = stability.grid_cycles(ctx, *settings["cycles"])
    cases += cycle_cases
    cases.append(stability.tiny_increments(ctx))
    cases += [case(ctx) for case in stability.NUMERICS.values()]
    return cases, _stiff_curves(ctx), (figures, floor, settings["cycles"])


def _stiff_curves(ctx):
    """Speed under drag (k dt = 10) and spring energy (omega dt = 1.5), GPU against explicit
    Euler, for the side-by-side chart."""
    steps = np.arange(1, 11)
    drag = stability.run_particles(ctx, stability.free_scene(drag=600.0), np.zeros((2, 2)),
                                np.array([[4.0, -3.0]] * 2), 10)
    # Log axes: an exact 0 (a speed below half a code rounds to zero) is drawn at the axis floor.
    drag_default = [max(np.hypot(*v.T).max(), charts.LOG_FLOOR) for _, v in drag]
    drag_euler = 5.0 * np.abs(1 - 10.0) ** steps
    drag_exact = np.maximum(5.0 * np.exp(-10.0 * steps), charts.LOG_FLOOR)
    drag_floor = 8 / 65024  # half a code of each velocity component, |v| of the nearest codes
    omega = 1.5 * 60
    spring = stability.run_particles(ctx, stability.free_scene(spring=(0.0, 0.0, omega ** 2)),
                                  np.array([[0.04, 0.0]] * 2), np.zeros((2, 2)), 10)
    e0 = 0.5 * omega ** 2 * 0.04 ** 2
    spring_default = [np.max(0.5 * np.sum(v * v, 1) + 0.5 * omega ** 2 * np.sum(x * x, 1)) / e0
                      for x, v in spring]
    spring_euler = (1 + 1.5 ** 2) ** steps
    return [("drag, k dt = 10", steps, drag_default, drag_euler, drag_exact, drag_floor, "speed"),
            ("spring, omega dt = 1.5", steps, spring_default, spring_euler, np.ones(len(steps)),
             None, "energy / start")]


def _table(rows, columns):
    head = "| " + " | ".join(title for title, _, _ in columns) + " |"
    rule = "|" + "---|" * len(columns)
    body = ["| " + " | ".join(fmt(r[key]) for _, key, fmt in columns) + " |" for r in rows]
    return "\n".join([head, rule] + body)


def _ms(value):
    return f"{value * 1e3:.2f}"


def _sci(value):
    return f"{value:.2e}"


def _write(ctx, out, quick, dejong_rows, collision_rows, dt_rows, cases, stiff_curves, cycles):
    caps = ctx.caps
    lines = [
        "# es2particles report", "",
        f"- Renderer: {caps.renderer} ({caps.version}), back-end {caps.backend}",
        f"- Machine: {platform.platform()}, {os.cpu_count()} CPU cores, Python "
        f"{platform.python_version()}, numpy {np.__version__}",
        f"- Date: {datetime.datetime.now().astimezone().isoformat(timespec='seconds')}",
        f"- Sweep: {'quick (--quick)' if quick else 'full'}. Times are medians of 5 repeats after a "
        "warm-up, GPU finished inside each timing; errors are against float64 numpy.", "",
    ]
    findings = _findings(dejong_rows, dt_rows)
    lines += ["## Main finding", ""] + findings + [""]
    chart_note = []
    have_charts = charts.available()
    fitted = _fitted_order(dt_rows)
    if have_charts:
        charts.work_precision(dejong_rows, "step_s", "max_error", out / "dejong_work_precision.png",
                              "de Jong: one-step error against step time", "step time (s)",
                              "max one-step error (world units)")
        charts.work_precision(dejong_rows, "frame_s", "density_tv_20", out / "dejong_density.png",
                              "de Jong: density distance to float64 after 20 steps",
                              "frame time with rendering (s)", "64x64 density TV distance",
                              floor_key="density_floor")
        charts.work_precision(collision_rows, "step_s", "median_error",
                              out / "collision_work_precision.png",
                              "collision: storage error at 0.25 s (float64 twin, same dt)",
                              "step time (s)", "median position error vs float64, same dt")
        charts.error_against_dt(dt_rows, out / "collision_dt.png", fitted)
        charts.stiff(stiff_curves, out / "stiff.png")
    else:
        chart_note = ["Charts were skipped: matplotlib is not installed. Install the extra with "
                      "`pip install \"es2particles[report]\"` (or `pip install matplotlib`) and run "
                      "the report again.", ""]
    lines += chart_note
    lines += ["## de Jong: error against run time", ""]
    if have_charts:
        lines += ["![work-precision](dejong_work_precision.png)", "",
                  "![density](dejong_density.png)", ""]
    lines += [_table(dejong_rows, [
        ("state", "series", str), ("N", "N", str), ("step ms", "step_s", _ms),
        ("frame ms", "frame_s", _ms), ("max one-step error", "max_error", _sci),
        ("RMS one-step error", "rms_error", _sci), ("density TV after 20 steps", "density_tv_20",
                                                    lambda v: f"{v:.4f}"),
        ("noise floor", "density_floor", lambda v: f"{v:.4f}")]), ""]
    lines += ["## Collision: error against run time", "",
              "Short horizon (15 steps, 0.25 s) against the float64 twin at the same dt, with "
              "objects: what the storage format and float32 arithmetic cost, nothing else; "
              "deepest penetration below a surface (one cell = 0.0078); relative energy drift "
              "over the 15 steps with r = 1, s = 1, no drag, no emitter (negative: lost). The max "
              "error is a few particles whose contact went another way than in float64.", ""]
    if have_charts:
        lines += ["![collision](collision_work_precision.png)", ""]
    lines += [_table(collision_rows, [
        ("state", "series", str), ("N", "N", str), ("step ms", "step_s", _ms),
        ("frame ms", "frame_s", _ms), ("median error", "median_error", _sci), ("max error", "max_error", _sci),
        ("deepest", "deepest", lambda v: f"{v:.4f}"),
        ("energy drift", "energy_drift", lambda v: f"{v:+.2e}")]), ""]
    lines += ["## Collision: error against time step", "",
              f"Free flight with drag 0.5 and gravity over {(QUICK if quick else FULL)['horizon']:g} s, "
              "against the exact path. Semi-implicit Euler is first order: "
              f"fitted order on float32 state = {fitted:.2f} (theory: 1).", ""]
    lines += _floors(dt_rows)
    if have_charts:
        lines += ["![dt sweep](collision_dt.png)", ""]
    lines += [_table(sorted(dt_rows, key=lambda r: (r["series"], -r["dt"])), [
        ("state", "series", str), ("dt", "dt", lambda v: f"2^{int(round(np.log2(v)))}"),
        ("error", "error", _sci), ("run ms", "run_s", _ms)]), ""]
    lines += ["## Stability suite", ""]
    if have_charts:
        lines += ["Default integration (exact drag; sub-stepped symplectic Euler for the spring) "
                  "against explicit Euler:", "", "![stiff](stiff.png)", ""]
    lines += ["| case | measured | bound | result |", "|---|---|---|---|"]
    lines += ["| " + " | ".join(str(cell).replace("|", "\\|") for cell in c.row()) + " |"
              for c in cases]
    lines += [""]
    # A temporary file at a random name, renamed onto REPORT.md: a symlink there is replaced,
    # never followed, and a failure leaves no part file (the fixed ".REPORT.md.part" could be
    # a link pointing anywhere).
    text = "\n".join(lines) + "\n"
    return write_atomic(out / "REPORT.md", lambda tmp: Path(tmp).write_text(text))


def _fitted_order(dt_rows):
    rows = [r for r in dt_rows if r["series"] == "rgba32f"]
    if len(rows) < 3:
        return float("nan")
    return measure.fitted_order([r["dt"] for r in rows], [r["error"] for r in rows])


def _floors(dt_rows):
    lines = []
    for series in sorted({r["series"] for r in dt_rows}):
        rows = sorted((r for r in dt_rows if r["series"] == series), key=lambda r: -r["dt"])
        best = min(rows, key=lambda r: r["error"])
        smallest = rows[-1]
        where = ("at the smallest dt tried" if best is smallest else
                 f"below it the error rises again, to {smallest['error']:.2e} at "
                 f"dt = 2^{int(round(np.log2(smallest['dt'])))}")
        lines.append(f"- {series}: error floor {best['error']:.2e} at dt = "
                     f"2^{int(round(np.log2(best['dt'])))}; {where}.")
    return lines + [""]


def _findings(dejong_rows, dt_rows):
    """Only differences larger than their noise floor: one-step errors (deterministic), density
    distances against the float64-vs-float64 floor, the dt sweep's floors per format."""
    out = []
    by = {}
    for r in dejong_rows:
        by.setdefault(r["N"], {})[r["series"]] = r
    n = max(by)
    row = by[n]
    if "rgba8 nearest" in row:
        base = row["rgba8 nearest"]
        for name, r in row.items():
            if name == "rgba8 nearest":
                continue
            out.append(f"- de Jong at N = {n}: {name} costs {r['step_s'] / base['step_s']:.2f}x "
                       f"the step time of rgba8 (nearest) for {r['max_error'] / base['max_error']:.2g}x "
                       f"its one-step error ({r['max_error']:.2e} against {base['max_error']:.2e}).")
        floor = base["density_floor"]
        above = {name: r["density_tv_20"] for name, r in row.items()
                 if r["density_tv_20"] > 1.5 * floor}
        if above:
            out.append(f"- de Jong density after 20 steps, N = {n}: above the sampling floor "
                       f"({floor:.4f}, float64 against float64): "
                       + "; ".join(f"{k} {v:.4f}" for k, v in above.items()) + ".")
        else:
            out.append(f"- de Jong density after 20 steps, N = {n}: every format is within the "
                       f"sampling floor ({floor:.4f}, float64 against float64): at this size the "
                       "density cannot tell the formats apart.")
    floors = {}
    for r in dt_rows:
        cur = floors.get(r["series"])
        if cur is None or r["error"] < cur["error"]:
            floors[r["series"]] = r
    if floors:
        out.append("- Collision, smooth case: the smallest error each format reaches — "
                   + "; ".join(f"{s} {r['error']:.1e} (dt 2^{int(round(np.log2(r['dt'])))})"
                               for s, r in sorted(floors.items())) + ".")
    return out
