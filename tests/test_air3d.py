"""The 3D air (the flame's wind source, ``scenes/air.py`` in three dimensions): one step of the
MAC grid's passes (advection, the fire's carry, the body force with gusts, vorticity
confinement, buoyancy, the divergence, the 7-point pressure iterations and the projection) with
an obstacle and open, slip and no-slip sides, against an independent float64 reference
(``air3d_reference.py``) in each storage format; the burner's feed within its noise's bounds."""

import numpy as np
import pytest

import air3d_reference as ref
from es2particles import PassGraph, Simulation
from es2particles.scenes.air import Air, Fire

CODE = 1 / 65024  # a 16-bit code of a unit range
SHAPE = (9, 8, 7)  # W, H, D: odd, not cubic
LO, HI = (-0.6, 0.0, -0.5), (0.6, 1.4, 0.5)
WALLS = (2, 0, 0, 2, 1, 2)  # x: open, slip; y: slip (the floor), open; z: no-slip, open
STEP = dict(dt=1 / 30, force=(0.4, 0.0, -0.3), gusts=(0.5, 2.0), vorticity=1.5,
            keep=(0.97, 0.9), buoyancy=3.0, iterations=30, warm=0.5, step=7)


def solid():
    """A block of 2 x 2 x 2 cells off the centre."""
    d, h, w = SHAPE[::-1]
    out = np.zeros((d, h, w), bool)
    out[2:4, 3:5, 5:7] = True
    return out


def air(burner=(0.0, -5.0, 0.0, 0.1), advection="semi-lagrangian"):
    """The scene's Air (its burner out of the box by default: the carry alone) and the
    reference's."""
    s = STEP
    declared = Air(SHAPE, LO, HI, s["dt"], 4.0, WALLS, solid=solid(),
                   pressure_iterations=s["iterations"], warm_start=s["warm"],
                   vorticity=s["vorticity"], force=s["force"], gusts=s["gusts"],
                   fire=Fire(burner, keep=s["keep"], buoyancy=s["buoyancy"]),
                   advection=advection)
    return declared, ref.Air3(solid(), LO, HI, WALLS)


def start(reference):
    """A smooth wind on the faces (up to ~1.6 m/s, 0 on blocked ones), a pressure, and a fire
    blob (density and temperature in [0, 1])."""
    def wind(p):
        x, y, z = p[..., 0], p[..., 1], p[..., 2]
        return (0.9 + 0.6 * np.sin(3 * y + 1) * np.cos(2 * z), 0.7 * np.sin(2.5 * x + z),
                0.5 * np.cos(2 * x) * np.sin(3 * y))
    d, h, w = reference.shape
    faces = []
    for axis, (which, blocked) in enumerate(zip("uvw", reference.blocked())):
        shape = [d, h, w]
        shape[2 - axis] += 1
        faces.append(np.where(blocked, 0.0, wind(reference.points(which, shape))[axis]))
    c = reference.points("c", (d, h, w))
    r2 = (c[..., 0] ** 2 + (c[..., 1] - 0.5) ** 2 + c[..., 2] ** 2) / 0.2
    fire = np.stack([np.exp(-r2), 0.9 * np.exp(-1.5 * r2)], -1)
    pressure = 0.03 * np.sin(2 * c[..., 0]) * np.cos(3 * c[..., 1] + c[..., 2])
    return faces, pressure, fire


NAMES = ("u", "v", "w", "fire", "divergence", "pressure")


def gpu_step(ctx, declared, fmt, faces, pressure, fire, step):
    """The stored start and the GPU's quantities after one step from it."""
    g = PassGraph()
    declared.declare(g)
    with Simulation(ctx, g, None, outputs=NAMES, fmt=fmt) as sim:
        for name, value in zip(("u", "v", "w", "pressure", "fire"), (*faces, pressure, fire)):
            sim.upload(name, value if value.ndim == 4 else value[..., None])
        stored = {q: sim.download(q) for q in ("u", "v", "w", "pressure", "fire")}
        sim.steps_done = step  # the gusts' time: step * dt
        sim.step()
        after = {q: sim.download(q) for q in NAMES}
    squeeze = {q: a[..., 0] if a.shape[-1] == 1 else a for q, a in stored.items()}
    return squeeze, {q: a[..., 0] if a.shape[-1] == 1 else a for q, a in after.items()}


def reference_step(reference, stored, advection="semi-lagrangian"):
    s = STEP
    return ref.step(reference, stored["u"], stored["v"], stored["w"], stored["pressure"],
                    stored["fire"], s["dt"], s["keep"], s["force"], s["gusts"], s["step"],
                    s["buoyancy"], s["vorticity"], s["iterations"], s["warm"],
                    maccormack=advection == "maccormack")


@pytest.mark.parametrize("advection", ["semi-lagrangian", "maccormack"])
@pytest.mark.parametrize("fmt", ["rgba32f", "rgba16f", "rgba8"])
def test_one_3d_step_matches_float64(gl, fmt, advection):
    """The faces' error as a share of max |u|, against the format's bound, as the 2D wind's
    test derives it: float32 arithmetic; half floats' 11-bit significand on each of a face's
    writes (three; MacCormack's ahead and behind are two more) plus k pressure writes through
    the gradient (/dx); RGBA8's half code on each write likewise. The fire within its own
    format's rounding of [0, 1]: one write, or MacCormack's three (the correction adds the
    ahead's error, half the behind's, which holds the ahead's again, and its own)."""
    declared, reference = air(advection=advection)
    stored, got = gpu_step(gl, declared, fmt, *start(reference), STEP["step"])
    want = dict(zip(("u", "v", "w", "fire", "divergence", "pressure"),
                    reference_step(reference, stored, advection)))
    error = np.concatenate([(got[c] - want[c]).ravel() for c in "uvw"])
    scale = max(np.abs(want[c]).max() for c in "uvw")
    k, dx = STEP["iterations"], min(reference.cell)
    writes = 3 if advection == "semi-lagrangian" else 5
    bound = {"rgba32f": 2 ** -18 * scale,
             "rgba16f": (writes * 2 ** -10 * scale
                         + k * 2 ** -10 * np.abs(want["pressure"]).max() / dx),
             "rgba8": writes * 4.0 * CODE + k * declared.pressure_reach * CODE / dx}[fmt]
    print(f"{fmt}: max |u - u64| = {np.abs(error).max():.3e} ({np.abs(error).max() / scale:.2e} "
          f"of max |u| {scale:.2f}), bound {bound:.3e}; mean {error.mean():.2e}")
    assert np.abs(error).max() <= bound
    assert abs(error.mean()) <= {"rgba32f": 1e-7, "rgba16f": 2 ** -11 * scale,
                                 "rgba8": 2 * 4.0 * CODE}[fmt]
    for c, blocked in zip("uvw", reference.blocked()):  # walls and the obstacle hold
        assert np.all(got[c][blocked] == 0)
    fire_error = np.abs(got["fire"] - want["fire"]).max()
    # one write: float32's rounding; a half float's unit in [0.5, 1) (llvmpipe truncates);
    # half a code of [0, 1] each way, from the write and from the stored start's reads
    fire_bound = {"rgba32f": 2 ** -20, "rgba16f": 2 ** -11 + 2 ** -20, "rgba8": CODE}[fmt]
    fire_bound *= 1 if advection == "semi-lagrangian" else 3
    print(f"{fmt}: max |fire - fire64| = {fire_error:.3e}, bound {fire_bound:.3e}")
    assert fire_error <= fire_bound


def test_maccormack_s_limiter_takes_a_still_axis_own_cells(gl):
    """Air still along y (v = 0, u and w not) over a fire of noise, whose corrections the limiter
    cuts: the cells it takes are found as each cell's own index less its move, so
    on the still axis they are its own and the next (the reference's), not the row below where
    the backtrace's world point rounds under a grid line."""
    declared, reference = air(advection="maccormack")
    faces, pressure, _ = start(reference)
    faces[1] = np.zeros_like(faces[1])
    fire = np.random.default_rng(5).uniform(0.0, 1.0, reference.shape + (2,))
    stored, got = gpu_step(gl, declared, "rgba32f", faces, pressure, fire, STEP["step"])
    want = reference_step(reference, stored, "maccormack")[3]
    semi = reference_step(reference, stored)[3]
    error = np.abs(got["fire"] - want).max()
    print(f"max |fire - fire64| = {error:.2e}; MacCormack moved it by up to "
          f"{np.abs(want - semi).max():.2f} from the semi-Lagrangian")
    assert np.abs(want - semi).max() > 0.1  # the correction acts, and the limiter with it
    assert error <= 3 * 2 ** -20


def test_the_burner_feeds_the_fire_within_its_flicker(gl):
    """Still air, no fire, one step: where the flat ball of the burner holds a cell fully (its
    distance within 0.7 of the radius, half as high as wide) the fire rises to between 0.3 and
    1 of the feed (the noise's flicker takes up to 0.7), not the same everywhere; outside the
    ball it stays 0; between, it is at most the feed."""
    burner = (0.05, 0.3, -0.05, 0.5)
    declared, reference = air(burner)
    d, h, w = reference.shape
    faces = [np.zeros((d, h, w + 1)), np.zeros((d, h + 1, w)), np.zeros((d + 1, h, w))]
    _, got = gpu_step(gl, declared, "rgba32f", faces, np.zeros((d, h, w)),
                      np.zeros((d, h, w, 2)), 0)
    c = reference.points("c", (d, h, w))
    r = np.linalg.norm((c - burner[:3]) / (burner[3] * np.array([1.0, 0.5, 1.0])), axis=-1)
    fire, free = got["fire"], ~reference.solid
    inside, outside = (r <= 0.7) & free, (r >= 1.0) | ~free
    print(f"{inside.sum()} cells inside: fire {fire[inside].min(0)} to {fire[inside].max(0)}")
    assert inside.sum() >= 8
    assert np.all(fire[inside] >= 0.3 - 1e-6) and np.all(fire[inside] <= 1 + 1e-6)
    assert fire[inside].std(axis=0).min() > 0.01  # the flicker acts
    assert np.all(fire[outside] == 0) and np.all(fire <= 1 + 1e-6)
