"""Time a frame of each scene by stage, against numpy and datashader on the same job.

Run: ``python benchmarks/bench.py`` (after ``pip install .``; ``pip install ".[bench]"`` adds
datashader). Options: ``--sizes 16,18,20,22`` (log2 particle counts), ``--scenes
dejong,collision,command`` (``command``: the whole ``es2particles run`` of the article's picture,
start-up included, against the numpy + pillow script, alternately, and where its seconds go;
``dask``: task overhead, and jobs in one process against LocalClusters of 1 and 2 workers),
``--repeats 5``, ``--quick`` (2^16 and 2^18 only, no host-memory soak); ``--scenes fountain``
adds the 3D fountain (step against its numpy twin; sprite renders of 1 to 32 pixels, both
blend modes), ``--scenes smoke`` the smoke at 2^14 to 2^18 (step, sort against the CPU route,
shadow map, whole frames with and without each part), ``--scenes boids`` the boids step at
2^12 to 2^16 against its neighbour grid's build and a numpy step over a k-d tree's pairs,
``--scenes liquid`` the liquid's step likewise against its grids' builds and numpy, ``--scenes
sph`` the SPH dam break's at 5, 2.5 and 1.25 cm spacing, ``--scenes neighbours`` a
neighbour search through the grid against the sort alone and against every pair,
``--scenes backends`` each scene's step and frame on desktop GL against OpenGL ES (the ES time
over the GL time, alternating rounds), ``--scenes accumulate`` the image noise of
``--accumulate K`` against a float64 reference of 4x10^9 samples (10^8 with ``--quick``), ours and
numpy, by samples and by time. It prints tables and writes
them as Markdown to ``out/bench/bench.md``.

Each time is the median (and min, max) of the repeats after a warm-up, with the GL work finished
inside each timing (``ctx.finish()`` or a readback). Ratio columns are peer time / our time,
measured in the same process: the machines are shared and noisy, so compare ratios.
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from peers import (NumpyDeJong, NumpyFrame, datashader_counts, datashader_dejong,  # noqa: E402
                   png_bytes)

from es2particles import open_context  # noqa: E402
from es2particles.gl.context import FORMAT_DTYPES, bytes_per_texel  # noqa: E402
from es2particles.report.measure import timings  # noqa: E402
from es2particles.io.output import encode_png  # noqa: E402
from es2particles.frame.pipeline import Pipeline  # noqa: E402
from es2particles import Bloom  # noqa: E402
from es2particles.scenes.collision import Collision  # noqa: E402
from es2particles.twins.particle import step_reference  # noqa: E402
from es2particles.scenes.dejong import DeJong  # noqa: E402

SIZE = (1024, 1024)
STAGES = ("step", "render", "post", "readback", "PNG encode", "frame")


def timed(function, repeats, finish=lambda: None):
    return timings(function, finish, repeats)


def stages(p, *kinds, camera=None):
    """A function that runs the pipeline's frame stages of ``kinds`` (plan.py: Stage.kind) once,
    in the plan's order, for ``camera``: one part of a frame, timed alone."""
    chosen = [s for s in p.plan.frame_stages if s.kind in kinds]
    return lambda: [p.executor.run(s, p.executor.frame(camera)) for s in chosen]


def ours(ctx, scene_name, count, repeats):
    scene = DeJong() if scene_name == "dejong" else Collision(shape="circle+box+capsule")
    with Pipeline(ctx, scene, count, SIZE, bloom=Bloom()) as p:
        if scene_name == "dejong":
            p.step(20)
        else:  # one draw of 3N candidates, as before growth.py drew them in chunks
            from growth import collision_steady
            collision_steady(p, np.random.default_rng(0), chunk=3 * count)
        finish = ctx.finish
        rows = {"step": timed(lambda: p.step(1), repeats, finish),
                "render": timed(stages(p, "points"), repeats, finish)}
        rows["post"] = timed(stages(p, "post"), repeats, finish)
        p.render()
        rows["readback"] = timed(p.image, repeats)
        image = p.image()
        # Ours: the encoder es2particles.io.output.save_image uses (unfiltered rows, level 1).
        rows["PNG encode"] = timed(lambda: encode_png(image), repeats)
        rows["frame"] = timed(lambda: (p.step(1), p.render(), encode_png(p.image())), repeats)
        buffers = dict(p.sim.plan.buffers)
    return rows, buffers


def numpy_peer(scene_name, count, repeats):
    if scene_name == "dejong":
        job = NumpyDeJong(count)
        frame, step = job.frame, job.step
        positions = lambda: job.p  # noqa: E731
    else:
        if count > 2 ** 18:  # the float64 twin loops over sub-steps: minutes per step beyond
            return None
        scene = Collision(shape="circle+box+capsule")
        rng = np.random.default_rng(0)
        state = {"x": rng.uniform(-0.9, 0.9, (count, 2)), "v": rng.uniform(-2, 2, (count, 2)),
                 "life": np.stack([np.zeros(count), np.full(count, 5.0)], 1)}
        frame = NumpyFrame(extent=1.0)

        def step():
            state["x"], state["v"], state["life"] = step_reference(
                state["x"], state["v"], state["life"], scene.field, scene.params)
        positions = lambda: state["x"]  # noqa: E731
        repeats = min(repeats, 3)
    frame.density(positions())
    frame.post()
    rows = {"step": timed(step, repeats),
            "render": timed(lambda: frame.density(positions()), repeats),
            "post": timed(frame.post, repeats), "readback": None,
            "PNG encode": timed(lambda: png_bytes(frame.image), repeats),
            "frame": timed(lambda: (step(), frame.density(positions()), png_bytes(frame.post())),
                           repeats)}
    return rows


def datashader_peer(count, repeats):
    job = datashader_dejong(count)
    if job is None:
        return None
    step, render, post, encode = job
    render()
    post()
    return {"step": timed(step, repeats), "render": timed(render, repeats),
            "post": timed(post, repeats), "readback": None, "PNG encode": timed(encode, repeats),
            "frame": timed(lambda: (step(), render(), post(), encode()), repeats)}


def host_memory_growth(ctx, frames=500):
    """Resident memory after frame 10 and after frame ``frames`` of a de Jong animation."""
    def rss():
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

    with Pipeline(ctx, DeJong(), 2 ** 16, (512, 512), bloom=Bloom()) as p:
        marks = {}
        for frame in range(1, frames + 1):
            p.step(1)
            p.render()
            p.image()
            if frame in (10, frames):
                marks[frame] = rss()
    return marks


ARTICLE_COMMAND = ["run", "dejong", "--reseed", "--particles", "1048576", "--size", "1024x1024",
                   "--iterations", "3", "--steps", "1"]
STARTUP_STAGES = ("imports", "parser", "context", "probe", "compiles", "set-up", "steps",
                  "first frame", "readback", "PNG")


def whole_command(emit, rounds):
    """The article's picture as a user makes it, start-up included: the whole `es2particles run`
    command against the numpy + pillow script making the same picture (numpy_dejong.py), run
    alternately ``rounds`` times in separate processes; then where our seconds go, stage by stage
    (startup.py walks the command's path in one process). Both sides' bytecode is compiled first,
    as `pip install` leaves it (this machine sets PYTHONDONTWRITEBYTECODE)."""
    import compileall
    import json
    import statistics

    here = Path(__file__).resolve().parent
    import es2particles
    compileall.compile_dir(Path(es2particles.__file__).parent, quiet=1)
    compileall.compile_dir(here, quiet=1)
    ours, numpy_script, stages = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        # Each process starts in the temporary folder: `-m es2particles.cli` from a clone's root
        # would import the clone's sources (uncompiled) instead of the installed package.
        def wall(args):
            start = time.perf_counter()
            subprocess.run(args, check=True, capture_output=True, cwd=tmp)
            return time.perf_counter() - start
        command = [sys.executable, "-m", "es2particles.cli", *ARTICLE_COMMAND,
                   "--out", f"{tmp}/a.png"]
        script = [sys.executable, str(here / "numpy_dejong.py"), "--reseed", f"{tmp}/b.png"]
        bare = min(wall([sys.executable, "-c", "pass"]) for _ in range(3))
        wall(command), wall(script)  # warm the file cache and the shader cache
        for _ in range(rounds):
            ours.append(wall(command))
            numpy_script.append(wall(script))
        for _ in range(max(3, rounds // 2)):
            out = subprocess.run([sys.executable, str(here / "startup.py"), *ARTICLE_COMMAND,
                                  "--out", f"{tmp}/c.png"], check=True, capture_output=True,
                                 text=True, cwd=tmp).stdout
            stages.append(json.loads(out))
    med = statistics.median
    pairs = [n / o for n, o in zip(numpy_script, ours)]
    emit(f"`es2particles {' '.join(ARTICLE_COMMAND)} --out x.png` against the numpy + pillow "
         f"script making the same picture, alternately, {rounds} rounds (whole processes):")
    emit()
    emit("| | median s | min s | max s |")
    emit("|---|---|---|---|")
    for name, times in (("es2particles run", ours), ("numpy + pillow script", numpy_script)):
        emit(f"| {name} | {med(times):.3f} | {min(times):.3f} | {max(times):.3f} |")
    emit()
    emit(f"Whole-command ratio (script / ours): median of the rounds' ratios {med(pairs):.2f} "
         f"(range {min(pairs):.2f}-{max(pairs):.2f}); of the medians "
         f"{med(numpy_script) / med(ours):.2f}")
    emit()
    emit(f"Where our seconds go (startup.py, median of {len(stages)} runs; the interpreter's own "
         f"start and exit, `python -c pass`, is {bare * 1e3:.0f} ms):")
    emit()
    emit("| stage | ms |")
    emit("|---|---|")
    for stage in STARTUP_STAGES:
        emit(f"| {stage} | {med(s[stage] for s in stages) * 1e3:.0f} |")
    emit(f"| sum | {med(sum(s.values()) for s in stages) * 1e3:.0f} |")


def dask_section(emit, quick):
    """Dask: what a task costs (an empty one, and one of our frame tasks on a warm worker), and
    the same jobs in one process and on LocalClusters of 1 and 2 workers, each command timed
    whole (the cluster's start included) and its bytes compared with one process's."""
    import logging
    import statistics

    from distributed import Client, LocalCluster

    from es2particles.cluster import tasks as cluster

    with LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=None,
                      silence_logs=logging.ERROR) as local, Client(local) as client:
        client.submit(int, 0, pure=False).result()
        empty = []
        for _ in range(50):
            start = time.perf_counter()
            client.submit(int, 0, pure=False).result()
            empty.append(time.perf_counter() - start)
        from es2particles.frame.settings import FrameSettings
        from es2particles.run import Run

        run = Run("dejong", {"a": 1.4, "b": -2.3, "c": 2.4, "d": -2.1, "iterations": 3,
                             "reseed": True, "animate_to": None},
                  FrameSettings(particles=1024, size=(64, 64)), frames=2)
        client.submit(cluster.frames_task, run, [1], pure=False).result()  # the context, made
        tiny = []
        for _ in range(20):
            start = time.perf_counter()
            client.submit(cluster.frames_task, run, [1], pure=False).result()
            tiny.append(time.perf_counter() - start)
        start = time.perf_counter()
        client.submit(np.zeros, (1024, 1024), np.float64, pure=False).result()  # 8 MiB back
        density = time.perf_counter() - start
    emit(f"Task overhead (LocalCluster, 1 worker): an empty task "
         f"{statistics.median(empty) * 1e3:.1f} ms "
         f"round trip; our smallest frame task (64x64, 1024 particles: pipeline, draw, PNG) "
         f"{statistics.median(tiny) * 1e3:.0f} ms; a task returning a 1024^2 float64 sum (8 MiB) "
         f"{density * 1e3:.0f} ms")
    emit()
    jobs = [("animation: reseeded de Jong, 2^20 points, 1024x1024, 24 frames",
             ["run", "dejong", "--reseed", "--frames", "24", "--animate-to", "1.5,-2.2,2.3,-2.0"],
             ".gif"),
            ("animation: 3D fountain (stateful), 2^16 particles, 512x512, 24 frames",
             ["run", "fountain", "--particles", "65536", "--size", "512x512", "--frames", "24"],
             ".gif"),
            (f"still: de Jong, 2^24 particles ({2 ** 24 // 2 ** 22} shares), 1024x1024",
             ["run", "dejong", "--particles", str(2 ** 24)], ".png")]
    if quick:
        jobs = jobs[2:]
    emit("| job | one process s | 1 worker s | 2 workers s | 2 workers / 1 process | same bytes |")
    emit("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for label, command, suffix in jobs:
            times, data = [], []
            for k, extra in enumerate(([], ["--workers", "1"], ["--workers", "2"])):
                out = f"{tmp}/{k}{suffix}"
                start = time.perf_counter()
                subprocess.run([sys.executable, "-m", "es2particles", *command, *extra, "--out",
                                out], check=True, capture_output=True)
                times.append(time.perf_counter() - start)
                data.append(Path(out).read_bytes())
            emit(f"| {label} | {times[0]:.1f} | {times[1]:.1f} | {times[2]:.1f} | "
                 f"{times[0] / times[2]:.2f} | "
                 f"{'yes' if data[0] == data[1] == data[2] else 'NO'} |")
    start = time.perf_counter()
    with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None,
                      silence_logs=logging.ERROR):
        pass
    emit()
    emit(f"Starting and closing a 2-worker LocalCluster: {time.perf_counter() - start:.1f} s "
         "(in each --workers time above)")


def fountain_section(ctx, sizes, repeats, emit):
    """The 3D fountain: its step against the numpy twin of the same step (float64), and the
    sprite render (meshes, then sprites with depth) at sprite sizes of 1 to 32 pixels in both
    blend modes. Sprites draw at a fixed size here (no attenuation) so the size is what is
    timed."""
    from es2particles.frame.pipeline import Renderer
    from es2particles.render.sprites import Sprites
    from es2particles.scenes import Fountain
    from es2particles.twins.fountain import fountain_step

    scene = Fountain()
    camera = scene.camera_at(0, 1)
    emit("| N | stage | ours ms (min-max) | numpy ms | numpy/ours |")
    emit("|---|---|---|---|---|")
    for log2n in sizes:
        count = 2 ** log2n
        with Pipeline(ctx, scene, count, SIZE) as p:
            p.warm_up()
            finish = ctx.finish
            step = timed(lambda: p.step(1), repeats, finish)
            x, v = p.sim.download("position"), p.sim.download("velocity")
            peer = timed(lambda: fountain_step(x, v, scene.params), repeats)
            emit(f"| 2^{log2n} | step | {fmt_ms(step)} ({step[1] * 1e3:.1f}-{step[2] * 1e3:.1f})"
                 f" | {fmt_ms(peer)} | {peer[0] / step[0]:.2f} |")
            for pixels in (1, 4, 16, 32):
                for blend in ("add", "over"):
                    sprites = Sprites(meshes=scene.meshes(), blend=blend, size_spread=0.0,
                                      attenuation=(1.0, 0.0, 0.0))
                    with Renderer(ctx, sprites, p.sim, size=SIZE, point_size=pixels) as r:
                        t = timed(lambda: r.draw(camera), repeats, finish)
                    emit(f"| 2^{log2n} | render, {pixels} px sprites, {blend} | {fmt_ms(t)} "
                         f"({t[1] * 1e3:.1f}-{t[2] * 1e3:.1f}) | - | - |")


def confetti_section(ctx, sizes, repeats, emit):
    """The confetti's quads against point sprites of the same state: the confetti scene after
    its warm-up, drawn as its quads (four vertices a particle through one index buffer, three
    textures fetched by each vertex) and as disc sprites of the size a quad covers on screen
    (one vertex a particle), meshes off, at the scene's camera: the cost per particle of each."""
    from es2particles.frame.pipeline import Renderer
    from es2particles.render.sprites import Sprites
    from es2particles.scenes import Confetti

    scene = Confetti()
    camera = scene.camera_at(0, 1)
    quads = replace(scene.rendering(), meshes=())
    d = np.linalg.norm(np.subtract(camera.eye, camera.target))
    pixels = scene.params.paper_size * camera.focal_pixels(SIZE[1]) / d  # a quad's side on screen
    sprites = Sprites(sprite="disc", size_spread=0.0, attenuation=(0.0, 0.0, 1 / d ** 2),
                      roles={"position": "position", "fade": "life"})
    emit(f"| N | quads ms (min-max) | ns a quad | sprites ms ({pixels:.1f} px) | ns a sprite | "
         "quads/sprites |")
    emit("|---|---|---|---|---|---|")
    for log2n in sizes:
        count = 2 ** log2n
        with Pipeline(ctx, scene, count, SIZE) as p:
            p.warm_up()
            finish = ctx.finish
            times = []
            for rendering, extra in ((quads, {}),
                                     (sprites, {"point_size": pixels * 1024 / SIZE[1]})):
                with Renderer(ctx, rendering, p.sim, size=SIZE, **extra) as r:
                    r.draw(camera)
                    times.append(timed(lambda: r.draw(camera), repeats, finish))
        q, s = times
        emit(f"| 2^{log2n} | {fmt_ms(q)} ({q[1] * 1e3:.1f}-{q[2] * 1e3:.1f}) | "
             f"{q[0] / count * 1e9:.0f} | {fmt_ms(s)} | {s[0] / count * 1e9:.0f} | "
             f"{q[0] / s[0]:.2f} |")


def upsample_section(ctx, repeats, emit):
    """The ARM chapter's smoke look on the 3D collision (puff sprites added, soft over 0.1 m,
    2^14 particles, 960x540): a frame at full resolution against frames whose sprites are drawn
    into a buffer of half and a quarter of the resolution and laid back by each upsampler: the
    error along the sphere's silhouette (pixels within 2 of it, found by a float64 pinhole) and
    elsewhere, in codes of 255 against the full-resolution frame, and the frame's time."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
    from test_soft import sphere_edges

    from es2particles.scenes import Collision3D

    size = (960, 540)

    def render(**options):
        scene = Collision3D(sprite="puff", blend="add", soft=0.1, **options)
        with Pipeline(ctx, scene, 2 ** 14, size, point_size=40.0, seed=3) as p:
            next(p.frames())
            image = p.image().astype(float)
            camera = p.camera(0, 1)
            return image, timed(lambda: p.render(), repeats, ctx.finish), camera

    reference, full, camera = render()
    edges = sphere_edges(camera, size)
    emit("| buffer | upsample | edge error | elsewhere | frame ms | saved |")
    emit("|---|---|---|---|---|---|")
    emit(f"| 1 | - | 0 | 0 | {fmt_ms(full)} | - |")
    for scale in (0.5, 0.25):
        for upsample in ("nearest", "bilinear", "bilateral"):
            image, t, _ = render(buffer_scale=scale, upsample=upsample)
            diff = np.abs(image - reference).mean(axis=2)
            emit(f"| {scale:g} | {upsample} | {diff[edges].mean():.2f} | "
                 f"{diff[~edges].mean():.2f} | {fmt_ms(t)} | {1 - t[0] / full[0]:.0%} |")


def step_and_build(ctx, sim, repeats):
    """(a whole step's timing, its neighbour grids' builds' timing) of simulation ``sim``: the
    key passes, sorts and tables run alone, as the step runs them."""
    build = [s for s in sim.stages if s.kind in ("neighbour key", "sort merge",
                                                "neighbour table")]
    frame = sim.executor.frame()
    return (timed(sim.step, repeats, ctx.finish),
            timed(lambda: [sim.executor.run(s, frame) for s in build], repeats, ctx.finish))


def emit_scaling(emit, name, growth):
    """The exponent of a step's time against N, from (count, seconds) pairs."""
    if len(growth) >= 2:
        counts, times = zip(*growth)
        exponent = np.polyfit(np.log(counts), np.log(times), 1)[0]
        emit(f"Scaling of the {name} step with N: time ~ N^{exponent:.2f}")


def boids_numpy_step(x, v, p):
    """The boids step in numpy (float64): scipy's k-d tree finds the pairs within the largest
    radius, the three rules sum over them with bincount; the same rules as boids.frag."""
    from scipy.spatial import cKDTree

    rs, ra, rc = p.radii
    ws, wa, wc = p.weights
    lo, hi = p.speed
    pairs = cKDTree(x).query_pairs(max(p.radii), output_type="ndarray")
    i, j = np.concatenate([pairs[:, 0], pairs[:, 1]]), np.concatenate([pairs[:, 1], pairs[:, 0]])
    d = x[j] - x[i]
    r = np.linalg.norm(d, axis=1)
    n = len(x)

    def total(mask, values):
        return np.stack([np.bincount(i[mask], values[mask, k], n)
                         for k in range(x.shape[1])], 1)

    sep = (r < rs) & (r > 0)
    away = -total(sep, d / np.where(sep, r * r, 1.0)[:, None])
    count_a = np.bincount(i[r < ra], minlength=n)[:, None]
    count_c = np.bincount(i[r < rc], minlength=n)[:, None]
    steer = ws * away * rs
    steer += np.where(count_a > 0, wa * (total(r < ra, v[j]) / np.maximum(count_a, 1) - v), 0.0)
    steer += np.where(count_c > 0, wc * total(r < rc, d) / np.maximum(count_c, 1) / rc * hi, 0.0)
    box = np.asarray(p.extent, float)
    wall = (x <= rc).astype(float) - (x >= box - rc).astype(float)
    v = v + p.dt * (steer + wall * hi / max(rc, p.dt * hi))
    s = np.linalg.norm(v, axis=1, keepdims=True)
    v = v / s * np.clip(s, lo, hi)
    return np.clip(x + p.dt * v, 0.0, box), v


def boids_section(ctx, sizes, repeats, emit, dimensions=2):
    """The boids step (a neighbour grid: key pass, sort by cell, cell table; then the rules'
    pass over 3 rows of cells, 9 in 3D, and the position pass) at the default density (16,384
    boids in a 4 x 4 box, or a unit cube in 3D, the box grown with N), against the neighbour
    grid's build alone and a numpy step whose pairs come from scipy's k-d tree."""
    from es2particles.frame.simulation import Simulation
    from es2particles.scenes.boids import Boids

    emit(f"{dimensions}D:")
    emit("| N | step ms (min-max) | grid build ms | build share | numpy + k-d tree ms | "
         "numpy/ours |")
    emit("|---|---|---|---|---|---|")
    growth = []
    for log2n in sizes:
        count = 2 ** log2n
        scene = Boids.at_density(count, dimensions)
        with Simulation(ctx, scene.graph(ctx.caps), count) as sim:
            scene.initialise(sim, np.random.default_rng(1))
            sim.run(20)
            step, grid = step_and_build(ctx, sim, repeats)
            x, v = sim.download("position"), sim.download("velocity")
        peer = timed(lambda: boids_numpy_step(x, v, scene.params), repeats)
        growth.append((count, step[0]))
        emit(f"| 2^{log2n} | {step[0] * 1e3:.1f} ({step[1] * 1e3:.1f}-{step[2] * 1e3:.1f}) | "
             f"{grid[0] * 1e3:.1f} | {grid[0] / step[0]:.0%} | {peer[0] * 1e3:.1f} | "
             f"{peer[0] / step[0]:.2f} |")
    emit_scaling(emit, f"{dimensions}D boids", growth)


def liquid_numpy_step(x, v, p, h, dt):
    """The liquid's gather-form step in numpy (float64), its pairs from a numpy cell list
    (twins/neighbours.py): the same formulas as liquid.frag."""
    from es2particles.scenes.liquid import GATHER_SHARE
    from es2particles.twins.neighbours import pairs_within

    n = len(x)

    def both(points):
        i, j, r = pairs_within(points, h)
        return np.concatenate([i, j]), np.concatenate([j, i]), np.concatenate([r, r])

    def total(i, values):
        return np.stack([np.bincount(i, values[:, k], n) for k in range(2)], 1)

    i, j, r = both(x)
    apart = r > 0
    i, j, r = i[apart], j[apart], r[apart]
    unit = (x[j] - x[i]) / r[:, None]
    u = ((v[i] - v[j]) * unit).sum(axis=1)
    sigma, beta = p.viscosity
    strength = np.where(u > 0, dt * (1 - r / h) * (sigma * u + beta * u * u), 0.0)
    v1 = v + dt * np.asarray(p.gravity) - 0.5 * total(i, strength[:, None] * unit)
    xs = x + dt * v1
    i, j, r = both(xs)
    a = 1 - r / h
    rho, near = np.bincount(i, a * a, n), np.bincount(i, a ** 3, n)
    apart = r > 0
    i, j, r, a = i[apart], j[apart], r[apart], a[apart]
    pressure = p.stiffness * h * (rho[i] + rho[j] - 2 * p.rest_density) * a \
        + p.near_stiffness * h * (near[i] + near[j]) * a * a
    x2 = xs - GATHER_SHARE * 0.5 * dt * dt * total(i, (pressure / r)[:, None] * (xs[j] - xs[i]))
    ox, oy, radius = p.obstacle
    c = x2 - (ox, oy)
    rc = np.hypot(c[:, 0], c[:, 1])
    inside = rc < radius
    x2[inside] = (ox, oy) + c[inside] / rc[inside, None] * radius
    x2 = np.clip(x2, 0.0, np.asarray(p.box, float))
    return x2, v1 + (x2 - xs) / dt


def liquid_section(ctx, sizes, repeats, emit):
    """The liquid's step (two neighbour grids, viscosity, prediction, densities, relaxation,
    velocity) mid dam break, against its two grids' builds and the same step in numpy."""
    from es2particles.frame.simulation import Simulation
    from es2particles.scenes.liquid import Liquid

    emit("| N | step ms (min-max) | grid builds ms | build share | numpy ms | numpy/ours |")
    emit("|---|---|---|---|---|---|")
    growth = []
    for log2n in sizes:
        count = 2 ** log2n
        scene = Liquid()
        with Simulation(ctx, scene.graph(ctx.caps, count=count), count) as sim:
            scene.initialise(sim, np.random.default_rng(1))
            sim.run(30)
            step, grid = step_and_build(ctx, sim, repeats)
            x, v = sim.download("position"), sim.download("velocity")
        h, dt = scene.radius_for(count), scene.dt_for(count)
        peer = timed(lambda: liquid_numpy_step(x, v, scene.params, h, dt), repeats)
        growth.append((count, step[0]))
        emit(f"| 2^{log2n} | {step[0] * 1e3:.1f} ({step[1] * 1e3:.1f}-{step[2] * 1e3:.1f}) | "
             f"{grid[0] * 1e3:.1f} | {grid[0] / step[0]:.0%} | {peer[0] * 1e3:.1f} | "
             f"{peer[0] / step[0]:.2f} |")
    emit_scaling(emit, "liquid", growth)


def sph_numpy_step(x, v, p):
    """The 2D SPH step in numpy (float64), its pairs from a numpy cell list: the same equations
    as sph.frag (density, Tait pressure without tension, Monaghan viscosity, walls)."""
    from es2particles.scenes.sph import G, RHO0, wendland
    from es2particles.twins.neighbours import pairs_within

    h, m, c0, dt, n = p.h, p.mass, p.sound, p.step, len(x)
    i, j, r = pairs_within(x, 2 * h)
    w = m * wendland(r, h)
    rho = np.bincount(i, w, n) + np.bincount(j, w, n) + m * wendland(np.zeros(1), h)[0]
    pressure = np.maximum(RHO0 * c0 * c0 / 7 * ((rho / RHO0) ** 7 - 1), 0.0)
    i, j, r = np.concatenate([i, j]), np.concatenate([j, i]), np.concatenate([r, r])
    apart = r > 0
    i, j, r = i[apart], j[apart], r[apart]
    d = x[i] - x[j]
    term = pressure[i] / rho[i] ** 2 + pressure[j] / rho[j] ** 2
    approach = ((v[i] - v[j]) * d).sum(axis=1)
    mu = h * approach / (r * r + 0.01 * h * h)
    term += np.where(approach < 0, -p.viscosity * c0 * mu / (0.5 * (rho[i] + rho[j])), 0.0)
    q = r / h
    slope = -35 / (4 * np.pi * h ** 3) * q * np.clip(1 - q / 2, 0, None) ** 3
    push = (m * term * slope / r)[:, None] * d
    a = np.array([0.0, -G]) - np.stack([np.bincount(i, push[:, k], n) for k in range(2)], 1)
    v = v + dt * a
    box = np.asarray(p.tank, float)
    v = np.where(((x <= 0) & (v < 0)) | ((x >= box) & (v > 0)), -p.restitution * v, v)
    return np.clip(x + dt * v, 0, box), v


def sph_section(ctx, spacings, repeats, emit):
    """The SPH dam break's step (one neighbour grid of support 2h; density, acceleration,
    position) 200 steps after the release, against its grid's build and the same step in
    numpy, at several spacings of the 1 x 2 m column."""
    from es2particles.frame.simulation import Simulation
    from es2particles.scenes.sph import Sph

    emit("| spacing | N | step ms (min-max) | grid build ms | build share | numpy ms | "
         "numpy/ours |")
    emit("|---|---|---|---|---|---|---|")
    growth = []
    for spacing in spacings:
        scene = Sph(spacing=spacing)
        count = scene.params.count
        with Simulation(ctx, scene.graph(ctx.caps), count, rounding="dither") as sim:
            scene.initialise(sim, np.random.default_rng(1))
            sim.run(200)
            step, grid = step_and_build(ctx, sim, repeats)
            x, v = sim.download("position"), sim.download("velocity")
        peer = timed(lambda: sph_numpy_step(x, v, scene.params), repeats)
        growth.append((count, step[0]))
        emit(f"| {spacing:g} m | {count} | {step[0] * 1e3:.1f} ({step[1] * 1e3:.1f}-"
             f"{step[2] * 1e3:.1f}) | {grid[0] * 1e3:.1f} | {grid[0] / step[0]:.0%} | "
             f"{peer[0] * 1e3:.1f} | {peer[0] / step[0]:.2f} |")
    emit_scaling(emit, "SPH", growth)


NEIGHBOURS_FOUND = """#version 100
// How many particles lie within sqrt(u_h2): through the neighbour grid, or (BRUTE) all of them.
void main()
{
    vec2 p = read_position(v_uv);
    float found = 0.0;
#ifdef BRUTE
    for (highp int k = 0; k < COUNT; k++) {
        float i = float(k);
        float row = floor((i + 0.5) / u_state_size.x);
        vec2 d = read_position((vec2(i - row * u_state_size.x, row) + 0.5) / u_state_size) - p;
        found += dot(d, d) < u_h2 ? 1.0 : 0.0;
    }
#else
    vec2 other;
    FOR_EACH_NEIGHBOUR(p, other) {
        vec2 d = read_position(other) - p;
        found += dot(d, d) < u_h2 ? 1.0 : 0.0;
    }
#endif
    write_found(found);
}
"""


def neighbours_section(ctx, sizes, brute_sizes, repeats, emit):
    """Finding each particle's neighbours within h (uniform over the unit square, about 13 each):
    the neighbour grid's build (key pass, sort, table) plus the pass counting through it, the
    sort alone, and a pass comparing every pair (N^2 fetches), each timed as a whole step."""
    import tempfile

    from es2particles.frame.graph import PassGraph
    from es2particles.frame.simulation import Simulation

    folder = Path(tempfile.mkdtemp())
    (folder / "found.frag").write_text(NEIGHBOURS_FOUND)
    (folder / "keep.frag").write_text("#version 100\nvoid main() { write_position("
                                      "read_position(v_uv)); }\n")

    def graph(count, brute):
        h = 1 / 128 if count >= 2 ** 16 else (13 / (np.pi * count)) ** 0.5
        g = PassGraph()
        g.quantity("position", 0.0, 1.0)
        g.quantity("found", 0.0, 2.0 ** 16, components=1)
        g.add("keep", str(folder / "keep.frag"), writes="position", reads=["position"])
        if brute:
            g.add("found", str(folder / "found.frag"), writes="found", reads=["position"],
                  uniforms={"u_h2": h * h}, defines={"BRUTE": None, "COUNT": count})
        else:
            g.neighbours("cells", "position", cell=h, bound=1024)
            g.add("found", str(folder / "found.frag"), writes="found", reads=["position"],
                  neighbours="cells", uniforms={"u_h2": h * h})
        return g

    emit("| N | grid + count ms | of it the sort ms | all pairs ms | all pairs / grid |")
    emit("|---|---|---|---|---|")
    for log2n in sizes:
        count = 2 ** log2n
        rng = np.random.default_rng(1)
        with Simulation(ctx, graph(count, False), count, fmt="rgba32f") as sim:
            sim.upload("position", rng.random((count, 2)))
            sim.run(1)
            grid = timed(sim.step, repeats, ctx.finish)
            merge = [s for s in sim.stages if s.kind == "sort merge"]
            frame = sim.executor.frame()
            sort = timed(lambda: [sim.executor.run(s, frame) for s in merge], repeats, ctx.finish)
        brute = None
        if log2n in brute_sizes:
            with Simulation(ctx, graph(count, True), count, fmt="rgba32f") as sim:
                sim.upload("position", rng.random((count, 2)))
                brute = timed(sim.step, max(1, repeats // 3), ctx.finish)
        emit(f"| 2^{log2n} | {grid[0] * 1e3:.1f} | {sort[0] * 1e3:.1f} | {fmt_ms(brute)} | "
             f"{'-' if brute is None else f'{brute[0] / grid[0]:.1f}'} |")


def smoke_section(ctx, sizes, repeats, emit):
    """The smoke: its step (acceleration, velocity, position, life), the back-to-front sort (key
    pass + the whole odd-even merge network, or 8 passes of it spread over frames) against the
    CPU route of the same order (read the positions back, numpy argsort of the view depth, upload
    the order), the opacity shadow map pass, and the whole frame (step, sort, shadow map, meshes
    and sprites) with each part switched off in turn."""
    from es2particles.scenes.smoke import Smoke

    emit("| N | stage | ours ms (min-max) | CPU route ms | CPU/ours |")
    emit("|---|---|---|---|---|")
    from es2particles.render.sort import Order

    finish = ctx.finish
    for log2n in sizes:
        count = 2 ** log2n
        scene = Smoke()
        camera = scene.camera_at(0, 1)
        with Pipeline(ctx, scene, count, SIZE) as p:
            p.warm_up()
            row = lambda stage, t, peer=None: emit(  # noqa: E731
                f"| 2^{log2n} | {stage} | {fmt_ms(t)} ({t[1] * 1e3:.1f}-{t[2] * 1e3:.1f}) | "
                f"{fmt_ms(peer)} | {'-' if peer is None else f'{peer[0] / t[0]:.2f}'} |")
            row("step", timed(lambda: p.step(1), repeats, finish))
            network = Order(count, p.plan.resources["order"].format)
            order_texture = ctx.texture((network.width, network.height), network.fmt)

            def cpu_sort():  # the order a CPU would make: read back, sort, upload
                depth = (p.sim.download("position") - camera.eye) @ camera.forward
                order = np.argsort(-depth, kind="stable")
                slots = np.arange(network.slots)
                slots[:count] = order
                ctx.write(order_texture, network.encode(np.zeros(network.slots, np.int64),
                                                        slots).tobytes())

            try:
                peer = timed(cpu_sort, repeats, finish)
            finally:
                ctx.free(order_texture)
            row(f"sort: key + {network.passes} merge passes", timed(
                stages(p, "sort key", "sort merge", camera=camera), repeats, finish), peer)
            row("shadow map pass", timed(stages(p, "shadow map", camera=camera), repeats,
                                         finish))
            row("frame: step, sort, shadow, render", timed(
                lambda: (p.step(1), p.render()), repeats, finish))
        for label, options in (("frame, sort spread 8 passes", {"sort": 8}),
                               ("frame, unsorted", {"sort": "off"}),
                               ("frame, no shadows", {"shadows": "off"})):
            with Pipeline(ctx, Smoke(**options), count, SIZE) as p:
                p.warm_up()
                row(label, timed(lambda: (p.step(1), p.render()), repeats, finish))
    smoke_sortedness(ctx, sizes[0], emit)


def smoke_sortedness(ctx, log2n, emit, frames=45):
    """How sorted the drawn order stays when the merge passes are spread over frames (Latta
    2004): the smoke moving under its orbiting camera, after ``frames`` frames of one step."""
    from es2particles.render.sort import Order, sortedness
    from es2particles.scenes.smoke import Smoke

    emit()
    emit(f"Order of the smoke at 2^{log2n} after {frames} frames of one step, the camera orbiting "
         "(sort.sortedness against the true view depth):")
    emit()
    emit("| sort | passes per frame | neighbours out of order | pairs out of order | mean "
         "displacement | mean depth error |")
    emit("|---|---|---|---|---|---|")
    for sort in ("full", 32, 16, 8, 4, "off"):
        scene = Smoke(sort=sort, camera="orbit", shadows="off")
        with Pipeline(ctx, scene, 2 ** log2n, (256, 256)) as p:
            p.warm_up()
            for frame in range(frames):
                p.step(1)
                p.render(frame, 4 * frames)
            camera = scene.camera_at(frames - 1, 4 * frames)
            depth = (p.sim.download("position") - camera.eye) @ camera.forward
            sorted_ = "order" in p.plan.resources
            order = np.arange(2 ** log2n)
            if sorted_:
                network = Order(2 ** log2n, p.plan.resources["order"].format)
                texels = np.frombuffer(p.executor.read("order"),
                                       np.uint8 if network.fmt == "rgba8" else np.float32)
                order = network.decode(texels.reshape(-1, 4))[1][: 2 ** log2n]
            passes = "-" if not sorted_ else (network.passes if sort == "full" else sort)
            m = sortedness(order, depth)
            emit(f"| {sort} | {passes} | {100 * m.adjacent:.2f}% | {100 * m.discordant:.3f}% | "
                 f"{100 * m.displacement:.3f}% | {100 * m.depth_error:.3f}% |")


def dejong_reference(samples, size, view, chains=2 ** 22, burn_in=50):
    """float64 densities (2, h, w) of two independent halves of ``samples`` points of the de
    Jong attractor (their sum is the reference; their difference measures its own noise):
    ``chains`` chains of the map from uniform starts, each iterate after the burn-in one sample;
    cached in out/bench (a 10^9-sample reference takes ~30 s here)."""
    w, h = size
    cache = Path("out/bench") / f"dejong_reference_halves_{samples:.0e}_{w}x{h}.npy"
    if cache.exists():
        return np.load(cache)
    halves = np.stack([_dejong_chains(samples // 2, size, view, chains, burn_in, seed)
                       for seed in (12345, 54321)])
    cache.parent.mkdir(parents=True, exist_ok=True)
    np.save(cache, halves)
    return halves


def _dejong_chains(samples, size, view, chains, burn_in, seed):
    from es2particles.scenes.dejong import ARTICLE_COEFFICIENTS, dejong_map

    w, h = size
    x0, y0, x1, y1 = view
    rng = np.random.default_rng(seed)
    p = rng.uniform(-2, 2, (chains, 2))
    for _ in range(burn_in):
        p = dejong_map(p, ARTICLE_COEFFICIENTS)
    counts = np.zeros(w * h)
    done = 0
    while done < samples:
        p = dejong_map(p, ARTICLE_COEFFICIENTS)
        take = p[: samples - done]
        i = np.clip(((take[:, 0] - x0) / (x1 - x0) * w).astype(np.int64), 0, w - 1)
        j = np.clip(((take[:, 1] - y0) / (y1 - y0) * h).astype(np.int64), 0, h - 1)
        counts += np.bincount(j * w + i, minlength=w * h)
        done += len(take)
    return counts.reshape(h, w)


def noise(density, reference):
    """Relative RMS difference of two densities, each normalised to unit sum."""
    d = density / density.sum()
    r = reference / reference.sum()
    return float(np.sqrt(np.sum((d - r) ** 2) / np.sum(r ** 2)))


def noise_beyond(density, halves):
    """The relative RMS noise of ``density`` itself: its distance to the reference (the sum of
    ``halves``) less, in quadrature, the reference's own noise, half the distance between its
    two independent halves (each has sqrt(2) times the whole's noise). Without it, the reference's
    noise (0.0097 at 10^9 samples, 1024x1024) hid the state's floor."""
    own = noise(halves[0], halves[1]) / 2
    return float(np.sqrt(max(noise(density, halves.sum(axis=0)) ** 2 - own ** 2, 0.0)))


def numpy_counts(p, view, size=SIZE):
    """The numpy peer's binning: the count of points ``p`` (n, 2) float32 on each pixel of
    ``view`` (flat, row 0 at the bottom), by floor, edges clamped in."""
    w, h = size
    x0, y0, x1, y1 = view
    i = ((p[:, 0] - x0) * np.float32(w / (x1 - x0))).astype(np.int32).clip(0, w - 1)
    j = ((p[:, 1] - y0) * np.float32(h / (y1 - y0))).astype(np.int32).clip(0, h - 1)
    return np.bincount(j * w + i, minlength=w * h)


def accumulation_section(ctx, emit, quick):
    """Image noise against a float64 reference, as a function of samples and time: ours with
    --accumulate K, and numpy (and datashader where installed) summing the same K steps of 2^20
    particles into one density, on the same 1024x1024 view."""
    from es2particles.scenes.dejong import DeJong

    reference_samples = 10 ** 8 if quick else 4 * 10 ** 9
    scene = DeJong()
    w, h = SIZE
    reference = dejong_reference(reference_samples, SIZE, scene.view)
    own = noise(reference[0], reference[1]) / 2
    count = 2 ** 20

    def numpy_density(job, k):
        counts = np.zeros(w * h)
        for sample in range(k):
            if sample:
                job.step()
            counts += numpy_counts(job.p, scene.view)
        return counts.reshape(h, w)

    emit(f"Image noise (relative RMS of the normalised density against a float64 reference of "
         f"{reference_samples:.0e} samples, less the reference's own noise, {own:.4f}, in "
         f"quadrature) and the time to make the density (steps and binning; no tone map), de "
         f"Jong, 2^20 particles, {w}x{h}, K samples per image:")
    emit()
    ds_job = datashader_counts(count, scene.view)
    if ds_job is not None:
        for _ in range(20):
            ds_job[0]()
        ds_job[1]()  # datashader compiles its aggregation at the first call: not timed

    def datashader_density(k):
        step, counts = ds_job
        total = counts()
        for _ in range(1, k):
            step()
            total += counts()
        return total

    emit("| K | samples | ours noise | ours s | ours 16-bit noise | numpy noise | numpy s | "
         "numpy s / ours s | datashader noise | datashader s | datashader s / ours s |")
    emit("|---|---|---|---|---|---|---|---|---|---|---|")
    rows, sixteen = [], []
    for k in (1, 4, 16) if quick else (1, 4, 16, 64, 256, 1024):
        with Pipeline(ctx, scene, count, SIZE, accumulate=k) as p:
            p.warm_up()
            ctx.finish()
            start = time.perf_counter()  # the density only, as the peers': Pipeline.density
            p.density()
            ctx.finish()
            ours_t = time.perf_counter() - start
            ours_d = np.frombuffer(p.executor.read("density"), np.float32).reshape(h, w)
        with Pipeline(ctx, dejong_16_bit(), count, SIZE, accumulate=k, rounding="jitter") as p:
            p.warm_up()
            p.density()
            sixteen.append(noise_beyond(np.frombuffer(p.executor.read("density"), np.float32)
                                        .reshape(h, w), reference))
        job = NumpyDeJong(count)
        for _ in range(20):
            job.step()
        start = time.perf_counter()
        peer_d = numpy_density(job, k)
        peer_t = time.perf_counter() - start
        ds_n = ds_t = None
        if ds_job is not None:
            start = time.perf_counter()
            ds_d = datashader_density(k)
            ds_t = time.perf_counter() - start
            ds_n = noise_beyond(ds_d, reference)
        ours_n, peer_n = noise_beyond(ours_d, reference), noise_beyond(peer_d, reference)
        rows.append((k, ours_n, ours_t, peer_n, peer_t, ds_n, ds_t))
        ds_cells = ("- | - | -" if ds_t is None
                    else f"{ds_n:.4f} | {ds_t:.2f} | {ds_t / ours_t:.2f}")
        emit(f"| {k} | {k * count:.3g} | {ours_n:.4f} | {ours_t:.2f} | {sixteen[-1]:.4f} | "
             f"{peer_n:.4f} | "
             f"{peer_t:.2f} | {peer_t / ours_t:.2f} | {ds_cells} |")
    emit()
    # Time to equal quality: the noise both sides reach (the larger of the two smallest), and the
    # time each needs for it, interpolated in log K between its rows (noise ~ a / sqrt(K) + floor).
    ks = np.log([r[0] for r in rows])

    def time_to(noise_at, time_at, target):
        k = np.exp(np.interp(-target, [-r[noise_at] for r in rows], ks))
        return k, np.exp(np.interp(np.log(k), ks, np.log([r[time_at] for r in rows])))

    for name, n_at, t_at in (("numpy", 3, 4), ("datashader", 5, 6)):
        if rows[-1][n_at] is None:
            continue
        target = max(rows[-1][1], rows[-1][n_at])
        ours_k, ours_time = time_to(1, 2, target)
        peer_k, peer_time = time_to(n_at, t_at, target)
        emit(f"Equal quality against {name} (noise {target:.4f}, which both reach): ours K ~ "
             f"{ours_k:.0f} in {ours_time:.2f} s, {name} K ~ {peer_k:.0f} in {peer_time:.2f} s: "
             f"{name} time / ours {peer_time / ours_time:.2f}")
    worst = max(rows, key=lambda r: r[1] / r[3])
    emit(f"Ours against numpy's noise, K by K: {', '.join(f'{r[1] / r[3]:.3f}' for r in rows)} "
         f"(the most, {worst[1] / worst[3]:.3f}x, at K = {worst[0]}); our position is "
         f"{scene.state_bits}-bit, rounding {scene.defaults.rounding}. 16-bit with jittered "
         f"reads: {', '.join(f'{n / r[3]:.3f}' for n, r in zip(sixteen, rows))}.")


CEILING_VERT = """#version 100
attribute vec2 a_p;
void main() { gl_Position = vec4(a_p, 0.0, 1.0); gl_PointSize = 1.0; }
"""
CEILING_FRAG = """#version 100
precision mediump float;
void main() { gl_FragColor = vec4(1.0); }
"""


def ceiling_draws(ctx, count, repeats):
    """What llvmpipe's point path costs with nothing of ours in it: ``count`` points from a
    vertex buffer (no texture fetch, no decode, a constant colour) added into an r32f target of
    SIZE, (a) drawn where they fall in one call, (b) the same in slices of SOFTWARE_DRAW_SLICE
    with a flush after each, as our points stage draws on a CPU rasteriser, and (c) all outside
    the clip volume, which is the vertex stage alone (shader, clip test) with no point set up,
    binned or rasterised."""
    from es2particles.render.points import SOFTWARE_DRAW_SLICE
    mgl = ctx.mgl
    program = mgl.program(vertex_shader=CEILING_VERT, fragment_shader=CEILING_FRAG)
    target = mgl.texture(SIZE, 1, dtype="f4")
    framebuffer = mgl.framebuffer([target])
    rng = np.random.default_rng(0)
    inside = rng.uniform(-1, 1, (count, 2)).astype("f4")
    out = {}
    for name, points, part in (("drawn", inside, count),
                               ("sliced", inside, SOFTWARE_DRAW_SLICE),
                               ("clipped", inside + np.float32(4), count)):
        buffer = mgl.buffer(points.tobytes())
        vao = mgl.vertex_array(program, [(buffer, "2f", "a_p")])

        def draw():
            framebuffer.use()
            mgl.enable(mgl.BLEND)
            mgl.blend_func = mgl.ONE, mgl.ONE
            for first in range(0, count, part):
                vao.render(mgl.POINTS, vertices=min(part, count - first), first=first)
                ctx.flush()
        out[name] = timed(draw, repeats, mgl.finish)
        vao.release()
        buffer.release()
    framebuffer.release()
    target.release()
    program.release()
    mgl.disable(mgl.BLEND)
    return out


def dejong_16_bit():
    """De Jong with its position in 16-bit codes, as it was before its state took 32 bits."""
    from es2particles.report.measure import DeJongInFormat

    return DeJongInFormat()


def sample_section(ctx, emit, repeats):
    """One accumulated sample of a stateful de Jong image (2^20 particles, SIZE), part by part:
    ours (a step, the points draw) with its 32-bit position and with 16-bit codes under jittered
    and dithered reads, the peers' step and binning, and the ceiling of llvmpipe's point path
    (:func:`ceiling_draws`)."""
    count = 2 ** 20
    scene = DeJong()
    rows = {}
    for label, run, rounding in (("32-bit (the default)", scene, "nearest"),
                                 ("16-bit, jittered reads", dejong_16_bit(), "jitter"),
                                 ("16-bit, dithered writes", dejong_16_bit(), "dither")):
        with Pipeline(ctx, run, count, SIZE, rounding=rounding) as p:
            p.warm_up()
            draw = stages(p, "points")
            step = timed(lambda: p.step(1), repeats, ctx.finish)
            points = timed(draw, repeats, ctx.finish)
            both = timed(lambda: (p.step(1), draw()), repeats, ctx.finish)
            rows[f"ours, {label}"] = (step, points, both)
    ceiling = ceiling_draws(ctx, count, repeats)
    job = NumpyDeJong(count)
    w, h = SIZE

    def bin_numpy():
        return numpy_counts(job.p, scene.view)
    rows["numpy float32"] = (timed(job.step, repeats), timed(bin_numpy, repeats),
                             timed(lambda: (job.step(), bin_numpy()), repeats))
    ds_job = datashader_counts(count, scene.view)
    if ds_job is not None:
        ds_step, ds_counts = ds_job
        ds_counts()  # compiles
        rows["datashader + numba"] = (timed(ds_step, repeats), timed(ds_counts, repeats),
                                      timed(lambda: (ds_step(), ds_counts()), repeats))
    emit(f"One accumulated sample of stateful de Jong, {count} particles, {w}x{h} (median of "
         f"{repeats}, ms; the step, the binning or points draw, and the two together):")
    emit()
    emit("| who | step | bin / draw | sample | sample / ours |")
    emit("|---|---|---|---|---|")
    ours = rows["ours, 32-bit (the default)"][2][0]
    for name, (step, binning, both) in rows.items():
        emit(f"| {name} | {fmt_ms(step)} | {fmt_ms(binning)} | {fmt_ms(both)} | "
             f"{both[0] / ours:.2f} |")
    emit()
    draw = rows["ours, 32-bit (the default)"][1]
    emit(f"The ceiling of llvmpipe's point path, {count} points with no fetch, decode or hash "
         f"(a vertex buffer, a constant colour): drawn in one call {fmt_ms(ceiling['drawn'])} "
         f"ms, in slices as ours {fmt_ms(ceiling['sliced'])} ms, all clipped (the vertex stage "
         f"alone) {fmt_ms(ceiling['clipped'])} ms. Ours draws in "
         f"{fmt_ms(draw)} ms, {draw[0] / ceiling['sliced'][0]:.2f}x the sliced ceiling.")


# The scenes the backends section times, each at a count its step takes in tens of ms here
# (None: the flame's noise keeps no particles).
BACKEND_RUNS = {"dejong": 2 ** 18, "fountain": 2 ** 14, "smoke": 2 ** 14, "wind": 2 ** 16,
                "boids": 2 ** 12, "liquid": 2 ** 12, "flame": None}


def backends_section(ctx, repeats, emit, rounds=3):
    """Each scene's step and whole frame (step, draws, readback) on desktop GL (``ctx``) and on
    OpenGL ES, in one process: ``rounds`` rounds that alternate the two, each the median of
    ``repeats``; the ratio is ES time / GL time, the median over the rounds."""
    from es2particles.frame.settings import FrameSettings
    from es2particles.run import Run

    es = open_context(backend="gles")
    emit(f"desktop: {ctx.caps.version}; ES: {es.caps.version}; 256x256 pictures; ES time / GL "
         f"time, the median of {rounds} alternating rounds of {repeats}")
    emit()
    emit("| scene | N | GL step ms | ES step ms | ES/GL | GL frame ms | ES frame ms | ES/GL |")
    emit("|---|---|---|---|---|---|---|---|")
    try:
        for name, count in BACKEND_RUNS.items():
            settings = FrameSettings(size=(256, 256), **({"particles": count} if count else {}))
            pipelines = {}
            for backend, context in (("gl", ctx), ("gles", es)):
                context.make_current()
                pipelines[backend] = Run(name, settings=settings).pipeline(context)[1]
            times = {(backend, part): [] for backend in pipelines for part in ("step", "frame")}
            for _ in range(rounds):
                for backend, p in pipelines.items():
                    p.ctx.make_current()
                    times[backend, "step"].append(timed(lambda: p.step(1), repeats,
                                                        p.ctx.finish)[0])
                    times[backend, "frame"].append(timed(lambda: (p.step(1), p.render(),
                                                                  p.image()), repeats)[0])
            for p in pipelines.values():
                p.ctx.make_current()
                p.release()
            med = {key: float(np.median(value)) for key, value in times.items()}
            emit(f"| {name} | {count or '-'} | {med['gl', 'step'] * 1e3:.1f} | "
                 f"{med['gles', 'step'] * 1e3:.1f} | "
                 f"{np.median(np.divide(times['gles', 'step'], times['gl', 'step'])):.2f} | "
                 f"{med['gl', 'frame'] * 1e3:.1f} | {med['gles', 'frame'] * 1e3:.1f} | "
                 f"{np.median(np.divide(times['gles', 'frame'], times['gl', 'frame'])):.2f} |")
    finally:
        es.release()
        ctx.make_current()


def fmt_ms(t):
    return "-" if t is None else f"{t[0] * 1e3:.1f}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="16,18,20,22")
    parser.add_argument("--scenes", default="dejong,collision,command")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    sizes = [16, 18] if args.quick else [int(s) for s in args.sizes.split(",")]
    out_lines = []

    def emit(line=""):
        print(line, flush=True)
        out_lines.append(line)

    with open_context() as ctx:
        emit(f"Renderer: {ctx.caps.renderer}; {os.cpu_count()} CPU cores; frame {SIZE[0]}x"
             f"{SIZE[1]}, bloom on; median (min-max) of {args.repeats} after a warm-up")
        have_ds = datashader_dejong(16) is not None
        if not have_ds:
            emit("datashader is not installed (pip install \".[bench]\"): its column is empty")
        scaling = {}
        for scene in args.scenes.split(","):
            emit()
            emit(f"## {scene}")
            emit()
            if scene == "fountain":
                fountain_section(ctx, sizes, args.repeats, emit)
                continue
            if scene == "backends":
                backends_section(ctx, args.repeats, emit)
                continue
            if scene == "accumulate":
                accumulation_section(ctx, emit, args.quick)
                continue
            if scene == "command":
                whole_command(emit, 5 if args.quick else 21)
                continue
            if scene == "dask":
                dask_section(emit, args.quick)
                continue
            if scene == "sample":
                sample_section(ctx, emit, args.repeats)
                continue
            if scene == "growth":  # cost against particles, image and sprite size: growth.py
                from growth import growth_section
                growth_section(ctx, emit, args.quick, args.repeats)
                continue
            if scene == "upsample":
                upsample_section(ctx, args.repeats, emit)
                continue
            if scene == "confetti":
                confetti_section(ctx, [12, 14] if args.quick else [12, 14, 16, 18],
                                 args.repeats, emit)
                continue
            if scene == "neighbours":
                neighbours_section(ctx, [12, 14] if args.quick else [12, 14, 16],
                                   [12] if args.quick else [12, 14], args.repeats, emit)
                continue
            if scene == "sph":
                sph_section(ctx, [0.05, 0.025] if args.quick else [0.05, 0.025, 0.0125],
                            args.repeats, emit)
                continue
            if scene == "liquid":
                liquid_section(ctx, [12, 14] if args.quick else [12, 14, 16], args.repeats, emit)
                continue
            if scene == "boids":
                boids_section(ctx, [12, 14] if args.quick else [12, 14, 16], args.repeats, emit)
                boids_section(ctx, [12, 14] if args.quick else [12, 14, 16], args.repeats, emit,
                              dimensions=3)
                continue
            if scene == "smoke":
                smoke_section(ctx, [14, 16] if args.quick else [14, 15, 16, 17, 18],
                              args.repeats, emit)
                continue
            emit("| N | stage | ours ms (min-max) | fps | numpy ms | numpy/ours | datashader ms | "
                 "datashader/ours |")
            emit("|---|---|---|---|---|---|---|---|")
            for log2n in sizes:
                count = 2 ** log2n
                mine, buffers = ours(ctx, scene, count, args.repeats)
                peer = numpy_peer(scene, count, args.repeats)
                ds = datashader_peer(count, args.repeats) if scene == "dejong" and have_ds else None
                scaling.setdefault(scene, []).append((count, mine["step"][0]))
                for stage in STAGES:
                    t = mine[stage]
                    p = peer[stage] if peer else None
                    d = ds[stage] if ds else None
                    fps = f"{1 / t[0]:.1f}" if stage == "frame" else ""
                    emit(f"| 2^{log2n} | {stage} | {t[0] * 1e3:.1f} ({t[1] * 1e3:.1f}-"
                         f"{t[2] * 1e3:.1f}) | {fps} | {fmt_ms(p)} | "
                         f"{'-' if p is None else f'{p[0] / t[0]:.2f}'} | {fmt_ms(d)} | "
                         f"{'-' if d is None else f'{d[0] / t[0]:.2f}'} |")
            emit()
            emit(f"GPU state per particle ({scene}, {', '.join(f'{q}: {n}' for q, n in buffers.items())}"
                 f" textures): " + ", ".join(
                     f"{f} {sum(buffers.values()) * bytes_per_texel(f)} B" for f in FORMAT_DTYPES) + "; plus 8 B of texel coordinates for drawing")
            counts, times = zip(*scaling[scene])
            if len(counts) >= 2:
                exponent = np.polyfit(np.log(counts), np.log(times), 1)[0]
                emit(f"Scaling of the {scene} step with N: time ~ N^{exponent:.2f}")
        if not args.quick:
            marks = host_memory_growth(ctx)
            emit()
            emit(f"Host memory (de Jong 2^16 animation): frame 10 {marks[10] / 2**20:.1f} MiB, "
                 f"frame 500 {marks[500] / 2**20:.1f} MiB")
    out = Path("out/bench")
    out.mkdir(parents=True, exist_ok=True)
    (out / "bench.md").write_text("\n".join(out_lines) + "\n")


if __name__ == "__main__":
    main()
