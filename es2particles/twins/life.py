"""One particle life cycle, shared by the scenes that emit particles: the numpy twin of
``lib/life.glsl``, the life quantity's range, and the staggered start that goes with it.

A particle's life is (age, lifetime) in seconds: age < 0 is not yet born, 0 <= age < lifetime
alive, older dead. Each step ages it by dt; one that is born or dies during the step is emitted,
with randomness from ``life_random`` (a hash of its texel and the step number).

The clock is exact: the life quantity is kept in RGBA8 whatever the simulation's format, over a
range where one step is exactly one code (a span of 65024 dt), so ``age + dt`` lands on the next
code under nearest and dithered rounding alike, at any dt. Accumulated in the state's own format,
age froze below half a code (dt <= 1e-4 at the old range), ran 0.4% fast at the defaults, stalled
at 32 s in half floats and ran 1.9x fast at dt = 1e-6 in float32. The price: ages and lifetimes
are whole steps, and a lifetime may be at most LIFE_STEPS steps.
"""

import numpy as np

LIFE_STEPS = 32512  # half the 16-bit grid: ages run from -LIFE_STEPS to +LIFE_STEPS steps


def life_range(dt):
    """(lo, hi) of the ``life`` quantity at time step ``dt``: age in +-LIFE_STEPS steps, lifetime
    in [0, 2 LIFE_STEPS] steps; one code is one step on both."""
    return (-LIFE_STEPS * dt, 0.0), (LIFE_STEPS * dt, 2 * LIFE_STEPS * dt)


def longest_life(dt):
    """The longest lifetime (and birth delay) the clock holds at time step ``dt``, in seconds."""
    return LIFE_STEPS * dt


def staggered_births(count, lifetime, rng):
    """A start of ``count`` unborn particles, (count, 2): birth delays spread evenly over the
    longest lifetime, lifetimes uniform in ``lifetime`` = (min, max). Emission then runs at its
    steady rate from the first step, and after one longest lifetime the stream is steady."""
    life = np.empty((count, 2))
    life[:, 0] = -rng.uniform(0, lifetime[1], count)
    life[:, 1] = rng.uniform(*lifetime, count)
    return life


def alive(life):
    """``life_alive``: born and not yet dead, per particle."""
    life = np.asarray(life)
    return (life[..., 0] >= 0) & (life[..., 0] < life[..., 1])


def emits(life, aged, dt):
    """``life_emits``: born or dead during the step of length ``dt`` that aged ``life`` to
    ``aged`` (each test half a step from the grid of whole steps)."""
    life, aged, half = np.asarray(life), np.asarray(aged), 0.5 * dt
    born = (life[..., 0] < -half) & (aged[..., 0] > -half)
    ended = (life[..., 0] < life[..., 1] - half) & (aged[..., 0] > life[..., 1] - half)
    return born | ended


def fade(life):
    """``life_fade``: 1 at birth, 0 at the end of life."""
    life = np.asarray(life, dtype=np.float32)
    return np.clip(1 - life[..., 0] / np.maximum(life[..., 1], np.float32(1e-6)), 0, 1)


def life_random(uv, step, state_size):
    """``life_random``: four numbers in [0, 1) per particle for texel coordinates ``uv`` (N, 2)
    and step number ``step`` (float32, as the GPU)."""
    texel = np.floor(np.asarray(uv, np.float32) * np.asarray(state_size, np.float32))
    return step_hash(texel, step, 0.0)


def step_hash(texel, step, salt):
    """``step_hash`` (lib/state.glsl): four numbers in [0, 1) for integer texels ``texel``
    (N, 2) at step number ``step`` and ``salt`` (float32, as the GPU)."""
    step = np.float32(step)
    columns = np.broadcast_to([np.fmod(step, np.float32(4096)),
                               np.floor(step / np.float32(4096)) + np.float32(salt)],
                              np.shape(texel))
    return hash44(np.concatenate([np.asarray(texel, np.float32), columns], axis=-1))


def hash44(p4):
    """numpy twin of ``hash44`` in ``lib/hash.glsl`` (float32, like the GPU)."""
    f = np.float32
    p4 = np.asarray(p4, np.float32)
    p4 = p4 * np.array([0.1031, 0.1030, 0.0973, 0.1099], f)
    p4 = p4 - np.floor(p4)
    p4 = p4 + np.sum(p4 * (p4[..., [3, 2, 0, 1]] + f(33.33)), axis=-1, keepdims=True)
    out = (p4[..., [0, 0, 1, 2]] + p4[..., [1, 2, 2, 3]]) * p4[..., [2, 1, 3, 0]]
    return out - np.floor(out)
