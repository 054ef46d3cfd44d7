"""The smoke scene's air velocity (lib/noise.glsl, lib/flow.glsl): the float64 twin against finite
differences of itself (the noise's analytic gradient, zero divergence, the closed-form curl, no
flow through the sphere), then the GPU's float32 and 16-bit packed results against the twin."""

import subprocess

import numpy as np
import pytest

from conftest import glslang, shader
from es2particles import PassGraph, Simulation
from es2particles.gl.bindings import pass_interface
from es2particles.gl.shaders import expand
from es2particles.twins import flow

EPS32 = 2.0 ** -24  # float32 unit roundoff
EPS64 = 2.0 ** -53
CENTRE = np.array([0.3, 1.1, -0.2])
RADIUS = 1.0
WIND = np.array([1.5, 0.2, -0.3])
SPHERE_V = np.array([0.4, -0.8, 0.6])
NOISE = np.array([0.5, 1.3, 0.6, 0.0])  # amplitude, spatial frequency, ramp distance, unused
OFFSET = np.array([2.5, -1.7, 4.1])
H_NOISE = flow.NOISE_HESSIAN_BOUND  # of simplex3: |gradient| and Hessian spectral norm
G_NOISE = flow.NOISE_GRADIENT_BOUND


def directions(rng, n):
    d = rng.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def around_sphere(rng, n, lo, hi):
    """n points at distances in [lo, hi] from the sphere's centre."""
    return CENTRE + directions(rng, n) * rng.uniform(lo, hi, n)[:, None]


def central_jacobian(f, x, h):
    """J[:, i, j] = d f_i / d x_j of f: (n, 3) -> (n, 3) by central differences at step h."""
    return np.stack([(f(x + h * e) - f(x - h * e)) / (2 * h) for e in np.eye(3)], axis=-1)


def air(x):
    return flow.air_velocity(x, CENTRE, RADIUS, WIND, SPHERE_V, NOISE, OFFSET)


def noise_part(x):
    return flow.curl_noise(x, OFFSET, NOISE[1], CENTRE, RADIUS, NOISE[2])


def sphere_part(x):
    return flow.sphere_flow(x, CENTRE, RADIUS, WIND, SPHERE_V)


# --- the noise, float64 ----------------------------------------------------------------------

def test_simplex_gradient_is_the_derivative_of_its_value():
    """Central differences at h and 2h: D(h) - f' = h^2/6 f''' + O(h^4), so (D(2h) - D(h)) / 3
    measures D(h)'s truncation at each point, and the analytic gradient must lie within it (half
    as much again for the O(h^4) rest); a wrong gradient would be off by O(1) instead."""
    rng = np.random.default_rng(0)
    p = rng.uniform(-40, 40, (20_000, 3))
    h = 1e-3
    _, gradient = flow.simplex3(p)
    value = lambda q: flow.simplex3(q)[0][:, None]  # noqa: E731
    d1 = central_jacobian(value, p, h)[:, 0]
    d2 = central_jacobian(value, p, 2 * h)[:, 0]
    truncation = np.abs(d2 - d1) / 3
    rounding = 4 * EPS64 * 40 / h  # |value| <= 1, its argument's rounding (|p| <= 40) over h
    error = np.abs(d1 - gradient)
    excess = (error - 1.5 * truncation - rounding).max()
    print(f"max |D(h) - gradient| {error.max():.2e}, max h^2 term {truncation.max():.2e}")
    assert excess <= 0, f"gradient off its central difference by {excess:.2e} beyond truncation"
    assert error.max() < 1e-5 * np.abs(gradient).max()


def test_simplex_values_fill_but_stay_in_the_unit_range():
    rng = np.random.default_rng(1)
    value, gradient = flow.simplex3(rng.uniform(-100, 100, (200_000, 3)))
    top, std = np.abs(value).max(), value.std()
    print(f"max |value| {top:.4f}, mean {value.mean():.4f}, std {std:.3f}, "
          f"max |gradient| {np.linalg.norm(gradient, axis=1).max():.2f}")
    assert 0.9 < top <= 0.9886  # 76 x the largest raw sum, 0.0130072 (twins/flow.py)
    assert std > 0.3 and abs(value.mean()) < 0.01


def test_simplex_is_continuous_with_a_continuous_gradient():
    """Along lines crossing hundreds of simplex faces in steps of 1e-4: each step's change is the
    trapezoid rule of the gradient, with a residual O(step^3 f''') (~1e-11); Perlin's radius 0.6
    leaves jumps of ~5e-3 at faces, which no step size shrinks. The gradient changes by at most
    H_NOISE x step (its derivative is bounded: C1)."""
    rng = np.random.default_rng(2)
    step = 1e-4
    worst_value = worst_gradient = biggest_change = 0.0
    for _ in range(3):
        d = directions(rng, 1)[0]
        p = rng.uniform(-10, 10, 3) + np.arange(100_000)[:, None] * step * d
        value, gradient = flow.simplex3(p)
        along = gradient @ d
        change = np.diff(value)
        trapezoid = 0.5 * (along[1:] + along[:-1]) * step
        worst_value = max(worst_value, np.abs(change - trapezoid).max())
        jump = np.linalg.norm(np.diff(gradient, axis=0), axis=1).max()
        worst_gradient = max(worst_gradient, jump)
        biggest_change = max(biggest_change, np.abs(change).max())
    print(f"largest step change {biggest_change:.2e}, trapezoid residual {worst_value:.2e}, "
          f"gradient change {worst_gradient:.2e}")
    assert biggest_change <= G_NOISE * step
    assert worst_value < step ** 2 * G_NOISE, worst_value  # far above O(step^3), below a jump
    assert worst_gradient <= H_NOISE * step * (1 + 1e-6), worst_gradient


def test_simplex_derivative_bounds():
    """The bounds the GPU tolerances use (twins/flow.py): the largest |gradient| and Hessian
    spectral norm (by central differences of the analytic gradient) at random points are within
    them, and near them."""
    rng = np.random.default_rng(3)
    p = rng.uniform(-50, 50, (50_000, 3))
    gradient = np.linalg.norm(flow.simplex3(p)[1], axis=1).max()
    hessian = central_jacobian(lambda q: flow.simplex3(q)[1], p, 1e-5)
    largest = np.abs(np.linalg.eigvalsh(0.5 * (hessian + hessian.transpose(0, 2, 1)))).max()
    print(f"largest |gradient| {gradient:.3f} (bound {G_NOISE}), |Hessian| {largest:.2f} "
          f"(bound {H_NOISE})")
    assert 0.95 * G_NOISE < gradient <= G_NOISE
    assert 0.95 * H_NOISE < largest <= H_NOISE


def test_simplex_repeats_every_289_cells():
    """The hash sees each lattice coordinate mod 289 (negative ones too): shifting p by 289 cells
    along a lattice axis, (289, 0, 0) unskewed, gives the same noise."""
    rng = np.random.default_rng(4)
    p = rng.uniform(-30, 30, (5000, 3))
    period = np.array([289.0, 0.0, 0.0]) - 289.0 * flow.G3
    for shift in (period, -period, period[[1, 0, 2]] * 2):
        a, ga = flow.simplex3(p)
        b, gb = flow.simplex3(p + shift)
        assert np.abs(a - b).max() < 1e-9 and np.abs(ga - gb).max() < 1e-8


# --- the field, float64 ----------------------------------------------------------------------

def divergence(f, x, h):
    return np.trace(central_jacobian(f, x, h), axis1=1, axis2=2)


def flow_points(rng, n, h):
    """Outside the sphere, a third in the noise's ramp band; clear by 4h of the sphere (the
    stencil stays outside) and of the band's outer edge, where alpha is only C2, the velocity
    C1, and a central difference's error O(h) rather than O(h^2)."""
    edge = RADIUS + NOISE[2]
    x = np.concatenate([around_sphere(rng, n // 3, RADIUS + 4 * h, edge - 4 * h),
                        around_sphere(rng, n - n // 3, edge + 4 * h, 4 * RADIUS)])
    return x


@pytest.mark.parametrize("name, field", [("sphere_flow", sphere_part),
                                         ("curl_noise", noise_part), ("air_velocity", air)])
def test_the_field_is_divergence_free(name, field):
    """div u by central differences is all truncation, h^2/6 sum d^3u_i/dx_i^3: at h/2 it falls 4x,
    and the Richardson combination (4 D(h/2) - D(h)) / 3 leaves O(h^4) and rounding, at most
    points ~1e-10 of the velocity gradient. Where the stencil straddles a kernel's edge
    (|d|^2 = 0.5, about one point in ten: the noise is C3 there, so the h^2 term jumps) it leaves
    up to ~1e-6. A divergence in the closed forms would stay at any h."""
    rng = np.random.default_rng(5)
    h = 2e-3
    x = flow_points(rng, 3000, h)
    gradient = np.linalg.norm(central_jacobian(field, x, h), axis=(1, 2)).max()
    d_h, d_half = divergence(field, x, h), divergence(field, x, h / 2)
    richardson = np.abs(4 * d_half - d_h) / 3
    ratio = np.median(np.abs(d_h) / np.maximum(np.abs(d_half), 1e-300))
    rounding = 6 * EPS64 * np.abs(field(x)).max() / (h / 2)
    print(f"{name}: max |div| at h {np.abs(d_h).max():.2e}, at h/2 {np.abs(d_half).max():.2e} "
          f"(median ratio {ratio:.2f}); Richardson median {np.median(richardson):.1e}, max "
          f"{richardson.max():.1e}; max |grad u| {gradient:.2f}")
    assert 3.5 < ratio < 4.5
    assert np.median(richardson) < 1e-9 * gradient + rounding
    assert richardson.max() < 1e-5 * gradient + rounding
    assert np.abs(d_half).max() < 1e-4 * gradient


def test_closed_form_curl_is_the_curl_of_the_ramped_potential():
    """curl_noise against the central-difference curl of ``potential`` (psi'): the difference is
    the h^2 truncation, which the Richardson combination (4 D(h) - D(2h)) / 3 removes, leaving
    ~1e-8 of the velocity (psi is C3, so the h^2 term is continuous); a wrong term in the
    closed form would be O(1)."""
    rng = np.random.default_rng(6)
    h = 1e-3
    x = flow_points(rng, 3000, h)
    args = (OFFSET, NOISE[1], CENTRE, RADIUS, NOISE[2])
    potential = lambda q: flow.potential(q, *args)  # noqa: E731

    def curl(step):
        j = central_jacobian(potential, x, step)
        return np.stack([j[:, 2, 1] - j[:, 1, 2], j[:, 0, 2] - j[:, 2, 0],
                         j[:, 1, 0] - j[:, 0, 1]], axis=-1)

    exact = flow.curl_noise(x, *args)
    c1, c2 = curl(h), curl(2 * h)
    error = np.abs(c1 - exact).max()
    richardson = np.abs((4 * c1 - c2) / 3 - exact).max()
    size = np.abs(exact).max()
    rounding = 4 * EPS64 * size / h
    print(f"max |curl D(h) - closed form| {error:.2e}, Richardson {richardson:.2e}, of |u| up to "
          f"{size:.2f}")
    assert richardson < 1e-6 * size + rounding, richardson
    assert error < 1e-4 * size
    # Far from the sphere psi' = psi: the plain curl.
    far = np.linalg.norm(x - CENTRE, axis=1) > RADIUS + NOISE[2]
    free = flow.curl_noise(x[far], OFFSET, NOISE[1], CENTRE, 0.0, 0.0)
    assert np.abs(free - exact[far]).max() < 1e-12


def test_no_air_through_the_sphere_and_wind_far_away():
    """On the surface (r = R (1 + 1e-9)) the air's normal velocity is the sphere's: what is left
    grows from the surface as 1e-9 R times the velocity gradient (measured just outside). The
    slip along it is not zero (the ideal flow's, and the noise's tangential part survives the
    ramp)."""
    rng = np.random.default_rng(7)
    n = directions(rng, 20_000)
    near = central_jacobian(air, CENTRE + n[:2000] * RADIUS * (1 + 1e-3), 1e-4)
    gradient = np.linalg.norm(near, axis=(1, 2)).max()
    x = CENTRE + n * RADIUS * (1 + 1e-9)
    u = air(x)
    normal = np.sum((u - SPHERE_V) * n, axis=1)
    bound = 1e-9 * RADIUS * 1.5 * gradient + 16 * EPS64 * np.abs(u).max()
    noise = noise_part(x)
    slip = np.linalg.norm(noise - np.sum(noise * n, axis=1)[:, None] * n, axis=1)
    print(f"max |(u - V).n| on the surface {np.abs(normal).max():.2e} (bound {bound:.1e}, |grad u|"
          f" {gradient:.1f}); noise's normal part {np.abs(np.sum(noise * n, axis=1)).max():.2e}, "
          f"its slip mean {slip.mean():.3f}")
    assert np.abs(normal).max() < bound
    assert slip.mean() > 0.1
    # Inside: the sphere's velocity, no noise.
    inside = around_sphere(rng, 1000, 0.0, RADIUS * 0.999)
    assert np.array_equal(air(inside), np.tile(SPHERE_V, (1000, 1)))
    # Far away the dipole dies as (R / r)^3 |wind - V|; the noise stays (unramped).
    for r in (10.0, 100.0, 1000.0):
        x = CENTRE + n[:100] * r
        dipole = np.linalg.norm(sphere_part(x) - WIND, axis=1).max()
        assert dipole <= (RADIUS / r) ** 3 * np.linalg.norm(WIND - SPHERE_V) * (1 + 1e-12)
        free = flow.curl_noise(x, OFFSET, NOISE[1], CENTRE, 0.0, 0.0)
        assert np.abs(air(x) - WIND - NOISE[0] * free).max() <= dipole * (1 + 1e-9) + 1e-15


# --- the GPU against the twin ----------------------------------------------------------------

SPAN = 8.0  # air's range: +-SPAN per component
UNIFORMS = {"u_centre": CENTRE, "u_radius": RADIUS, "u_wind": WIND, "u_sphere_velocity": SPHERE_V,
            "u_noise": NOISE, "u_offset": OFFSET}


def air_graph(uniforms=UNIFORMS):
    g = PassGraph()
    g.quantity("position", -4.0, 4.0, components=3)
    g.quantity("air", -SPAN, SPAN, components=3)
    g.add("position", shader("copy.frag"), writes="position", reads=("position",))
    g.add("air", shader("air.frag"), writes="air", reads=("position",),
          uniforms=uniforms)
    return g


def f32(value):
    return np.asarray(value, np.float32).astype(np.float64)


def float32_bound(x):
    """Largest float32 error of the field at points x (taken over all of them). The noise is read
    at p = s x + offset (+ PSI_OFFSET): s x, the two sums and the unskew each round by half an ulp
    of |p| at most, so the noise sees a point off by 4 eps32 max|p|, which moves each of its
    gradients by up to H_NOISE times that; the velocity takes s x up to three of them (J^T n),
    times the amplitude. Add 32 eps32 of the sizes summed (the flow's and the noise's
    arithmetic)."""
    amplitude, s = NOISE[0], NOISE[1]
    p = s * x + OFFSET
    largest = max(np.abs(p + o).max() for o in (0.0, flow.PSI_OFFSET_Y, flow.PSI_OFFSET_Z))
    moved = 4 * EPS32 * largest
    sizes = np.linalg.norm(WIND) + 3 * np.linalg.norm(WIND - SPHERE_V) + amplitude * s * 3 * G_NOISE
    return amplitude * s * 3 * H_NOISE * moved + 32 * EPS32 * sizes


def gpu_air(gl, fmt, x):
    with Simulation(gl, air_graph(), len(x), fmt=fmt) as sim:
        sim.upload("position", x)
        read = sim.download("position")  # the positions as the GPU reads them
        sim.step()
        return read, sim.download("air")


def test_gpu_matches_the_twin_in_float32(gl):
    """Several thousand points around the sphere, in its ramp band and far off, float32 state
    (rgba32f): positions and uniforms are float32 numbers, so the only difference from the twin
    is the shader's float32 arithmetic."""
    rng = np.random.default_rng(8)
    x = f32(np.clip(around_sphere(rng, 4096, 0.5 * RADIUS, 5.0), -3.999, 3.999))
    read, got = gpu_air(gl, "rgba32f", x)
    assert np.array_equal(read, x)
    ref = flow.air_velocity(x, f32(CENTRE), f32(RADIUS), f32(WIND), f32(SPHERE_V), f32(NOISE),
                            f32(OFFSET))
    assert np.abs(ref).max() < SPAN  # nothing clamped
    # float32 may put a point within 1e-6 R of the surface on the other side of it, where the
    # field jumps (ideal flow slips; the sphere does not): none of these is that close.
    assert np.abs(np.linalg.norm(x - f32(CENTRE), axis=1) - RADIUS).min() > 1e-5
    error = np.abs(got - ref).max(axis=1)
    bound = float32_bound(x)
    print(f"rgba32f: max |GPU - twin| {error.max():.2e} (median {np.median(error):.1e}), "
          f"bound {bound:.2e}; |u| up to {np.abs(ref).max():.2f}")
    assert error.max() <= bound, f"worst {error.max():.3e} > float32 bound {bound:.3e}"


def test_gpu_matches_the_twin_in_the_packed_state(gl):
    """RGBA8 state (16-bit fixed point): the twin at the positions as stored; the air comes back
    within half a code of its range (2 SPAN / 65024 / 2), plus the float32 bound, plus one float32
    ulp of the position decode (|x| < 4) times the velocity gradient (noise: amplitude s^2 3
    H_NOISE; dipole: 6 |wind - V| / R)."""
    rng = np.random.default_rng(9)
    x = np.clip(around_sphere(rng, 4096, 0.5 * RADIUS, 5.0), -3.999, 3.999)
    read, got = gpu_air(gl, "rgba8", x)
    assert np.abs(read - x).max() <= 8.0 / 65024 / 2 + 1e-6  # stored to half a code
    ref = flow.air_velocity(read, f32(CENTRE), f32(RADIUS), f32(WIND), f32(SPHERE_V), f32(NOISE),
                            f32(OFFSET))
    assert np.abs(np.linalg.norm(read - f32(CENTRE), axis=1) - RADIUS).min() > 1e-5
    error = np.abs(got - ref).max(axis=1)
    gradient = NOISE[0] * NOISE[1] ** 2 * 3 * H_NOISE + 6 * np.linalg.norm(WIND - SPHERE_V) / RADIUS
    bound = 2 * SPAN / 65024 / 2 + float32_bound(read) + 2 * EPS32 * 4 * gradient
    print(f"rgba8: max |GPU - twin| {error.max():.2e} (median {np.median(error):.1e}), bound "
          f"{bound:.2e} (half a code {SPAN / 65024:.2e})")
    assert error.max() <= bound, f"worst {error.max():.3e} > bound {bound:.3e}"


def test_air_pass_is_valid_glsl_es_100(tmp_path):
    """lib/noise.glsl and lib/flow.glsl through the air pass as the graph writes it, in each
    format's parts and rounding, for the Khronos reference compiler."""
    tool = glslang()
    g = air_graph()
    spec = next(p for p in g.passes if p.name == "air")
    for fmt in ("rgba8", "rgba16f", "rgba32f"):
        for part in range(g.quantities["air"].parts(fmt)):
            for defines in ({}, {"STATE_DITHER": None}):
                interface = pass_interface(spec, g.quantities, fmt, part)
                text = expand(spec.frag, defines, interface.lines, interface.epilogue).text
                target = tmp_path / "air.frag"
                target.write_text(text)
                result = subprocess.run([tool, str(target)], capture_output=True, text=True)
                assert result.returncode == 0, f"{fmt} part {part} {defines}:\n{result.stdout}"
