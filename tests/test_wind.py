"""The wind scene (issue 39): its fluid step against an independent float64 reference
(``wind_reference.py``) in each storage format, the pressure solve against scipy's exact sparse
solve of the same discrete Poisson problem (the docs' divergence table, from saved states), a
channel's steady flow against Poiseuille's parabola, the particles kept out of obstacles, and
bad input refused in one line."""

import numpy as np
import pytest

import wind_reference as ref
from es2particles import Simulation
from es2particles.frame.pipeline import Pipeline
from es2particles.cli import main
from es2particles.scenes.wind import Wind

CODE = 1 / 65024  # a 16-bit code of a unit range
WALLS = {"slip": ref.SLIP, "noslip": ref.NOSLIP, "open": ref.OPEN}


def reference_air(scene):
    p = scene.params
    kinds, speeds = p.wall_uniforms
    return ref.Air(scene.solid, p.cell, walls=tuple(int(k) for k in kinds), speeds=speeds)


def swirl(air):
    """A smooth wind on the faces, up to ~2.4 m/s, still on blocked faces, and a pressure."""
    def field(x, y):
        return (1.5 + 0.8 * np.sin(3 * y + 1) * np.cos(2 * x),
                0.6 * np.sin(2.5 * x) * np.cos(4 * y))
    xb, yb = air.blocked()
    fu, fv = air.faces("u"), air.faces("v")
    u = np.where(xb, 0.0, field(fu[..., 0], fu[..., 1])[0])
    v = np.where(yb, 0.0, field(fv[..., 0], fv[..., 1])[1])
    h, w = air.shape
    dx, dy = air.cell
    x, y = np.meshgrid((np.arange(w) + 0.5) * dx, (np.arange(h) + 0.5) * dy)
    return u, v, 0.05 * np.sin(2 * x) * np.cos(3 * y)


# Every ghost at once: an open side, a no-slip one, a slip one, a moving lid; two obstacles.
STEP_SCENE = dict(grid="48x32", box=(1.5, 1.0), walls="open,noslip,slip,0.5",
                  obstacle="circle:0.5,0.45,0.12+box:1.1,0.7,0.08,0.05", pressure_iterations=30,
                  warm_start=0.5)


def one_step(ctx, scene, fmt, u0, v0, p0, step=7):
    """The GPU's u, v, divergence, pressure and centred wind after one step from (u0, v0, p0)
    as stored, and the stored start itself."""
    names = ("u", "v", "divergence", "pressure", "wind")
    with Simulation(ctx, scene.graph(), None, outputs=names, fmt=fmt) as sim:
        for name, value in zip("uvp", (u0, v0, p0)):
            sim.upload("pressure" if name == "p" else name, value[..., None])
        stored = [sim.download(q)[..., 0] for q in ("u", "v", "pressure")]
        sim.steps_done = step  # the gusts' time: step * dt
        sim.step()
        after = {q: sim.download(q) for q in names}
    return stored, {q: a[..., 0] if a.shape[-1] == 1 else a for q, a in after.items()}


def reference_step(scene, stored, advection="semi-lagrangian", step=7, **more):
    p, air = scene.params, reference_air(scene)
    return ref.step(air, *stored, p.dt, p.wind, p.gusts, step, p.pressure_iterations,
                    p.warm_start, advection=advection, **more)


@pytest.mark.parametrize("advection", ["semi-lagrangian", "maccormack"])
@pytest.mark.parametrize("fmt", ["rgba32f", "rgba16f", "rgba8"])
def test_one_fluid_step_matches_float64(gl, fmt, advection):
    """The velocity error of one step as a share of max |u|, against the format's bound: float32
    arithmetic (2^-18 of max |u|: a few dozen roundings of the step's sums); half floats' 11-bit
    significand on each of a face's three writes (a whole unit in the last place, 2^-10 of the
    value: llvmpipe converts to half by truncation, measured as errors up to 0.75 of a unit and
    a mean of -1.5e-4 of max |u|), plus k pressure writes' rounding through the gradient (/dx);
    RGBA8's half code on each write likewise (worst cases: every rounding the same way). The mean error is checked against one code: a half-code bias on the faces'
    writes (1.5 codes over three) fails it."""
    scene = Wind(**STEP_SCENE, advection=advection)
    p, air = scene.params, reference_air(scene)
    stored, got = one_step(gl, scene, fmt, *swirl(air))
    want_u, want_v, want_div, want_p = reference_step(scene, stored, advection)
    error = np.concatenate([(got["u"] - want_u).ravel(), (got["v"] - want_v).ravel()])
    scale = max(np.abs(want_u).max(), np.abs(want_v).max())
    k, dx = p.pressure_iterations, min(p.cell)
    bound = {"rgba32f": 2 ** -18 * scale,
             "rgba16f": 3 * 2 ** -10 * scale + k * 2 ** -10 * np.abs(want_p).max() / dx,
             "rgba8": 3 * p.max_speed * CODE + k * scene.pressure_reach * CODE / dx}[fmt]
    share = np.abs(error).max() / scale
    print(f"{fmt} {advection}: max |u - u64| = {np.abs(error).max():.3e} ({share:.2e} of max |u| "
          f"{scale:.2f}), bound {bound:.3e}; mean {error.mean():.2e}")
    assert np.abs(error).max() <= bound
    assert abs(error.mean()) <= {"rgba32f": 1e-7, "rgba16f": 2 ** -11 * scale,
                                 "rgba8": 2 * p.max_speed * CODE}[fmt]
    xb, yb = air.blocked()
    assert np.all(got["u"][xb] == 0) and np.all(got["v"][yb] == 0)  # walls and obstacles hold
    centred = ref.centres(air, got["u"], got["v"])
    # the centres' own write: float32, half a half-float ulp, half a code of [-U, U]
    tolerance = {"rgba32f": 0, "rgba16f": 2 ** -10 * scale, "rgba8": p.max_speed * CODE}[fmt]
    tolerance += 2 ** -22 * scale
    assert np.abs(got["wind"] - centred).max() <= tolerance


def test_the_fluid_step_catches_a_wrong_wall(gl):
    """The reference is sharp enough to see a wall's condition: the same step with the open
    side taken as a slip wall differs from the GPU's by far more than the bound."""
    scene = Wind(**STEP_SCENE)
    air = reference_air(scene)
    stored, got = one_step(gl, scene, "rgba32f", *swirl(air))
    p = scene.params
    closed = ref.Air(air.solid, air.cell, (ref.SLIP,) + air.walls[1:], air.speeds)
    wrong = ref.step(closed, *stored, p.dt, p.wind, p.gusts, 7, p.pressure_iterations,
                     p.warm_start)[0]
    assert np.abs(got["u"] - wrong).max() > 1e3 * 2 ** -18 * np.abs(wrong).max()


def test_viscosity_and_a_moving_lid_match_float64(gl):
    """The viscous iterations, with every wall's tangential ghost (the lid moves at 0.5 m/s)."""
    scene = Wind(**STEP_SCENE, viscosity=0.002, viscosity_iterations=7)
    air = reference_air(scene)
    stored, got = one_step(gl, scene, "rgba32f", *swirl(air))
    want_u, want_v, _, _ = reference_step(scene, stored, nu=0.002, viscosity_iterations=7)
    scale = max(np.abs(want_u).max(), np.abs(want_v).max())
    assert np.abs(got["u"] - want_u).max() <= 2 ** -18 * scale
    assert np.abs(got["v"] - want_v).max() <= 2 ** -18 * scale
    still = ref.Air(air.solid, air.cell, air.walls, (0.0, 0.0, 0.0, 0.0))
    p = scene.params
    wrong = ref.step(still, *stored, p.dt, p.wind, p.gusts, 7, p.pressure_iterations,
                     p.warm_start, nu=0.002, viscosity_iterations=7)[0]
    assert np.abs(got["u"] - wrong).max() > 100 * 2 ** -18 * scale  # the lid is felt


def saved_run(tmp_path, name, *options):
    """The arrays of a run's --save-state (a small wind, its particles few)."""
    state, out = tmp_path / f"{name}.npz", tmp_path / f"{name}.png"
    assert main(["run", "wind", "--particles", "1024", "--size", "32x32", *options,
                 "--save-state", str(state), "--out", str(out)]) == 0
    with np.load(state) as data:
        return {k: data[k] for k in data.files}


def divergence_table(tmp_path, iterations=(10, 20, 40, 80), steps=20, grid="64x64"):
    """Rows (k, warm, pressure error, rms divergence left, the exact solve's, before) of the
    last step of a run of ``steps`` steps, each from its saved state: the saved divergence is
    the step's right-hand side; scipy solves the same discrete Poisson problem exactly."""
    rows = []
    for warm in (0.0, 1.0):
        for k in iterations:
            s = saved_run(tmp_path, f"k{k}w{warm}", "--grid", grid, "--steps", str(steps),
                          "--format", "rgba32f", "--pressure-iterations", str(k),
                          "--warm-start", str(warm))
            scene = Wind(grid=grid)
            air = reference_air(scene)
            div, p = s["divergence"][..., 0], s["pressure"][..., 0]
            u, v = s["u"][..., 0], s["v"][..., 0]
            exact = ref.exact_pressure(air, div)
            # the faces before this step's projection, then projected by the exact pressure
            before = ref.project(air, u, v, -p)
            left = ref.divergence(air, u, v)
            left_exact = ref.divergence(air, *ref.project(air, *before, exact))
            fluid = ~air.solid

            def rms(a):
                return float(np.sqrt(np.mean(a[fluid] ** 2)))
            rows.append((k, warm, float(np.linalg.norm(p - exact) / np.linalg.norm(exact)),
                         rms(left), rms(left_exact), rms(div)))
    return rows


@pytest.mark.gl
@pytest.mark.slow
def test_the_pressure_solve_converges_to_scipys_and_the_warm_start_helps(tmp_path):
    """The docs' divergence table (docs/scenes/wind.md), from saved states: the pressure's error
    against the exact solve falls with the iterations, and starting from last step's pressure
    beats starting from zero at every count."""
    pytest.importorskip("scipy")
    rows = divergence_table(tmp_path)
    print("\n| iterations | warm start | pressure error | rms divergence left | exact solve's "
          "| before |")
    for k, warm, error, left, exact, before in rows:
        print(f"| {k} | {warm:g} | {error:.2e} | {left:.3g} | {exact:.3g} | {before:.3g} |")
    cold = {k: e for k, w, e, *_ in rows if w == 0}
    warm = {k: e for k, w, e, *_ in rows if w == 1}
    ks = sorted(cold)
    assert all(cold[a] > cold[b] for a, b in zip(ks, ks[1:]))
    assert all(warm[k] < cold[k] for k in ks)
    for k, w, error, left, exact, before in rows:
        # the exact solve leaves only float32's rounding of the saved faces
        assert exact <= 1e-5 * before < left < before


def test_a_channel_settles_to_poiseuilles_parabola(gl):
    """Air driven along a channel with no-slip floor and ceiling settles to u(y) = f y (H - y) /
    (2 nu). Against the discrete steady state (the tridiagonal system of the same stencil, its
    ghosts included) within the iterations' shortfall, and against the parabola within the
    stencil's O(dy^2) error at the walls (the ghost -u puts zero on the face to second order)."""
    f, nu, height, dt, steps = 8.0, 0.01, 0.1, 1 / 240, 300
    scene = Wind(grid="8x16", box=(0.05, height), walls="open,open,noslip,noslip",
                 obstacle="none", wind=(f, 0.0), gusts=(0.0, 1.0), viscosity=nu,
                 viscosity_iterations=50, dt=dt, lifetime=(0.1, 0.2))
    with Simulation(gl, scene.graph(), None, outputs=["u", "v"], fmt="rgba32f") as sim:
        sim.run(steps)
        u = sim.download("u")[..., 0]
        v = sim.download("v")[..., 0]
    n = 16
    dy = height / n
    y = (np.arange(n) + 0.5) * dy
    parabola = f * y * (height - y) / (2 * nu)
    # the discrete steady state: nu (u[j+1] - 2 u[j] + u[j-1]) / dy^2 = -f, ghosts -u
    matrix = np.diag(np.full(n, -2.0)) + np.diag(np.ones(n - 1), 1) + np.diag(np.ones(n - 1), -1)
    matrix[0, 0] = matrix[-1, -1] = -3.0
    discrete = np.linalg.solve(nu / dy ** 2 * matrix, np.full(n, -f))
    profile = u[:, 4]  # a face in the middle of the channel
    print(f"centre {profile.max():.4f} m/s; discrete {discrete.max():.4f}; parabola "
          f"{parabola.max():.4f}; max |u - discrete| / max {np.abs(profile - discrete).max() / discrete.max():.2e}; "
          f"|u - parabola| / max {np.abs(profile - parabola).max() / parabola.max():.2e}")
    assert np.abs(profile - discrete).max() <= 0.01 * discrete.max()
    assert np.abs(profile - parabola).max() <= 2 / n ** 2 * parabola.max() + 0.01 * discrete.max()
    assert np.abs(u - profile[:, None]).max() <= 1e-4 * profile.max()  # the same at every x
    assert np.abs(v).max() <= 1e-4 * profile.max()


BAD = [
    (["--grid", "5000x64"], "--grid W must be in [2, 4096] cells, got 5000"),
    (["--grid", "64by64"], "--grid must be WxH cells, e.g. 256x256, got '64by64'"),
    (["--pressure-iterations", "0"], "--pressure-iterations must be in [1, 10000], got 0"),
    (["--walls", "open,open,slip"], "--walls must be 4 values LEFT,RIGHT,BOTTOM,TOP, got 3"),
    (["--walls", "open,open,slip,wood"], "--walls top: must be slip, noslip, open or a speed"),
    (["--walls", "open,open,slip,9"], "--walls top: a moving wall's speed must be in [-4, 4]"),
    (["--obstacle", "circle:0.3,0.5"], "--obstacle must be circle:X,Y,R or box:X,Y,HX,HY"),
    (["--obstacle", "box:0.5,0.5,2,2"], "--obstacle fills the whole box: there is no air"),
    (["--viscosity", "1000"], "--viscosity 1000 gives nu dt / dx^2 = 1.09e+06"),
    (["--advection", "bfecc"], "--advection must be one of semi-lagrangian, maccormack"),
    (["--viscosity-iterations", "50"], "--viscosity-iterations solve the viscous diffusion, "
                                       "and --viscosity is 0"),
    (["--wind", "0,0", "--gusts", "1,3"], "--gusts vary the --wind force, which is 0,0"),
    (["--particles", "0", "--relax", "0.5"], "--relax: only the particles use it, and "
                                             "--particles 0 runs the grids alone"),
    (["--particles", "0", "--lifetime", "1,5"], "--lifetime: only the particles use it"),
    (["--particles", "0", "--point-size", "2"], "--point-size: scene 'wind' does not use this "
                                                "setting (it draws a grid quantity as an image)"),
    (["--particles", "-1"], "--particles must be in [0, inf], got -1"),
]


@pytest.mark.parametrize("options, said", BAD, ids=[" ".join(o) for o, _ in BAD])
def test_bad_input_is_one_line_naming_the_option(tmp_path, capsys, monkeypatch, options, said):
    monkeypatch.setenv("ES2PARTICLES_BACKEND", "nope")  # refused before any context
    out = tmp_path / "x.png"
    assert main(["run", "wind", *options, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert said in err and err.count("\n") == 1 and "Traceback" not in err, err
    assert list(tmp_path.iterdir()) == []


def test_an_obstacle_mask_that_is_no_png_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("ES2PARTICLES_BACKEND", "nope")
    mask = tmp_path / "mask.png"
    mask.write_bytes(b"%PDF-1.4\n")
    assert main(["run", "wind", "--obstacle", str(mask), "--out", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert f"--obstacle (a mask): {str(mask)!r} is not a PNG image: it is a PDF" in err, err
    assert err.count("\n") == 1


def test_a_drag_in_the_live_view_pushes_the_air(gl):
    """The window's and the widget's drag on a 2D scene with a Push: the air under the pointer
    takes its velocity (here 1.5 m/s to the right, against a still start), and nowhere far from
    it; after the button comes up the push stops."""
    from es2particles.live.view import LiveView

    times = iter(np.arange(0, 100, 0.05))
    scene = Wind(grid="64x64", obstacle="none", wind=(0.0, 0.0), walls="slip,slip,slip,slip")
    with Pipeline(gl, scene, particles=1024, size=(128, 128), steps=0) as pipeline:
        view = LiveView(pipeline, clock=lambda: float(next(times)))
        view.start()
        view.press(64, 64, (128, 128))  # the box's centre, (0.5, 0.5)
        view.move(74, 64, (128, 128))  # 10 pixels = 0.078 m in 0.05 s: 1.56 m/s to the right
        view.run_steps(1)
        wind = pipeline.sim.download("wind")
        view.release()
        view.run_steps(1)
        after = pipeline.sim.download("wind")
    near = wind[32, 36, 0]  # the cell under the pointer's new place, (0.57, 0.51)
    far = np.abs(wind[:, :8]).max()  # the left eighth of the box, 0.5 m away
    print(f"under the pointer {near:.3f} m/s, far {far:.2e} m/s")
    assert 1.0 < near <= 1.6 and far < 0.05
    assert np.abs(after).max() < np.abs(wind).max()  # no push once released: it spreads out


def test_a_taylor_green_vortex_decays_at_its_analytic_rate(gl):
    """u = U sin(pi x / L) cos(pi y / L), v = -U cos(pi x / L) sin(pi y / L) in a box of slip
    walls is a steady solution of Euler's equations (discretely divergence-free on the faces
    too); viscosity makes it decay as exp(-2 nu (pi / L)^2 t) (its energy twice as fast). Slow
    and viscous (U = 0.05 m/s, nu = 0.05 m^2/s), so the advection's own numerical diffusion is
    small against it: the measured rate is held to the analytic one within 2%, the size of
    implicit Euler's error (nu dt (pi / L)^2 = 0.8%) and the grid's (0.3%) with room."""
    n, length, nu, dt, steps, speed = 32, 1.0, 0.05, 1 / 60, 60, 0.05
    scene = Wind(grid=f"{n}x{n}", box=(length, length), walls="slip,slip,slip,slip",
                 obstacle="none", wind=(0.0, 0.0), viscosity=nu,
                 viscosity_iterations=60, dt=dt, lifetime=(0.1, 0.2))
    air = reference_air(scene)
    k = np.pi / length
    fu, fv = air.faces("u"), air.faces("v")
    u0 = speed * np.sin(k * fu[..., 0]) * np.cos(k * fu[..., 1])
    v0 = -speed * np.cos(k * fv[..., 0]) * np.sin(k * fv[..., 1])
    with Simulation(gl, scene.graph(), None, outputs=["u", "v"], fmt="rgba32f") as sim:
        sim.upload("u", u0[..., None])
        sim.upload("v", v0[..., None])
        start = np.sum(sim.download("u") ** 2) + np.sum(sim.download("v") ** 2)
        sim.run(steps)
        end = np.sum(sim.download("u") ** 2) + np.sum(sim.download("v") ** 2)
    rate = -np.log(end / start) / (steps * dt) / 2  # the amplitude's
    analytic = 2 * nu * k ** 2
    print(f"decay rate {rate:.4f} /s, analytic {analytic:.4f} /s ({rate / analytic - 1:+.2%})")
    assert abs(rate / analytic - 1) <= 0.02


@pytest.mark.gl
def test_air_held_at_the_range_s_edge_is_said_once(tmp_path, capsys):
    """Issue 39's formats: out-of-range velocities are clamped and counted. A wind of 80 m/s^2
    drives the air past --max-speed 4: the run says how many faces sit at the edge, once (by
    MacCormack's scheme too: its ahead and behind faces are not said again); the default run
    says nothing."""
    small = ["--grid", "64x64", "--particles", "1024", "--size", "64x64", "--steps", "30"]
    for advection in ("semi-lagrangian", "maccormack"):
        assert main(["run", "wind", *small, "--wind", "80,0", "--advection", advection,
                     "--out", str(tmp_path / "a.png")]) == 0
        err = capsys.readouterr().err
        assert err.count("faces' wind is at +-4 m/s, the range's edge") == 1, err
        assert err.count("range's edge") == 1, err
    assert main(["run", "wind", *small, "--out", str(tmp_path / "b.png")]) == 0
    assert "range's edge" not in capsys.readouterr().err


def test_a_scene_with_particles_refuses_none(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("ES2PARTICLES_BACKEND", "nope")
    assert main(["run", "dejong", "--particles", "0", "--out", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert "--particles must be in [1, inf], got 0" in err and err.count("\n") == 1, err


def test_the_air_alone_is_drawn_as_its_speed(gl):
    """``--particles 0``: no particle quantity is planned or saved, and each pixel of the
    picture is the gradient map at |wind| / --max-speed, |wind| bilinear at the pixel's centre
    from the saved cell-centred wind (scipy's map_coordinates, edges extended), with the
    obstacle's colour over it: within a code (the picture's rounding, half a code, and the
    ramp read LINEAR between its 256 entries: 8-bit weights move it by 2^-8 of a step between
    entries of a few codes)."""
    ndimage = pytest.importorskip("scipy.ndimage")
    from es2particles.io.ramps import load_ramp

    scene = Wind(grid="48x32", box=(1.5, 1.0), obstacle="circle:0.5,0.5,0.15")
    size = (150, 100)
    with Pipeline(gl, scene, particles=0, size=size, steps=30) as pipeline:
        assert set(pipeline.sim.buffers) == {"u", "v", "wind", "divergence", "pressure"}
        assert pipeline.sim.count == 0
        pipeline.begin(1)
        picture = pipeline.image().astype(float)
        wind = pipeline.state()["wind"]
    w, h = size
    x = (np.arange(w) + 0.5) / w * 1.5
    y = (np.arange(h)[::-1] + 0.5) / h * 1.0  # the picture's rows from the top
    gx, gy = np.meshgrid(x / 1.5 * 48 - 0.5, y * 32 - 0.5)
    speed = np.hypot(*(ndimage.map_coordinates(wind[..., k], [gy, gx], order=1, mode="nearest")
                       for k in (0, 1)))
    t = np.clip(speed / scene.params.max_speed, 0, 1) * 255
    ramp = np.asarray(load_ramp(scene.defaults.gradient), float)[:, :3]
    i = np.minimum(np.floor(t).astype(int), 254)
    want = ramp[i] + (t - i)[..., None] * (ramp[i + 1] - ramp[i])
    cx, cy = np.meshgrid(x, y)
    clear = np.hypot(cx - 0.5, cy - 0.5) > 0.15 + 2 / 32  # off the obstacle's cells and edge
    error = np.abs(picture - want)[clear]
    print(f"air alone: speeds up to {speed.max():.2f} m/s; picture vs float64 ramp: max "
          f"{error.max():.1f} codes, mean {error.mean():.2f}")
    assert speed.max() > 1.0  # the air moves: the ramp is exercised, not only its slow end
    assert error.max() <= 1
    inside = np.hypot(cx - 0.5, cy - 0.5) < 0.15 - 2 / 32
    assert np.all(np.abs(picture[inside] - (46, 58, 84)) <= 1)  # the obstacle over it


def test_particles_are_coloured_by_their_mean_speed(gl):
    """The wind's particles as density points coloured by speed (render/points.py's hue): each
    point adds its fade (1 - age / lifetime) into the density's first channel and its fade times
    min(|velocity| / --max-speed, 1) into the second, against float64 binning of the stored
    state (point size 1: pixel floor((p - view) / view size * size)); the picture is the
    gradient map at their mean (second over first) times a brightness full from 4 times an even
    spread's density, on the log curve below it, written in the test (bloom off)."""
    from es2particles.io.ramps import load_ramp

    scene = Wind(grid="32x32", obstacle="none")
    size, n = (64, 48), 3000
    rng = np.random.default_rng(77)
    with Pipeline(gl, scene, particles=n, size=size, steps=0, bloom=None) as pipeline:
        pipeline.begin(1)
        sim = pipeline.sim
        sim.upload("position", rng.uniform(0.01, 0.99, (n, 2)))
        sim.upload("velocity", rng.uniform(-3.5, 3.5, (n, 2)))  # some beyond 4 m/s: clamped
        lifetime = rng.uniform(2, 6, n)
        sim.upload("life", np.stack([rng.uniform(0, 1, n) * lifetime, lifetime], 1))
        p, v, life = (sim.download(q) for q in ("position", "velocity", "life"))
        pipeline.render()
        w, h = size
        got = np.frombuffer(pipeline.executor.read("density"), np.float32)
        got = got.reshape(h, w, 4)[..., :2].astype(np.float64)
        picture = pipeline.image().astype(float)
    fade = np.where((life[:, 0] >= 0) & (life[:, 0] < life[:, 1]), 1 - life[:, 0] / life[:, 1], 0)
    hue = np.minimum(np.hypot(v[:, 0], v[:, 1]) / scene.params.max_speed, 1)
    x = np.floor(p[:, 0] * w).astype(int)
    y = np.floor(p[:, 1] * h).astype(int)
    want = np.zeros((h, w, 2))
    np.add.at(want, (y, x, 0), fade)
    np.add.at(want, (y, x, 1), fade * hue)
    # The point's fragment shader is mediump: a driver may keep half float's 11-bit significand
    # (llvmpipe does, for the hue: measured up to 2^-10.4 of it), once in the hue and once in
    # the product, each within 2^-11 of its value: a pixel's sums are within 2^-10 of its
    # density, the sum of its points' fades.
    error = np.abs(got - want)
    share = (error / np.maximum(want[..., :1], 1e-3)).max()
    print(f"density and speed sums: max |error| {error.max():.2e}, {share:.2e} of the pixel's "
          f"density (bound {2 ** -10:.2e})")
    assert np.all(error <= 2 ** -10 * want[..., :1] + 1e-7)
    mean = np.divide(want[..., 1], want[..., 0], out=np.zeros((h, w)), where=want[..., 0] > 0)
    even = n / (w * h)
    bright = np.clip(np.log1p(4 * want[..., 0] / even) / np.log1p(4 * 4), 0, 1)
    ramp = np.asarray(load_ramp(scene.defaults.gradient), float)[:, :3]
    t = np.clip(mean, 0, 1) * 255
    i = np.minimum(np.floor(t).astype(int), 254)
    colour = bright[..., None] * (ramp[i] + (t - i)[..., None] * (ramp[i + 1] - ramp[i]))
    off = np.abs(picture[::-1] - colour)  # the picture's rows from the top
    print(f"picture against float64: max {off.max():.2f} codes, mean {off.mean():.3f}")
    assert np.all(off <= 1.5)
