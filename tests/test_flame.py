"""The flame (issue 42, item 2): the blackbody ramp against Planck's and Stefan-Boltzmann's laws
written here; the march through a uniform grid, and through a uniform fire in the state (the
wind source's), against the closed form of emission and absorption over each ray's chord (rays
and box written here); the smoke flame's splat against its particles binned in float64; the
wind flame's fire rising from its burner; the march's error against a 256-step reference (the
docs' table); and the options' refusals. The wind source's air step against float64:
``test_air3d.py``."""

import numpy as np
import pytest

from conftest import command
from es2particles.frame.pipeline import Pipeline
from es2particles.render.flame import RAMP_KELVIN, ramp_image
from es2particles.scenes.flame import Flame, FlameParams

H, C, K_B = 6.62607015e-34, 2.99792458e8, 1.380649e-23  # CODATA 2018, exact


def _blackbody(kelvin):
    """(n, 3): Planck's radiance at 610, 550 and 465 nm, its brightest channel 1, times
    (T / 3000 K)^4."""
    lam = np.array([610e-9, 550e-9, 465e-9])
    t = np.asarray(kelvin, float)[:, None]
    radiance = 1 / lam ** 5 / (np.exp(H * C / (lam * K_B * t)) - 1)
    return radiance / radiance.max(axis=1, keepdims=True) * (t / 3000.0) ** 4


def test_the_ramp_is_a_blackbody():
    """Every texel within half a code of the law; hotter is brighter and whiter (green over
    red rises); 1,000 K is a dim red."""
    ramp = ramp_image()[0, :, :3].astype(float)
    want = _blackbody(np.linspace(1000.0, 3000.0, 256)) * 255
    assert RAMP_KELVIN == (1000.0, 3000.0)
    assert np.abs(ramp - want).max() <= 0.5 + 1e-9
    assert np.all(np.diff(want.sum(axis=1)) > 0) and np.all(np.diff(want[:, 1] / want[:, 0]) > 0)
    assert ramp[0].tolist() == [3.0, 0.0, 0.0]


class UniformGrid(Flame):
    """The smoke flame with its particles placed by hand: PER of them at the centre of each of
    the grid's cells, just born (heat 1); no step runs, so the field is uniform."""

    PER = 2

    def start(self, count, rng):
        lo, hi = (np.array(v) for v in self.params.box)
        n = self.params.cells
        cell = np.arange(count) % n ** 3
        ijk = np.stack([cell % n, cell // n % n, cell // n ** 2], axis=1)
        return {"position": lo + (ijk + 0.5) / n * (hi - lo),
                "life": np.tile([0.0, 1.0], (count, 1))}


def _rays(camera, size):
    """Unit ray directions (h, w, 3) through the pixel centres, GL's rows (0 at the bottom),
    from a look-at and the vertical field of view written here."""
    w, h = size
    eye, target = np.array(camera.eye, float), np.array(camera.target, float)
    f = (target - eye) / np.linalg.norm(target - eye)
    s = np.cross(f, camera.up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    k = np.tan(np.radians(camera.fov) / 2)
    y, x = np.mgrid[0:h, 0:w] + 0.5
    d = (f + ((2 * x / w - 1) * k * w / h)[..., None] * s + ((2 * y / h - 1) * k)[..., None] * u)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _chords(eye, rays, lo, hi):
    """Each ray's length inside the box [lo, hi], by its slabs (float64)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = (np.asarray(lo) - eye) / rays, (np.asarray(hi) - eye) / rays
    t0 = np.maximum(np.nanmax(np.minimum(a, b), axis=-1), 0)
    t1 = np.nanmin(np.maximum(a, b), axis=-1)
    return np.maximum(t1 - t0, 0)


def _rgba8(pipeline, name):
    w, h = pipeline.plan.resources[name].size
    return np.frombuffer(pipeline.executor.read(name), np.uint8).reshape(h, w, 4).astype(float)


class UniformFire(Flame):
    """The wind flame with its fire set by hand: density RHO and temperature 1 in every cell;
    no step runs, so the field is uniform."""

    RHO = 0.375

    def start(self, count, rng):
        n = self.params.cells
        return {"fire": np.broadcast_to([self.RHO, 1.0], (n, n, n, 2))}


def _closed_form_holds(scene, p, size, rho):
    """Density rho in every cell: along a chord c, L = (E / K) B (1 - exp(-K rho c)) + background
    exp(-K rho c) and the picture 1 - exp(-L), exact at any step count. Within the ramp's
    rounding (half a code, carried through the curve) and the output's conversion: 0.6 of a code,
    Direct3D's tolerance for float to 8-bit (D3D12_FLOAT32_TO_INTEGER_TOLERANCE_IN_ULP; GL
    allows either neighbouring code): an H200 went 0.03 of a code past half a code where
    llvmpipe rounds to nearest. The mean error stays within a tenth of a code: a
    half-code bias fails."""
    rendering = scene.rendering()
    next(p.frames())
    got = _rgba8(p, "flame")[..., :3] / 255
    camera = p.camera(0, 1)
    chord = _chords(np.array(camera.eye), _rays(camera, size), *scene.params.box)
    through = np.exp(-scene.params.extinction * rho * chord)[..., None]
    ratio = scene.params.emission / scene.params.extinction
    light = ratio * _blackbody([3000.0]) * (1 - through) + np.array(rendering.background) * through
    want = 1 - np.exp(-light)
    assert (chord > 0).mean() > 0.3 and chord.max() > 3  # the box fills much of the picture
    slack = 0.6 / 255 + np.exp(-light) * ratio * (1 - through) * 0.5 / 255 + 1e-4
    error = got - want
    print(f"mean {error.mean() * 255:+.3f} codes, max {np.abs(error).max() * 255:.2f}")
    assert np.all(np.abs(error) <= slack)
    assert abs(error.mean()) < 0.1 / 255


VIEW = dict(extinction=1.5, emission=3.0, eye=(2.5, 2.6, 4.2), target=(0.0, 1.5, 0.0))


@pytest.mark.parametrize("steps, jitter", [(1, "off"), (7, "on")])
def test_a_uniform_grid_is_the_closed_form(gl, steps, jitter):
    """The smoke source's splatted grid, uniform: the closed form (``_closed_form_holds``)."""
    n, size = 8, (96, 64)
    scene = UniformGrid(source="smoke", cells=n, march_steps=steps, march_jitter=jitter, **VIEW)
    with Pipeline(gl, scene, particles=UniformGrid.PER * n ** 3, size=size, steps=0) as p:
        _closed_form_holds(scene, p, size, UniformGrid.PER * scene.rendering().per_particle)


@pytest.mark.parametrize("fmt", ["rgba8", "rgba32f"])
def test_a_uniform_fire_in_the_state_is_the_closed_form(gl, fmt):
    """The wind source's march reads the fire from the state (its generated trilinear sample of
    the 3D grid, decoding 16-bit codes in RGBA8): uniform, it is the same closed form."""
    n, size = 6, (96, 64)
    scene = UniformFire(source="wind", cells=n, march_steps=5, march_jitter="on", **VIEW)
    with Pipeline(gl, scene, size=size, steps=0, fmt=fmt, rounding="nearest") as p:
        _closed_form_holds(scene, p, size, UniformFire.RHO)


def test_the_wind_flame_rises_from_its_burner(gl):
    """From still air the fire fed at the burner rises as a column: after two seconds (16^3
    cells) the air in the column over the burner moves up at over 1 m/s a metre up, its fire
    has reached above 1.5 m and not yet 2.5 m (its front moves at about the air's speed), and
    none is beside the column; a stronger buoyancy lifts its front higher."""
    def column(**given):
        scene = Flame(source="wind", cells=16, **given)
        with Pipeline(gl, scene, size=(16, 16), steps=60) as p:
            next(p.frames())
            fire, v = p.sim.download("fire"), p.sim.download("v")[..., 0]
        lo, hi = scene.params.box
        y = (np.arange(16) + 0.5) / 16 * (hi[1] - lo[1]) + lo[1]
        middle = slice(6, 10)  # over the burner at the box's centre
        heat = fire[middle, :, middle, 1].mean(axis=(0, 2))
        front = y[heat > 0.01].max()
        return front, y, v[middle, :16, middle].mean(axis=(0, 2)), fire
    front, y, rise, fire = column()
    print(f"the fire's front at {front:.2f} m; the column rises at {rise[4]:.2f} m/s at "
          f"{y[4]:.2f} m")
    assert 1.5 < front < 2.5 and rise[4] > 1.0
    assert fire[:, :, :3, 1].max() < 1e-3 and fire[:, :, -3:, 1].max() < 1e-3  # not beside it
    assert column(buoyancy=20.0)[0] > front


@pytest.mark.slow
def test_the_wind_flame_is_stable_at_its_defaults_and_says_when_it_is_not(gl):
    """Ten seconds of the wind flame (24^3 cells, 300 steps): at the defaults its air stays well
    inside its range (measured: 3.7 m/s at most of 8), and so does MacCormack's without
    confinement (5.1 m/s); with confinement eight times as strong (--vorticity 8), or
    MacCormack's at the default confinement, the curls grow until the air sits on the range's
    edge (measured by 120 steps), and the run's end says so, naming the options to change."""
    def run(**given):
        scene = Flame(source="wind", cells=24, **given)
        with Pipeline(gl, scene, size=(16, 16), steps=300) as p:
            next(p.frames())
            fastest = max(np.abs(p.sim.download(c)).max() for c in "uvw")
            return fastest, scene.after_run(p.sim)
    fastest, said = run()
    print(f"defaults: {fastest:.2f} m/s at most; ", end="")
    assert fastest < 0.7 * 8.0 and said == []
    fastest, said = run(advection="maccormack", vorticity=0.0)
    print(f"MacCormack, no confinement: {fastest:.2f} m/s")
    assert fastest < 0.8 * 8.0 and said == []
    for given in ({"vorticity": 8.0}, {"advection": "maccormack"}):
        fastest, said = run(**given)
        print(f"{given}: {fastest:.2f} m/s; {said}")
        assert fastest == pytest.approx(8.0, abs=0.01)
        (line,) = said  # the faces alone: MacCormack's ahead and behind are not said again
        assert "written beyond it and clamped" in line and "--vorticity" in line
        assert ("--advection maccormack" in line) == ("advection" in given)


def test_the_wind_flame_s_seed_stirs_its_start(gl):
    """The seed draws the start's stir of the air (at most 0.02 m/s a face, blocked faces
    still), so two seeds make two fires; the same seed the same bytes."""
    def fire(seed):
        with Pipeline(gl, Flame(source="wind", cells=8), size=(16, 16), steps=20,
                      seed=seed) as p:
            next(p.frames())
            return p.sim.download("fire")
    a, b = fire(1), fire(2)
    assert np.array_equal(a, fire(1)) and not np.array_equal(a, b)
    start = Flame(source="wind", cells=8).start(0, np.random.default_rng(3))
    floor = start["v"][:, 0]
    assert np.all(floor == 0) and 0.015 < np.abs(start["u"]).max() <= 0.02


def test_the_splat_counts_the_particles_in_each_cell(gl):
    """The smoke flame's grid after 40 steps: each cell's count and heat are those of the live
    particles read back and binned here in float64 (positions on a cell's face may fall either
    way: at most 1 in 2,000 particles)."""
    scene = Flame(source="smoke", cells=16)
    with Pipeline(gl, scene, particles=2 ** 13, size=(32, 32), steps=40) as p:
        next(p.frames())
        position, life = p.sim.download("position"), p.sim.download("life")
        resource = p.plan.resources["flame grid"]
        w, h = resource.size
        grid = np.frombuffer(p.executor.read("flame grid"), np.float32).reshape(h, w, 4)
    assert resource.format == "rgba32f"
    lo, hi = (np.array(v) for v in scene.params.box)
    n = 16
    alive = (life[:, 0] >= 0) & (life[:, 0] < life[:, 1])
    cell = np.floor((position - lo) / (hi - lo) * n).astype(int)
    inside = alive & np.all((cell >= 0) & (cell < n), axis=1)
    assert inside.sum() > 0.5 * len(position)
    across = int(np.ceil(np.sqrt(n)))
    counts, heat = np.zeros((h, w)), np.zeros((h, w))
    i, j, k = cell[inside].T
    rows, cols = (k // across) * n + j, (k % across) * n + i
    np.add.at(counts, (rows, cols), 1)
    np.add.at(heat, (rows, cols), 1 - life[inside, 0] / life[inside, 1])
    assert counts.sum() == grid[..., 0].sum()
    assert np.abs(grid[..., 0] - counts).sum() <= 2 * len(position) / 2000
    assert np.abs(grid[..., 1] - heat).sum() <= 2 * len(position) / 2000 + 1e-3 * heat.sum()


def _flame(gl, size=(128, 128), **options):
    with Pipeline(gl, Flame(**options), size=size, steps=30) as p:
        next(p.frames())
        return p.image().astype(float)


@pytest.mark.slow
def test_the_march_converges_to_the_reference(gl):
    """The docs' table (docs/scenes/flame.md): 16, 32 and 64 jittered steps and the author's
    128 against 256 unjittered steps, in codes: each doubling errs less, and 64 jittered steps
    stay within 1 code on average."""
    reference = _flame(gl, march_steps=256, march_jitter="off")
    errors = {steps: np.abs(_flame(gl, march_steps=steps) - reference).mean()
              for steps in (16, 32, 64, 128)}
    print({k: round(v, 3) for k, v in errors.items()})
    assert errors[16] > errors[32] > errors[64] > errors[128]
    assert errors[64] < 1.0


def test_accumulated_marches_are_the_mean_of_the_steps_marches(gl):
    """--accumulate K: the picture is the mean of the K single marches of this step and the
    next K-1 (each drawn alone here, its dither's phase moved a step), within the rounding of
    those single pictures to codes (half a code each way); with the noise still (--rise 0) the
    16 dithered segments' error against 256 midpoint segments falls by more than half."""
    still = dict(march_steps=16, rise=0.0)
    with Pipeline(gl, Flame(**still), size=(96, 96), steps=30) as p:
        p.warm_up()
        singles = []
        for _ in range(8):
            p.render()
            singles.append(p.image().astype(float))
            p.step(1)
    with Pipeline(gl, Flame(**still), size=(96, 96), steps=30, accumulate=8) as p:
        p.warm_up()
        p.render()
        averaged = p.image().astype(float)
    off = np.abs(averaged - np.mean(singles, axis=0))
    print(f"accumulated against the singles' mean: max {off.max():.2f}, mean {off.mean():.3f}")
    assert off.max() <= 1.0
    assert abs((averaged - np.mean(singles, axis=0)).mean()) < 0.05
    reference = _flame(gl, size=(96, 96), march_steps=256, march_jitter="off", rise=0.0)
    single, mean = (np.abs(x - reference).mean() for x in (singles[0], averaged))
    print(f"16 dithered segments against 256 midpoints: one march {single:.3f} codes, eight "
          f"averaged {mean:.3f}")
    assert mean < single / 2


def test_the_flame_lights_its_shafts(gl):
    """--shafts on: the shafts' source is the flame's own picture, texel for texel (nothing in
    front of it), and the composite only adds light, most near the flame."""
    with Pipeline(gl, Flame(shafts="on"), size=(96, 96), steps=30) as p:
        p.warm_up()
        p.render()
        lit = p.image().astype(int)
        source, flame = (np.frombuffer(gl.read(p.executor.front(name), components=3),
                                       np.uint8) for name in ("shaft occluders", "flame"))
    assert np.array_equal(source, flame)
    plain = np.frombuffer(flame, np.uint8).reshape(96, 96, 3)[::-1].astype(int)
    added = lit - plain
    assert added.min() >= -1 and added.mean() > 1
    bright = plain.max(axis=2) > 100
    near = np.zeros_like(bright)
    ys, xs = np.nonzero(bright)
    near[max(ys.min() - 8, 0):ys.max() + 9, max(xs.min() - 8, 0):xs.max() + 9] = True
    assert added[near & ~bright].mean() > 1.5 * added[~near].mean()  # 35 against 20 codes


def test_every_flame_option_acts(gl):
    """Each option of the noise flame, moved off its default, changes the picture."""
    base = _flame(gl, size=(48, 48))
    idle = [name for name, value in {
        "march_steps": 20, "march_jitter": "off", "dt": 0.05, "extinction": 1.0,
        "emission": 4.0, "shape": (0.5, 1.8, 0.3, 3.0), "rise": 0.5,
        "eye": (1.0, 1.4, 5.0), "target": (0.0, 1.0, 0.0), "fov": 40.0}.items()
        if np.array_equal(_flame(gl, size=(48, 48), **{name: value}), base)]
    assert not idle


def test_every_wind_flame_option_acts(gl):
    """Each option only the wind source uses, moved off its default, changes the picture."""
    def picture(**given):
        scene = Flame(source="wind", **{"cells": 10, **given})
        with Pipeline(gl, scene, size=(48, 48), steps=40) as p:
            next(p.frames())
            return p.image()
    base = picture()
    idle = [name for name, value in {
        "cells": 12, "burner": (0.2, 0.1, 0.0, 0.6), "buoyancy": 4.0, "cooling": (3.0, 0.6),
        "vorticity": 3.0, "pressure_iterations": 2, "max_speed": 0.5,
        "advection": "maccormack"}.items()
        if np.array_equal(picture(**{name: value}), base)]
    assert not idle


@pytest.mark.parametrize("words, named", [
    (["--source", "fire"], "--source"),
    (["--march-steps", "0"], "--march-steps"),
    (["--march-steps", "1025"], "--march-steps"),
    (["--march-jitter", "maybe"], "--march-jitter"),
    (["--cells", "32"], "--cells"),
    (["--source", "smoke", "--rise", "2"], "--rise"),
    (["--particles", "1000"], "--particles"),
    (["--format", "rgba32f"], "--format"),
    (["--source", "wind", "--particles", "1000"], "--particles"),
    (["--source", "wind", "--shape", "0.5,2,0.3,3"], "--shape"),
    (["--source", "smoke", "--buoyancy", "2"], "--buoyancy"),
    (["--advection", "maccormack"], "--advection"),
    (["--burner", "0,0.1,0,0.2"], "--burner"),
    (["--source", "wind", "--burner", "0,0.1,0,2"], "--burner"),
    (["--source", "wind", "--cooling", "-1,0"], "--cooling"),
    (["--source", "wind", "--pressure-iterations", "0"], "--pressure-iterations"),
])
def test_bad_flame_options_are_one_line(tmp_path, words, named):
    out = tmp_path / "x.png"
    code, lines = command("run", "flame", "--size", "32x32", *words, "--out", str(out))
    assert code == 2 and len(lines) == 1 and named in lines[0], lines
    assert not out.exists()


def test_the_noise_flame_has_no_particles():
    """Its plan has no state and no pass; the box holds the flame's reach."""
    from es2particles.frame.plan import plan_frame

    plan = plan_frame(Flame())
    assert not [r for r in plan.resources.values() if r.kind == "state"]
    assert [s.name for s in plan.stages] == ["flame"]
    lo, hi = FlameParams().box
    assert hi[1] == pytest.approx(2.0 + 1.5 * 0.3) and lo[0] == pytest.approx(-(0.45 + 0.45))
