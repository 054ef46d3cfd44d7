"""What compressing the 3D collision field costs: memory per object, and the collision error
against the uncompressed field, measured on the GPU.

Memory: an n^3 field at each format. The atlas's ASTC blocks are 2D (w x h texels of one slice),
each tile padded to whole blocks, which the bytes count; the seed's 3D blocks (Table 2.1 of the
ARM chapter: a 3D texture, no atlas) are listed for reference, as rates only: ES 2.0 has no 3D
textures to hold them.

Error: the same start (the scene's own emission, no randomness in flight) run for a fixed number
of steps against the float field (``rgba32f``), the state kept in float32 so that only the field
differs. rgba16f is the chapter's half floats (distance and normal as they are);
rgba8-smooth is the compressed fields' encoding (an 8-bit distance) left uncompressed:
the difference between its row and an ASTC row is what the blocks cost, the rest is the 8 bits.
Penetration: the deepest any living particle is inside the exact shapes after any step,
in voxels. Trajectory: how far each particle alive in both runs ends from its reference place
(median and 99th percentile, in voxels); bouncing is chaotic, so a few particles that took another
branch dominate a maximum, and the median is the figure to compare.
"""

import numpy as np

from ..gl.astc import BLOCKS
from ..fields.field3d import TriangleMesh, atlas_layout
from ..frame.simulation import Simulation

SEED_3D_BLOCKS = ((3, 3, 3), (4, 3, 3), (4, 4, 3), (4, 4, 4), (5, 4, 4), (5, 5, 4), (5, 5, 5),
                  (6, 5, 5), (6, 6, 5), (6, 6, 6))
MEASURED_BLOCKS = ((4, 4), (5, 5), (6, 6), (8, 8), (10, 10), (12, 12))


def atlas_bytes(n, bytes_per_block, block=(1, 1), max_size=16384):
    """Bytes of the atlas of an n^3 field as the scene lays it out (in a 16384-texel texture, as
    llvmpipe's; a padded 256^3 field needs more than 4096): tiles padded to whole blocks, the
    last row's unused tiles counted."""
    w, h = atlas_layout((n, n, n), max_size, block)[3:]
    return -(-w // block[0]) * -(-h // block[1]) * bytes_per_block


def memory_rows(resolutions=(64, 128, 256)):
    """Rows (format, nominal bits per voxel, {n: bytes of an n^3 field}), padding counted."""
    rows = [("rgba32f", 128.0, {n: atlas_bytes(n, 16) for n in resolutions}),
            ("rgba16f", 64.0, {n: atlas_bytes(n, 8) for n in resolutions}),
            ("rgba8", 32.0, {n: atlas_bytes(n, 4) for n in resolutions}),
            ("rgba8-smooth", 32.0, {n: atlas_bytes(n, 4) for n in resolutions})]
    for bw, bh in BLOCKS:
        rows.append((f"astc {bw}x{bh} (atlas)", 128 / (bw * bh),
                     {n: atlas_bytes(n, 16, (bw, bh)) for n in resolutions}))
    for bx, by, bz in SEED_3D_BLOCKS:
        rows.append((f"astc {bx}x{by}x{bz} (seed, 3D)", 128 / (bx * by * bz),
                     {n: -(-n // bx) * -(-n // by) * -(-n // bz) * 16 for n in resolutions}))
    return rows


def _run(ctx, scene, count, steps):
    """Positions after each step (steps, count, 3) and who is alive (steps, count)."""
    sim = Simulation(ctx, scene.graph(ctx.caps), count, outputs=("position", "life"),
                     fmt="rgba32f")
    try:
        scene.initialise(sim, np.random.default_rng(0))
        positions, alive = [], []
        for _ in range(steps):
            sim.step()
            life = sim.download("life")
            positions.append(sim.download("position"))
            alive.append((life[:, 0] >= 0) & (life[:, 0] < life[:, 1]))
        return np.array(positions), np.array(alive)
    finally:
        sim.release()


def collision_errors(ctx, scene_of, field, count=4096, steps=90, blocks=MEASURED_BLOCKS):
    """Rows (format, deepest penetration, median and p99 trajectory error, all in voxels) of the
    field in each format against the float field. ``scene_of(field_format)`` makes the scene over
    the same field (its physics without randomness in flight). Penetration needs the exact
    distance: NaN for a mesh's field."""
    ref_x, ref_alive = _run(ctx, scene_of("rgba32f"), count, steps)
    formats = ["rgba32f", "rgba16f", "rgba8", "rgba8-smooth"] + [f"astc{w}x{h}"
                                                                  for w, h in blocks]
    analytic = not any(isinstance(s, TriangleMesh) for s in field.shapes)
    rows = []
    for fmt in formats:
        x, alive = (ref_x, ref_alive) if fmt == "rgba32f" else _run(ctx, scene_of(fmt), count,
                                                                   steps)
        deepest = np.nan
        if analytic:
            q = (x - field.pivot).reshape(-1, 3)  # a still object: object space is world - pivot
            depth = -field.exact(q)[0].reshape(alive.shape)
            deepest = max(float(np.max(np.where(alive, depth, -np.inf))) / field.voxel, 0.0)
        both = alive[-1] & ref_alive[-1]
        off = np.linalg.norm(x[-1][both] - ref_x[-1][both], axis=1) / field.voxel
        rows.append((fmt, deepest, float(np.median(off)), float(np.quantile(off, 0.99))))
    return rows


def table_lines(memory, errors=None):
    """The table as text lines: memory per format, and the measured errors where given."""
    n_list = list(memory[0][2])
    measured = {fmt.replace("astc", "astc "): row for fmt, *row in (errors or [])}
    head = (f"{'format':<26}{'bits/voxel':>11}" + "".join(f"{f'{n}^3':>11}" for n in n_list)
            + ("   penetration  trajectory median / p99 (voxels)" if errors else ""))
    lines = [head]
    for name, bits, sizes in memory:
        line = f"{name:<26}{bits:>11.2f}" + "".join(f"{_size(sizes[n]):>11}" for n in n_list)
        key = name.split(" (")[0]
        row = measured.get(key)
        if row is not None:
            depth = "-" if np.isnan(row[0]) else f"{row[0]:.2f}"
            line += f"   {depth:>11}  {row[1]:>8.3f} / {row[2]:.3f}"
        lines.append(line)
    return lines


def _size(n):
    for unit, scale in (("MiB", 2 ** 20), ("KiB", 2 ** 10)):
        if n >= scale:
            return f"{n / scale:.2f} {unit}"
    return f"{n} B"
