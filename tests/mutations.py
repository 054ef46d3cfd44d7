"""The shader mutation suite: plausible bugs put into the GLSL (and, where a numpy twin mirrors the
code, into the twin as well), each caught by the tests named for it, or the suite says so.

    python -m tests.mutations              # every mutation, the table in Markdown
    python -m tests.mutations --list       # names and areas only
    python -m tests.mutations NAME ...     # some of them

Each mutation is a list of exact text replacements. The package, its shaders and the tests are
copied once into a temporary folder (the repository is never touched); for each mutation the
replacements are made there (each must match exactly once, or the suite stops: a mutation that no
longer applies is an error, not a pass), the named tests run against the copy (``python -m pytest
-x``, or every named test where the mutation says so, with the copy first on the path), and the files are put back. A mutation is caught when
pytest reports failed tests (exit 1); exit 0 is a survivor; anything else (a collection error,
an interrupted run) is reported as broken. The suite exits 1 unless every mutation is caught.
tests/test_mutations.py runs a subset in the test command; docs/mutations.md gives the full table.

A bug put into a shader and its twin alike is the hard case: the GPU-against-twin comparisons
still agree, so only tests against independent physics (tests/test_twins.py, the thin-wall and
energy tests, the float64 references) can catch it.
"""

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
COPIED = ("es2particles", "shaders", "tests", "pyproject.toml")


@dataclass(frozen=True)
class Mutation:
    name: str
    area: str
    what: str
    edits: tuple  # ((path, old, new), ...): each old must occur exactly once in its file
    tests: tuple  # pytest arguments: files, node ids or "-k" expressions
    every: bool = False  # run every named test (not stop at the first failure): the table counts them

    @property
    def files(self):
        return sorted({path for path, _, _ in self.edits})


def _both(shader, shader_edit, twin, twin_edit):
    """The same bug in a shader and in its numpy twin."""
    return ((shader, *shader_edit), (twin, *twin_edit))


PACK = "shaders/glsl100/lib/pack.glsl"
STATE = "shaders/glsl100/lib/state.glsl"
PARTICLE = "shaders/glsl100/lib/particle.glsl"
PARTICLE_TWIN = "es2particles/twins/particle.py"
COLLISION3D = "shaders/glsl100/collision3d.frag"
COLLISION3D_TWIN = "es2particles/twins/collision3d.py"
FOUNTAIN = "shaders/glsl100/fountain.frag"
FOUNTAIN_TWIN = "es2particles/twins/fountain.py"
DRAG = "shaders/glsl100/lib/drag.glsl"
DRAG_TWIN = "es2particles/twins/drag.py"
FLOW = "shaders/glsl100/lib/flow.glsl"
FLOW_TWIN = "es2particles/twins/flow.py"
LIFE = "shaders/glsl100/lib/life.glsl"
TRIG = "shaders/glsl100/lib/trig.glsl"
ATTRACTOR = "shaders/glsl100/lib/attractor.glsl"
MERGE = "shaders/glsl100/sort/merge.frag"
KEY = "shaders/glsl100/sort/key.frag"
NKEY = "shaders/glsl100/neighbours/key.frag"
NTABLE = "shaders/glsl100/neighbours/table.frag"
NLIB = "shaders/glsl100/lib/neighbours.glsl"
ORDER = "shaders/glsl100/lib/order.glsl"
BOIDS = "shaders/glsl100/boids/boids.frag"
SHAFTS = "shaders/glsl100/shafts/scatter.frag"
TRAILS = "shaders/glsl100/post/trails.frag"
LIQUID = "shaders/glsl100/liquid/liquid.frag"
SPH = "shaders/glsl100/sph/sph.frag"
FLAME = "shaders/glsl100/flame/march.frag"
WIND = "shaders/glsl100/wind/fluid.frag"

MUTATIONS = (
    # --- packing -----------------------------------------------------------------------------
    Mutation("pack-half-code-high", "packing", "every nearest-rounded RGBA8 write half a code high",
             ((PACK, "float code = floor(clamp_unit(x) * 65024.0 + 0.5);",
               "float code = floor(clamp_unit(x) * 65024.0 + 1.0);"),),
             ("tests/test_dejong.py", "tests/test_clifford.py"), every=True),
    Mutation("unpack-high-byte-256", "packing", "the high byte read back as 256 codes, not 255",
             ((PACK, "return (bytes.x * 255.0 + bytes.y) * (1.0 / 65024.0);",
               "return (bytes.x * 256.0 + bytes.y) * (1.0 / 65024.0);"),),
             ("tests/test_packing.py",)),
    Mutation("dither-half-code-high", "packing", "every dithered write half a code high",
             ((PACK, "float s = clamp_unit(x) * 65024.0;",
               "float s = clamp_unit(x) * 65024.0 + 0.5;"),),
             ("tests/test_clifford.py",)),
    Mutation("dither-dead-zone-gone", "packing",
             "dithered rounding without its dead zone (dithers float32's own error into a drift)",
             ((PACK, "#define DITHER_DEAD_ZONE 0.015625", "#define DITHER_DEAD_ZONE 0.0"),),
             ("tests/test_packing.py", "tests/test_numerics.py")),
    Mutation("read-jitter-narrow", "packing",
             "jittered reads offset over a quarter of the code instead of all of it",
             ((STATE, "return (u - 0.5) * ((1.0 - 2.0 * DITHER_DEAD_ZONE) / 65024.0);",
               "return (u - 0.5) * ((1.0 - 2.0 * DITHER_DEAD_ZONE) / 260096.0);"),),
             ("tests/test_jitter.py", "tests/test_clifford.py")),
    Mutation("float-state-unclamped", "packing", "float formats no longer clamped to the range",
             ((STATE, "value.x >= lo.x ? min(value.x, hi.x) : lo.x",
               "value.x >= lo.x ? value.x : lo.x"),),
             ("tests/test_packing.py", "tests/test_stability.py")),
    # --- attractors --------------------------------------------------------------------------
    Mutation("dejong-wrong-axis", "attractors", "de Jong's last cosine reads x instead of y",
             (("shaders/glsl100/attractors/dejong.frag", "trig_cos(k.w * p.y)",
               "trig_cos(k.w * p.x)"),),
             ("tests/test_dejong.py",)),
    Mutation("clifford-c-for-d", "attractors", "Clifford's first cosine weighted by d, not c",
             (("shaders/glsl100/attractors/clifford.frag", "k.z * trig_cos(k.x * p.x)",
               "k.w * trig_cos(k.x * p.x)"),),
             ("tests/test_clifford.py",)),
    Mutation("attractor-one-iteration-short", "attractors", "one map iteration fewer a step",
             ((ATTRACTOR, "for (int i = 0; i < ITERATIONS; ++i)",
               "for (int i = 1; i < ITERATIONS; ++i)"),),
             ("tests/test_dejong.py",)),
    Mutation("reseed-jitter-reversed", "attractors",
             "accumulated samples' grid shifted the wrong way",
             ((ATTRACTOR, "(v_uv + u_jitter / u_state_size)", "(v_uv - u_jitter / u_state_size)"),),
             ("tests/test_accumulate.py",)),
    Mutation("trig-pi-over-two-short", "attractors",
             "the range reduction's pi/2 loses its last term (8 + 11 bits only)",
             ((TRIG, "float r = ((x - n * TRIG_PIO2_1) - n * TRIG_PIO2_2) - n * TRIG_PIO2_3;",
               "float r = (x - n * TRIG_PIO2_1) - n * TRIG_PIO2_2;"),),
             ("tests/test_numerics.py::test_trig_is_float64_sin_and_cos_to_float32_rounding",)),
    # --- collision 2D ------------------------------------------------------------------------
    Mutation("substeps-two-cells", "collision 2D",
             "sub-steps of two cells instead of half a cell, shader and twin",
             _both(PARTICLE, ("ceil(reach / (0.5 * u_cell))", "ceil(reach / (2.0 * u_cell))"),
                   PARTICLE_TWIN, ("np.ceil(reach / (0.5 * field.cell))",
                                   "np.ceil(reach / (2.0 * field.cell))")),
             ("tests/test_twins.py", "tests/test_collision.py")),
    Mutation("entry-carry-sign", "collision 2D",
             "the normal's distance carried with the wrong sign, shader and twin",
             _both(PARTICLE, ("            d = dot(moved, n);", "            d = -dot(moved, n);"),
                   PARTICLE_TWIN, ("d = np.where(back, np.sum(moved * n, axis=-1), d)",
                                   "d = np.where(back, -np.sum(moved * n, axis=-1), d)")),
             ("tests/test_twins.py", "tests/test_collision.py")),
    Mutation("side-of-entry-gone", "collision 2D",
             "no 'came through the other side' rule, shader and twin",
             _both(PARTICLE, ("if (dot(moved, n) > 0.0 && d > -2.0 * u_cell) {", "if (false) {"),
                   PARTICLE_TWIN, ("back = (d < 0) & (np.sum(moved * n, axis=-1) > 0) & "
                                   "(d > -2 * field.cell)", "back = d != d")),
             ("tests/test_twins.py", "tests/test_collision.py")),
    Mutation("sliding-swapped", "collision 2D",
             "sliding and its complement swapped in the bounce, shader and twin",
             _both(PARTICLE, ("(n * u_sliding + along / along_length * (1.0 - u_sliding))",
                              "(n * (1.0 - u_sliding) + along / along_length * u_sliding)"),
                   PARTICLE_TWIN, ("(n * sliding + t * (1 - sliding))",
                                   "(n * (1 - sliding) + t * sliding)")),
             ("tests/test_twins.py", "tests/test_collision.py")),
    Mutation("contact-energy-sign", "collision 2D",
             "the push-out's work against the acceleration added instead of taken, shader only",
             ((PARTICLE, "v *= sqrt(max(v2 - work, 0.0) / v2);",
               "v *= sqrt(max(v2 + work, 0.0) / v2);"),),
             ("tests/test_collision.py",)),
    Mutation("drag-explicit-euler", "collision 2D",
             "drag as explicit Euler (1 - k h) instead of exp(-k h), shader and twin",
             _both(DRAG, ("float decay = exp(-kh);", "float decay = 1.0 - kh;"),
                   DRAG_TWIN, ("decay = np.exp(-kh)", "decay = 1 - kh")),
             ("tests/test_twins.py", "tests/test_stability.py")),
    # --- collision 3D ------------------------------------------------------------------------
    Mutation("slope-work-whole", "collision 3D",
             "a turned particle pays the push-out's whole work again (issue 45's static "
             "friction), shader and twin",
             _both(COLLISION3D, ("        work = min(2.0 * ours * an, max(vn * vn - (speed * speed - dot(v, v)), 0.0))\n"
                                 "            + 2.0 * (d - ours) * an;",
                                 "        work = 2.0 * d * an + 0.0 * ours;"),
                   COLLISION3D_TWIN, ("work = np.where(hit & (vn < 0), capped, 2 * d * an)",
                                      "work = 2 * d * an + 0 * capped")),
             ("tests/test_collision3d.py", "tests/test_twins.py")),
    Mutation("response-loss-ignored", "collision 3D",
             "the cap at vn^2 without what the response took already, shader and twin",
             _both(COLLISION3D, ("max(vn * vn - (speed * speed - dot(v, v)), 0.0))",
                                 "max(vn * vn - 0.0 * (speed * speed - dot(v, v)), 0.0))"),
                   COLLISION3D_TWIN, ("np.maximum(vn * vn - (speed * speed - v2), 0))",
                                      "np.maximum(vn * vn - 0 * (speed * speed - v2), 0))")),
             ("tests/test_collision3d.py", "tests/test_twins.py")),
    Mutation("substeps3d-doubled", "collision 3D",
             "3D sub-steps twice the bound, shader and twin",
             _both(COLLISION3D, ("ceil(reach / u_substep)", "ceil(reach / (2.0 * u_substep))"),
                   COLLISION3D_TWIN, ("np.ceil(reach / substep)", "np.ceil(reach / (2 * substep))")),
             ("tests/test_twins.py", "tests/test_collision3d.py")),
    Mutation("side-of-entry3d-gone", "collision 3D",
             "no side-of-entry rule in 3D, shader only",
             ((COLLISION3D, "if (dot(moved, n) > 0.0 && d > -2.0 * u_voxel && d < -0.25 * u_voxel) {",
               "if (false) {"),),
             ("tests/test_collision3d.py",)),
    Mutation("came-from-facing-gone", "collision 3D",
             "the side-of-entry rule without its 'came from a surface facing away' check (the "
             "spinning-object leak), shader and twin",
             _both(COLLISION3D, ("if (dot(n_before, n) < 0.0) {", "if (true) {"),
                   COLLISION3D_TWIN, ("back[back] = np.sum(came_from * n[back], axis=1) < 0",
                                      "back[back] = True")),
             ("tests/test_collision3d.py::test_no_particle_deeper_than_a_voxel_at_the_fastest_spin",)),
    Mutation("surface-velocity-ignored", "collision 3D",
             "contact with a moving object in the world frame, not the surface's, shader only",
             ((COLLISION3D, "vec3 relative = v - surface;", "vec3 relative = v;"),
              (COLLISION3D, "v = relative + surface;", "v = relative;")),
             ("tests/test_collision3d.py",)),
    # --- fountain ----------------------------------------------------------------------------
    Mutation("floor-bounce-elastic", "fountain",
             "the floor bounce keeps all the speed, shader and twin",
             _both(FOUNTAIN, ("p.v.y = u_bounce * sqrt(", "p.v.y = sqrt("),
                   FOUNTAIN_TWIN, ("v[below, 1] = p.bounce * np.sqrt(", "v[below, 1] = np.sqrt(")),
             ("tests/test_twins.py", "tests/test_fountain.py")),
    Mutation("fountain-old-velocity", "fountain",
             "the position moved with last step's velocity (explicit Euler), shader only",
             ((FOUNTAIN, "        p.v = clamp(p.v * drag.x + u_gravity * drag.y, -u_max_speed, u_max_speed);\n"
                         "        p.x += p.v * u_dt;",
               "        p.x += p.v * u_dt;\n"
               "        p.v = clamp(p.v * drag.x + u_gravity * drag.y, -u_max_speed, u_max_speed);"),),
             ("tests/test_fountain.py",)),
    # --- smoke -------------------------------------------------------------------------------
    Mutation("curl-sign", "smoke", "one component of the curl noise's curl with its sign flipped, "
             "shader and twin",
             _both(FLOW, ("vec3(c.y - b.z, a.z - c.x, b.x - a.y)", "vec3(c.y - b.z, c.x - a.z, b.x - a.y)"),
                   FLOW_TWIN, ("ga[:, 2] - gc[:, 0]", "gc[:, 0] - ga[:, 2]")),
             ("tests/test_flow.py",)),
    Mutation("stokes-tau-doubled", "smoke", "the air's pull on a particle at half strength, shader only",
             (("shaders/glsl100/smoke.frag", "- read_velocity(v_uv)) / u_tau + u_gravity",
               "- read_velocity(v_uv)) / (2.0 * u_tau) + u_gravity"),),
             ("tests/test_smoke.py",)),
    # --- motion ------------------------------------------------------------------------------
    Mutation("motion-sway-still", "motion", "a swaying object's centre moves but its velocity "
             "is left 0 (the air and the bounce miss the push), shader only",
             (("shaders/glsl100/lib/motion.glsl", "pose.velocity = u_motion_sway.xyz * w * sc.y;",
               "pose.velocity = vec3(0.0);"),),
             ("tests/test_smoke.py",)),
    Mutation("motion-normal-unturned", "motion", "a turned object's normals left as at rest, "
             "shader only", (("shaders/glsl100/lib/motion.glsl",
                              "    return motion_rotate(v, u_motion_spin.xyz, pose.turn);",
                              "    return v;"),),
             ("tests/test_meshes.py",)),
    # --- sort --------------------------------------------------------------------------------
    Mutation("merge-keeps-larger", "sort", "the lower slot of a comparator keeps the larger key",
             ((MERGE, "result = order_less(other, own) ? other : own;",
               "result = order_less(own, other) ? other : own;"),),
             ("tests/test_sort.py",)),
    Mutation("merge-one-comparator-short", "sort",
             "the network's last block boundary off by one comparator",
             ((MERGE, "block + u_k < 2.0 * u_p", "block + u_k < 2.0 * u_p - 1.0"),),
             ("tests/test_sort.py",)),
    Mutation("depth-key-reversed", "sort", "the depth key measured from the near side",
             ((KEY, "float t = clamp_unit((u_depth.x - depth) * u_depth.y);",
               "float t = clamp_unit(1.0 - (u_depth.x - depth) * u_depth.y);"),),
             ("tests/test_sort.py",)),
    # --- life --------------------------------------------------------------------------------
    Mutation("life-ends-a-step-late", "life", "a particle re-emitted a step after its lifetime",
             ((LIFE, "aged.x > life.y - half_step;", "aged.x > life.y + half_step;"),),
             ("tests/test_collision.py", "tests/test_emitter.py")),
    Mutation("life-born-never", "life", "the unborn never come alive (birth test reversed)",
             ((LIFE, "bool born = life.x < -half_step && aged.x > -half_step;",
               "bool born = life.x > -half_step && aged.x > -half_step;"),),
             ("tests/test_collision.py", "tests/test_emitter.py")),
    # --- grids (issue 39) --------------------------------------------------------------------
    Mutation("iterations-not-ping-ponged", "grids",
             "a versioned quantity's pair not swapped after a write: iterations reread one texture",
             (("es2particles/frame/executor.py", "                    if stage.swap:\n",
               "                    if False:\n"),),
             ("tests/test_grids.py", "tests/test_wind.py")),
    Mutation("warm-start-twice", "grids", "the warm start's factor applied twice",
             (("shaders/glsl100/lib/warm_start.frag", "write(WARM_READ(v_uv) * u_warm);",
               "write(WARM_READ(v_uv) * u_warm * u_warm);"),),
             ("tests/test_grids.py", "tests/test_wind.py")),
    Mutation("bilinear-half-cell-off", "grids", "sample_q's cell centres half a cell off",
             (("es2particles/gl/bindings.py", 'u_{g}_box.xy) * u_{g}_size - 0.5"',
               'u_{g}_box.xy) * u_{g}_size"'),),
             ("tests/test_grids.py",)),
    Mutation("atlas-rows-by-tiles-y", "grids",
             "a 3D grid's slice row taken over the atlas's rows, not its columns (reads only)",
             (("es2particles/gl/bindings.py", 'f"    float row = floor((k + 0.5) / u_{g}_tiles.x);",',
               'f"    float row = floor((k + 0.5) / u_{g}_tiles.y);",'),),
             ("tests/test_grids3d.py",)),
    Mutation("trilinear-slices-swapped", "grids",
             "a trilinear sample's weight across slices given to the wrong slice",
             (("es2particles/gl/bindings.py", '"    return mix(below, above, t.z);"',
               '"    return mix(above, below, t.z);"'),),
             ("tests/test_grids3d.py",)),
    Mutation("atlas-cell-k-transposed", "grids",
             "a 3D grid pass's slice number from its tile column by rows (k = x * rows + y)",
             (("es2particles/gl/bindings.py",
               "tile.y * u_{g}_tiles.x + tile.x);", "tile.x * u_{g}_tiles.y + tile.y);"),),
             ("tests/test_grids3d.py",)),
    Mutation("hardware-sample-half-cell-off", "grids",
             "a hardware-filtered sample's texel coordinate half a texel off",
             (("es2particles/gl/bindings.py", 'f"    return read_{q}({g}_uv(c));", "}"]',
               'f"    return read_{q}({g}_uv(c - 0.5));", "}"]'),),
             ("tests/test_grids3d.py",)),
    Mutation("hardware-tap-leaves-its-tile", "grids",
             "a 3D hardware sample's taps not held within their slice's tile: the filter "
             "reaches the next slice's cells",
             (("es2particles/gl/bindings.py",
               'f"    vec2 xy = clamp(c.xy, vec2(0.0), u_{g}_size.xy - 1.0);",',
               'f"    vec2 xy = c.xy;",'),),
             ("tests/test_grids3d.py",)),
    # --- the wind field ------------------------------------------------------------------------
    Mutation("wind-divergence-sign", "wind", "the divergence's x flux with its sign flipped",
             ((WIND, "(u_at(c + EX) - u_at(c)) / u_cell.x",
               "(u_at(c) - u_at(c + EX)) / u_cell.x"),),
             ("tests/test_wind.py",)),
    Mutation("wind-open-side-closed", "wind",
             "the open side's pressure condition gone (zero gradient everywhere)",
             ((WIND, "        return kind == WALL_OPEN ? -p : p;", "        return p;"),),
             ("tests/test_wind.py",)),
    Mutation("wind-stencil-off-by-one", "wind", "the Poisson stencil's lower neighbour two cells down",
             ((WIND, "+ pressure_near(c, -EY, p))", "+ pressure_near(c, -2.0 * EY, p))"),),
             ("tests/test_wind.py",)),
    Mutation("wind-projection-wrong-cell", "wind", "a face's gradient taken from one cell only",
             ((WIND, "float p_first = first ? pressure_at(c - d) : -p_second;",
               "float p_first = first ? pressure_at(c) : -p_second;"),),
             ("tests/test_wind.py",)),
    Mutation("wind-lid-still", "wind", "a moving wall's tangential ghost as a still wall's",
             ((WIND, ": kind == WALL_NOSLIP ? -value : 2.0 * speed - value;",
               ": -value;"),),
             ("tests/test_wind.py",)),
    # --- neighbour grids ------------------------------------------------------------------------
    Mutation("neighbour-cells-transposed", "neighbours",
             "the key numbers cells column by column: a row's three cells are no longer a run",
             ((NKEY, "slot = order_encode(cell.y * u_neighbour_size.x + cell.x, index);",
               "slot = order_encode(cell.x * u_neighbour_size.y + cell.y, index);"),),
             ("tests/test_neighbours.py",)),
    Mutation("neighbour-search-past-the-cell", "neighbours",
             "the table's search finds the first slot after its cell, not the first in it",
             ((NTABLE, "if (key_at(mid) < c) {", "if (key_at(mid) <= c) {"),),
             ("tests/test_neighbours.py",)),
    Mutation("neighbour-right-column-missed", "neighbours",
             "a row's run stops at the point's own column",
             ((NLIB, "float x1 = min(c.x + 1.0, u_neighbour_size.x - 1.0);",
               "float x1 = min(c.x, u_neighbour_size.x - 1.0);"),),
             ("tests/test_neighbours.py",)),
    Mutation("neighbour-rows-shifted", "neighbours", "the three rows visited start at the point's own",
             ((NLIB, "at.y += r - 3.0 * layer - 1.0;", "at.y += r - 3.0 * layer;"),),
             ("tests/test_neighbours.py",)),
    Mutation("neighbour-layers-shifted", "neighbours",
             "the three layers of a 3D grid visited start at the point's own",
             ((NLIB, "at.z += layer - 1.0;", "at.z += layer;"),),
             ("tests/test_neighbours.py",)),
    Mutation("neighbour-slot-counted-at-mediump", "neighbours",
             "the slot counted as float(k): llvmpipe converts a mediump int at half precision",
             ((NLIB, "    float slot = neighbour_slot;\n",
               "    float slot = neighbour_run.x + float(k);\n"),),
             ("tests/test_neighbours.py",)),
    Mutation("neighbour-key-low-bits-lost", "neighbours",
             "an RGBA8 key read without the bits in the low half of its word",
             ((ORDER, "return floor(word.x / ORDER_HIGH_MOD) * (65536.0 / ORDER_LOW_MOD) + "
                      "floor(word.y / ORDER_LOW_MOD);",
               "return floor(word.x / ORDER_HIGH_MOD) * (65536.0 / ORDER_LOW_MOD);"),),
             ("tests/test_neighbours.py::test_the_table_holds_each_cells_first_slot_in_rgba8",)),
    Mutation("neighbour-bound-check-doubled", "neighbours",
             "the row check lets rows of up to twice the bound through",
             (("es2particles/frame/neighbours.py", "    if worst > n.bound:",
               "    if worst > 2 * n.bound:"),),
             ("tests/test_neighbours.py",)),
    # --- boids ------------------------------------------------------------------------------------
    Mutation("boids-separation-attracts", "boids", "separation pulls toward the nearest",
             ((BOIDS, "away -= d / (r * r);", "away += d / (r * r);"),),
             ("tests/test_boids.py",)),
    Mutation("boids-alignment-absolute", "boids",
             "alignment steers by the neighbours' mean velocity, not its difference from its own",
             ((BOIDS, "steer += u_weights.y * (heading / counts.x - v);",
               "steer += u_weights.y * (heading / counts.x);"),),
             ("tests/test_boids.py",)),
    Mutation("boids-walls-inverted", "boids", "the walls' turn pushes toward the wall",
             ((BOIDS, "VEC wall = step(x, VEC(u_radii.z)) - step(u_box - VEC(u_radii.z), x);",
               "VEC wall = step(u_box - VEC(u_radii.z), x) - step(x, VEC(u_radii.z));"),),
             ("tests/test_boids.py",)),
    Mutation("boids-no-minimum-speed", "boids", "the speed held only below the maximum",
             ((BOIDS, "clamp(s, u_speed.x, u_speed.y)", "clamp(s, 0.0, u_speed.y)"),),
             ("tests/test_boids.py",)),
    Mutation("boids-half-step", "boids", "the position moves half a step's velocity",
             ((BOIDS, "clamp(x + u_dt * read_velocity(v_uv), VEC(0.0), u_box)",
               "clamp(x + 0.5 * u_dt * read_velocity(v_uv), VEC(0.0), u_box)"),),
             ("tests/test_boids.py",)),
    # --- liquid ------------------------------------------------------------------------------------
    Mutation("liquid-viscosity-pushes", "liquid", "the viscosity impulse added, not taken away",
             ((LIQUID, "write_velocity(v + u_dt * u_gravity - 0.5 * impulse);",
               "write_velocity(v + u_dt * u_gravity + 0.5 * impulse);"),),
             ("tests/test_liquid.py",)),
    Mutation("liquid-density-linear", "liquid", "the density sums (1 - q), not (1 - q)^2",
             ((LIQUID, "rho += vec2(a * a, a * a * a);", "rho += vec2(a, a * a * a);"),),
             ("tests/test_liquid.py",)),
    Mutation("liquid-rest-density-once", "liquid",
             "the pair's pressure takes rho0 once for two particles' densities",
             ((LIQUID, "(rho.x - 2.0 * u_rest)", "(rho.x - u_rest)"),),
             ("tests/test_liquid.py",)),
    Mutation("liquid-velocity-times-dt", "liquid",
             "the velocity's correction multiplied by dt, not divided",
             ((LIQUID, "(read_position(v_uv) - read_predicted(v_uv)) / u_dt",
               "(read_position(v_uv) - read_predicted(v_uv)) * u_dt"),),
             ("tests/test_liquid.py",)),
    Mutation("liquid-obstacle-half", "liquid", "the obstacle holds out only half its radius",
             ((LIQUID, "if (length(c) < obstacle.z) {", "if (length(c) < 0.5 * obstacle.z) {"),),
             ("tests/test_liquid.py",)),
    Mutation("liquid-saved-density-cubed", "liquid",
             "the saved state's density recomputed with (1 - q)^3",
             (("es2particles/twins/neighbours.py", "    density = np.bincount(i, a ** 2, n) + "
               "np.bincount(j, a ** 2, n)",
               "    density = np.bincount(i, a ** 3, n) + np.bincount(j, a ** 2, n)"),),
             ("tests/test_liquid.py",)),
    Mutation("metaballs-threshold-half", "liquid", "the metaball surface at half the author's "
             "threshold: the liquid swells",
             (("shaders/glsl100/metaballs/threshold.frag", "step(u_threshold, ",
               "step(0.5 * u_threshold, "),),
             ("tests/test_metaballs.py",)),
    Mutation("metaballs-blur-spread", "liquid", "the author's blur taps a texel further apart",
             (("es2particles/render/metaballs.py",
               "pairs = [(float(k * strong), float(w))", "pairs = [(float(k * (strong + 1)), "
               "float(w))"),),
             ("tests/test_metaballs.py",)),
    Mutation("metaballs-shadow-rim-flipped", "liquid",
             "the rim shadow inside deepens towards the middle, not the rim",
             (("shaders/glsl100/metaballs/liquid.frag", "float rim = 1.0 - alpha;",
               "float rim = alpha;"),),
             ("tests/test_metaballs.py",)),
    # --- round 2 (issue 46): confetti, the lamp, soft particles, the sort, live controls, run
    # files, the memory estimate, the page's executor, jitter; and the issues' new scenes ------
    Mutation("confetti-tumble-half", "confetti", "a piece in flight tumbles at half --tumble",
             (("shaders/glsl100/collision3d.frag", "vec2 turn = trig_sin_cos(u_tumble * u_dt);",
               "vec2 turn = trig_sin_cos(0.5 * u_tumble * u_dt);"),),
             ("tests/test_confetti.py",)),
    Mutation("confetti-landed-keeps-tumbling", "confetti",
             "a piece that touched a surface keeps tumbling instead of lying flat on it",
             (("shaders/glsl100/collision3d.frag",
               "p.n = dot(touched, touched) > 0.0 ? touched : tumble(n, uv);",
               "p.n = tumble(n, uv);"),),
             ("tests/test_confetti.py",)),
    Mutation("confetti-quad-sunk", "confetti", "a quad lifted below its surface, not above it",
             (("shaders/glsl100/quads/confetti.vert", "vec3 world = p + n * lift + ",
               "vec3 world = p - n * lift + "),),
             ("tests/test_confetti.py",)),
    Mutation("confetti-back-unlit", "confetti", "a quad seen from its back side is unlit",
             (("shaders/glsl100/quads/confetti.vert",
               "float lambert = abs(dot(n, normalize(u_light - world)));",
               "float lambert = max(dot(n, normalize(u_light - world)), 0.0);"),),
             ("tests/test_confetti.py",)),
    Mutation("lamp-particles-opaque", "lamp", "a particle stops all the lamp's light, whatever "
             "its opacity", (("shaders/glsl100/lamp/particle.frag",
                              "float stopped = u_lamp_opacity * texture2D",
                              "float stopped = texture2D"),),
             ("tests/test_lamp.py",)),
    Mutation("lamp-footprint-not-shrinking", "lamp",
             "a particle's footprint in the light map does not shrink with its distance to the lamp",
             (("shaders/glsl100/lamp/particle.vert", "        / max(distance(u_lamp, p), 1e-6);",
               "        / 1.0;"),),
             ("tests/test_lamp.py",)),
    Mutation("lamp-disc-wider", "lamp", "the lamp's disc of light full to its rim",
             (("shaders/glsl100/sprites/mesh.frag", "smoothstep(0.75, 1.0, length(uv * 2.0 - 1.0))",
               "smoothstep(0.99, 1.0, length(uv * 2.0 - 1.0))"),),
             ("tests/test_lamp.py",)),
    Mutation("soft-fade-doubled", "soft", "a soft sprite fades over half of --soft",
             (("shaders/glsl100/sprites/sprite.frag", "a *= clamp(gap / u_soft, 0.0, 1.0);",
               "a *= clamp(2.0 * gap / u_soft, 0.0, 1.0);"),),
             ("tests/test_soft.py",)),
    Mutation("soft-bilateral-ignores-depth", "soft",
             "the bilateral upsample weighs every texel alike, whatever its depth",
             (("shaders/glsl100/sprites/upsample.frag",
               "float w = bilinear * similar + 1e-5 * bilinear;", "float w = bilinear;"),),
             ("tests/test_soft.py",)),
    Mutation("soft-over-not-premultiplied", "soft",
             "the sprite buffer laid over the picture as if not premultiplied",
             (("shaders/glsl100/sprites/upsample.frag",
               "gl_FragColor = vec4(smoke.rgb + picture.rgb * (1.0 - smoke.a), 1.0);",
               "gl_FragColor = vec4(smoke.rgb * smoke.a + picture.rgb * (1.0 - smoke.a), 1.0);"),),
             ("tests/test_soft.py",)),
    Mutation("live-orbit-climbs-down", "live", "a drag down lowers the eye instead of raising it",
             (("es2particles/live/controls.py",
               "elevation = math.asin(max(-1.0, min(1.0, height / r))) + ORBIT_RATE * dy",
               "elevation = math.asin(max(-1.0, min(1.0, height / r))) - ORBIT_RATE * dy"),),
             ("tests/test_live_controls.py",)),
    Mutation("live-zoom-no-lower-limit", "live", "the wheel brings the eye closer than 0.5 m",
             (("es2particles/live/controls.py",
               "new = min(max(r * math.exp(-WHEEL_STEP * notches), DISTANCE_LIMITS[0]),",
               "new = min(max(r * math.exp(-WHEEL_STEP * notches), 0.0),"),),
             ("tests/test_live_controls.py",)),
    Mutation("live-walk-with-height", "live", "walking moves along the view, not the floor",
             (("es2particles/live/controls.py",
               "        level = forward - np.dot(forward, self.up) * self.up\n",
               "        level = forward + 0.0 * self.up\n"),),
             ("tests/test_live_controls.py",)),
    Mutation("live-ray-y-flipped", "live", "a pixel's ray leaves upwards for a pixel below the "
             "centre", (("es2particles/live/controls.py", "        y = 1 - 2 * pixel[1] / h",
                         "        y = 2 * pixel[1] / h - 1"),),
             ("tests/test_live_controls.py",)),
    Mutation("page-orbit-no-elevation-limit", "page",
             "the page's drag lets the eye climb past the elevation limit",
             (("es2particles/export/webpage/executor.js",
               "Math.min(c.elevation_limit, state.elevation + dy * c.orbit_rate));",
               "state.elevation + dy * c.orbit_rate);"),),
             ("tests/test_export.py::test_fountain_page_orbits_and_zooms_with_the_mouse_as_the_python_camera_does",
              "tests/test_export.py::test_page_draws_an_orthographic_camera_and_orbits_about_its_up_axis")),
    Mutation("page-sample-steps-skipped", "page",
             "the page draws an accumulating stage's further samples without their steps",
             (("es2particles/export/webpage/executor.js",
               "      setSample(s);\n      step();\n      use(p, values(",
               "      setSample(s);\n      use(p, values("),),
             ("tests/test_export.py::test_an_accumulated_flame_page_averages_its_marches_as_egl_does",)),
    Mutation("run-file-drops-parameters", "run files",
             "a run file writes only the parameters whose value is not the default's",
             (("es2particles/run.py", "if value is not None and name in scene.Params.options()}}",
               "if value is not None and name in scene.Params.options()\n"
               "                           and value != scene.Params().values()[name]}}"),),
             ("tests/test_cli.py", "tests/test_runs.py", "tests/test_inputs.py")),
    Mutation("memory-start-single-precision", "memory",
             "the start's float64 arrays counted as float32", (("es2particles/frame/memory.py",
              "peaks.add(\"start\", *_elements(q, count, q.components * 8))",
              "peaks.add(\"start\", *_elements(q, count, q.components * 4))"),),
             ("tests/test_memory.py",)),
    Mutation("memory-targets-once", "memory", "a ping-pong target's second texture not counted",
             (("es2particles/frame/parts.py",
               "colour = self.parts * self.buffers * w * h * bytes_per_texel(self.format)",
               "colour = self.parts * w * h * bytes_per_texel(self.format)"),),
             ("tests/test_memory.py",)),
    Mutation("jitter-half-a-code", "jitter", "a jittered read offset over half its code",
             (("shaders/glsl100/lib/state.glsl",
               "return (u - 0.5) * ((1.0 - 2.0 * DITHER_DEAD_ZONE) / 65024.0);",
               "return (u - 0.5) * ((1.0 - 2.0 * DITHER_DEAD_ZONE) / 130048.0);"),),
             ("tests/test_jitter.py",)),
    Mutation("heading-sprites-backwards", "boids", "a dart points the way its boid came from",
             (("shaders/glsl100/sprites/sprite.vert",
               "vec2 along = (ahead.xy / ahead.w - gl_Position.xy / gl_Position.w) * vec2(u_aspect, 1.0);",
               "vec2 along = (gl_Position.xy / gl_Position.w - ahead.xy / ahead.w) * vec2(u_aspect, 1.0);"),),
             ("tests/test_sprite_roles.py",)),
    Mutation("flame-accumulate-unweighed", "flame", "each accumulated march added whole, not 1/K",
             (("shaders/glsl100/flame/march.frag", "    gl_FragColor *= u_weight;",
               "    gl_FragColor *= 1.0;"),),
             ("tests/test_flame.py",)),
    Mutation("state-resumes-at-step-0", "run files", "a loaded state's step count not taken: "
             "the resumed run's dither, gusts and clocks start again from step 0",
             (("es2particles/frame/pipeline.py", "        self.sim.steps_done = steps\n",
               "        self.sim.steps_done = 0\n"),),
             ("tests/test_runs.py::test_a_state_round_trips_with_every_field_off_its_default",)),
    Mutation("gradient-map-green-luma", "post", "the gradient map weighs red as green is weighed",
             (("shaders/glsl100/post/gradient.frag", "vec3(0.2126, 0.7152, 0.0722)",
               "vec3(0.7152, 0.2126, 0.0722)"),),
             ("tests/test_post.py",)),
    Mutation("ramp-lookup-edge-texels", "post", "the ramp read from texel edges, not centres "
             "(every gradient map: density, field, any picture)",
             (("shaders/glsl100/lib/ramp.glsl", "vec2(t * (255.0 / 256.0) + 0.5 / 256.0, 0.5)",
               "vec2(t, 0.5)"),),
             ("tests/test_post.py", "tests/test_flame.py")),
    Mutation("bloom-blur-half-code-high", "bloom", "each blur pass half a code high",
             (("shaders/glsl100/post/blur.frag", "    gl_FragColor = vec4(sum, 1.0);",
               "    gl_FragColor = vec4(sum + 0.5 / 255.0, 1.0);"),),
             ("tests/test_bloom.py::test_each_bloom_stage_is_its_float64_step",)),
    Mutation("bloom-bright-half-code-low", "bloom", "the bright pass half a code low",
             (("shaders/glsl100/post/bright.frag", "    gl_FragColor = vec4(c * keep, 1.0);",
               "    gl_FragColor = vec4(c * keep - 0.5 / 255.0, 1.0);"),),
             ("tests/test_bloom.py::test_each_bloom_stage_is_its_float64_step",)),
    Mutation("bloom-composite-half-code-high", "bloom", "the composite half a code high",
             (("shaders/glsl100/post/composite.frag", "u_intensity * glow, 1.0), 1.0);",
               "u_intensity * glow + 0.5 / 255.0, 1.0), 1.0);"),),
             ("tests/test_bloom.py::test_each_bloom_stage_is_its_float64_step",)),
    Mutation("bloom-reads-the-density", "bloom", "bloom's composite reads the bright pass, not "
             "the picture", (("es2particles/frame/bloom.py", "                 {\"u_source\": Ref(source),",
                              "                 {\"u_source\": Ref(names[0]),"),),
             ("tests/test_bloom.py",)),
    # --- sph -------------------------------------------------------------------------------------
    Mutation("sph-kernel-twice", "sph", "the kernel normalised as 7 / (2 pi h^2): every density doubled",
             ((SPH, "return KERNEL_NORM * t * t * t * t * (2.0 * q + 1.0);",
               "return 2.0 * KERNEL_NORM * t * t * t * t * (2.0 * q + 1.0);"),),
             ("tests/test_sph.py",)),
    Mutation("sph-tait-exponent-six", "sph", "the Tait equation's exponent 6, not 7",
             ((SPH, "return max(u_fluid.y * (s2 * s2 * s2 * s - 1.0), 0.0);",
               "return max(u_fluid.y * (s2 * s2 * s2 - 1.0), 0.0);"),),
             ("tests/test_sph.py",)),
    Mutation("sph-viscosity-sign", "sph", "the artificial viscosity pulls approaching pairs together",
             ((SPH, "term -= u_viscosity * u_fluid.z * mu / (0.5 * (rho + rho_j));",
               "term += u_viscosity * u_fluid.z * mu / (0.5 * (rho + rho_j));"),),
             ("tests/test_sph.py",)),
    Mutation("sph-wall-passes", "sph", "a wall keeps the outward velocity instead of turning it",
             ((SPH, "        v.y *= -u_restitution;", "        v.y *= u_restitution;"),),
             ("tests/test_sph.py",)),
    Mutation("sph-pressure-attracts", "sph", "the pressure gradient's sign flipped",
             ((SPH, "a -= u_mass * term * kernel_slope(r) * d / r;",
               "a += u_mass * term * kernel_slope(r) * d / r;"),),
             ("tests/test_sph.py",)),
    Mutation("sph-saved-density-without-itself", "sph",
             "the saved state's density leaves each particle's own weight out",
             (("es2particles/scenes/sph.py",
               "np.bincount(i, w, n) + np.bincount(j, w, n) + self_weight",
               "np.bincount(i, w, n) + np.bincount(j, w, n)"),),
             ("tests/test_sph.py",)),
    # --- light shafts ------------------------------------------------------------------------------
    Mutation("shafts-ray-from-the-pixel", "shafts",
             "samples taken from the light towards the pixel: the ray's factor measured from the "
             "wrong end",
             ((SHAFTS, "vec2 p = light + (v_uv - light) * f;", "vec2 p = v_uv + (light - v_uv) * f;"),),
             ("tests/test_shafts.py",)),
    Mutation("shafts-flip-behind-the-camera", "shafts",
             "a light behind the camera shines as if in front (the fade takes the cosine's size)",
             (("shaders/glsl100/shafts/composite.frag", "clamp(facing / u_fade, 0.0, 1.0)",
               "clamp(abs(facing) / u_fade, 0.0, 1.0)"),),
             ("tests/test_shafts.py",)),
    Mutation("shafts-gain-lost", "shafts",
             "the passes' normalisation never multiplied back",
             (("es2particles/render/shafts.py", "        gain *= total\n", "        gain *= 1.0\n"),),
             ("tests/test_shafts.py",)),
    Mutation("shafts-sprite-opacity-inverted", "shafts",
             "an occluding sprite lets its opacity through, not one less it",
             (("shaders/glsl100/sprites/sprite.frag", "gl_FragColor = vec4(vec3(1.0 - a), 1.0);",
               "gl_FragColor = vec4(vec3(a), 1.0);"),),
             ("tests/test_shafts.py",)),
    Mutation("shafts-quads-let-light-through", "shafts",
             "confetti drawn in their colours into the occluders, not black",
             (("shaders/glsl100/quads/confetti.frag",
               "gl_FragColor = vec4(0.0, 0.0, 0.0, 1.0);  // light shafts' occluder",
               "gl_FragColor = vec4(v_colour, 1.0);  // light shafts' occluder"),),
             ("tests/test_shafts.py",)),
    # --- trails --------------------------------------------------------------------------------------
    Mutation("trails-never-fade", "trails", "the last frame kept whole, not times the opacity",
             ((TRAILS, "vec3 kept = max(u_keep * texture2D(u_trail, v_uv).rgb - 0.6 / 255.0, 0.0);",
               "vec3 kept = max(texture2D(u_trail, v_uv).rgb - 0.6 / 255.0, 0.0);"),),
             ("tests/test_trails.py",)),
    Mutation("trails-keep-a-ghost", "trails",
             "the fade without its 0.6 of a code: dim trails round back to themselves forever",
             ((TRAILS, "- 0.6 / 255.0, 0.0);", "- 0.0 / 255.0, 0.0);"),),
             ("tests/test_trails.py",)),
    Mutation("trails-added-not-kept-brighter", "trails",
             "the trail added to the picture, not the brighter of the two",
             ((TRAILS, "gl_FragColor = vec4(max(texture2D(u_picture, v_uv).rgb, kept), 1.0);",
               "gl_FragColor = vec4(min(texture2D(u_picture, v_uv).rgb + kept, 1.0), 1.0);"),),
             ("tests/test_trails.py",)),
    Mutation("trails-frames-drawn-alone", "trails",
             "a reseeded scene's wanted frame drawn without the frames its trail holds",
             (("es2particles/frame/settings.py",
               "return bool(scene.stateless) and resolve(settings, None, \"trails\") == \"off\"",
               "return bool(scene.stateless)"),),
             ("tests/test_trails.py",)),
    Mutation("ribbons-every-band-overwritten", "trails",
             "each frame's positions written into every band of the history, not its own",
             (("shaders/glsl100/ribbons/history.frag", "    if (band == u_band) {",
               "    if (band >= 0.0) {"),),
             ("tests/test_trails.py",)),
    Mutation("ribbons-lives-joined", "trails",
             "a particle born again joined to where its last life ended",
             (("shaders/glsl100/ribbons/ribbon.vert",
               "bool empty = newer.a == 0.0 || older.a == 0.0 || newer.a < older.a;",
               "bool empty = newer.a == 0.0 || older.a == 0.0;"),),
             ("tests/test_trails.py",)),
    Mutation("ribbons-fade-reversed", "trails", "ribbons brightest at their oldest end",
             (("shaders/glsl100/ribbons/ribbon.vert",
               "v_fade = 1.0 - (a_segment + (end ? 1.0 : 0.0)) / (u_bands - 1.0);",
               "v_fade = (a_segment + (end ? 1.0 : 0.0)) / (u_bands - 1.0);"),),
             ("tests/test_trails.py",)),
    Mutation("ribbons-newest-band-lags", "trails",
             "the strips read the history one band behind the one just written",
             (("es2particles/frame/trails.py",
               "repeat=tuple({\"u_newest\": float(j)} for j in range(k)), per_frame=1,",
               "repeat=tuple({\"u_newest\": float((j - 1) % k)} for j in range(k)), per_frame=1,"),),
             ("tests/test_trails.py",)),
    # --- flame ---------------------------------------------------------------------------------------
    Mutation("flame-segment-light-not-dimmed", "flame",
             "a segment's light added whole, not times the light let through before it",
             ((FLAME, "light += through * a * ramp_colour(", "light += a * ramp_colour("),),
             ("tests/test_flame.py",)),
    Mutation("flame-ray-from-the-box-origin", "flame",
             "the march starts at the eye, not where the ray enters the box",
             ((FLAME, "float t0 = max(max(max(enter.x, enter.y), enter.z), 0.0);",
               "float t0 = 0.0;"),),
             ("tests/test_flame.py",)),
    Mutation("flame-ramp-half-texel", "flame",
             "the ramp read at the texels' edges, not their centres: half a texel cooler",
             ((FLAME, "ramp_colour(u_ramp, f.y)",
               "texture2D(u_ramp, vec2(f.y * 255.0 / 256.0, 0.5)).rgb"),),
             ("tests/test_flame.py",)),
    Mutation("flame-splat-slice-off-by-one", "flame",
             "a particle splatted into the next z slice's tile",
             (("shaders/glsl100/flame/splat.vert",
               "float row = floor((c.z + 0.5) / u_atlas.y);\n    vec2 texel = vec2(c.z - row",
               "c.z = min(c.z + 1.0, u_atlas.x - 1.0);\n    float row = floor((c.z + 0.5) / u_atlas.y);\n    vec2 texel = vec2(c.z - row"),),
             ("tests/test_flame.py",)),
    Mutation("flame-dead-particles-splatted", "flame",
             "dead and unborn particles splatted with the live ones",
             (("shaders/glsl100/flame/splat.vert", "if (!life_alive(life) || !inside) {",
               "if (!inside) {"),),
             ("tests/test_flame.py",)),
    # --- the wind flame's 3D air -----------------------------------------------------------------
    Mutation("air3d-stencil-without-z", "wind flame",
             "the 3D pressure stencil without its z neighbours (a 5-point stencil in 3D)",
             ((WIND, "    sum += k.z * (pressure_near(c, EZ, p) + pressure_near(c, -EZ, p));\n",
               ""),),
             ("tests/test_air3d.py",)),
    Mutation("air3d-divergence-without-z", "wind flame",
             "the 3D divergence without the flux through the z faces",
             ((WIND, "    flux += (w_at(c + EZ) - w_at(c)) / u_cell.z;\n", ""),),
             ("tests/test_air3d.py",)),
    Mutation("air3d-front-side-closed", "wind flame",
             "an open back or front side's pressure ghost taken as a closed side's",
             ((WIND, "        return (n.z < 0.0 ? u_walls_z.x : u_walls_z.y) == WALL_OPEN ? -p : p;",
               "        return p;"),),
             ("tests/test_air3d.py",)),
    Mutation("air3d-confinement-reversed", "wind flame",
             "3D vorticity confinement's cross product reversed (w x N): it spins the curls down",
             ((WIND, "* cross(n, curl_at(c));", "* cross(curl_at(c), n);"),),
             ("tests/test_air3d.py",)),
    Mutation("air3d-curl-y-sign", "wind flame",
             "the curl's y component with its sign flipped",
             ((WIND, "(f.x - k.x) / h.z - (r.z - l.z) / h.x,", "(r.z - l.z) / h.x - (f.x - k.x) / h.z,"),),
             ("tests/test_air3d.py",)),
    Mutation("air3d-limiter-four-corners", "wind flame",
             "3D MacCormack's limiter over the 4 values of the backtrace's own slice, not 8",
             ((WIND, "#define CORNERS 8\n", "#define CORNERS 4\n"),),
             ("tests/test_air3d.py",)),
    Mutation("maccormack-limiter-from-world-point", "wind flame",
             "MacCormack's limiter cells found from the backtrace's world point, not the cell "
             "less its move: a still cell's own row may round to the one below",
             ((WIND, "    vecd i = floor(c - u_dt * wind_sample(x) * OWN_SIZE / (OWN_HI - OWN_LO));",
               "    vecd i = floor((x - u_dt * wind_sample(x) - OWN_LO) / (OWN_HI - OWN_LO) * OWN_SIZE"
               " - 0.5);"),),
             ("tests/test_air3d.py",)),
    Mutation("fire-maccormack-uncorrected", "wind flame",
             "the fire's MacCormack correction without the behind's error: the ahead alone",
             ((WIND, "    vec2 fire = corrected(c, x) * u_keep;",
               "    vec2 fire = fire_ahead_at(c) * u_keep;"),),
             ("tests/test_air3d.py",)),
    Mutation("fire-buoyancy-from-density", "wind flame",
             "buoyancy from the fire's density, not its temperature",
             ((WIND, "(fire_at(c - d).y + fire_at(c).y)", "(fire_at(c - d).x + fire_at(c).x)"),),
             ("tests/test_air3d.py",)),
    Mutation("fire-never-fades", "wind flame",
             "the fire carried without fading: its keep left out",
             ((WIND, "vec2 fire = sample_fire(x - u_dt * wind_sample(x)) * u_keep;",
               "vec2 fire = sample_fire(x - u_dt * wind_sample(x));"),),
             ("tests/test_air3d.py",)),
    Mutation("fire-feed-ignores-flicker", "wind flame",
             "the burner's feed without its flicker: the same everywhere",
             ((WIND, "max(fire, inside * flicker * u_feed)", "max(fire, inside * u_feed)"),),
             ("tests/test_air3d.py",)),
    Mutation("fire-march-half-density", "wind flame",
             "the march reads the state's fire at half its density",
             ((FLAME, "    return clamp(field_sample(p), 0.0, 1.0);",
               "    return clamp(field_sample(p) * vec2(0.5, 1.0), 0.0, 1.0);"),),
             ("tests/test_flame.py::test_a_uniform_fire_in_the_state_is_the_closed_form",)),
    Mutation("fire-floor-open", "wind flame",
             "the wind flame's floor open, not a slip wall: air comes up through it",
             (("es2particles/scenes/flame.py",
               'WIND_WALLS = tuple(WALL_KINDS["open" if side == 3 else "slip"] for side in range(6))',
               'WIND_WALLS = tuple(WALL_KINDS["open" if side in (2, 3) else "slip"] for side in range(6))'),),
             ("tests/test_flame.py::test_the_wind_flame_rises_from_its_burner",
              "tests/test_flame.py::test_the_wind_flame_s_seed_stirs_its_start")),
    Mutation("pack32-first-code-rounded", "bits32",
             "the first code of a 32-bit value rounded, not floored: the rest below zero clamps "
             "to 0, and a value keeps 16 bits in half its cases",
             (("shaders/glsl100/lib/pack.glsl", "float k1 = floor(scaled);",
               "float k1 = floor(scaled + 0.5);"),),
             ("tests/test_bits32.py",)),
    Mutation("mesh-field-from-mask", "collision3d",
             "a closed mesh's field from its voxel mask alone, as before issue 45",
             (("es2particles/fields/field3d.py", "        if not self.closed:\n            return dist, normal",
               "        if True:\n            return dist, normal"),),
             ("tests/test_collision3d.py::test_a_box_mesh_is_the_box_near_its_surface",
              "tests/test_collision3d.py::test_mesh_field_matches_the_sphere_it_approximates")),
    Mutation("mesh-distance-unsigned", "collision3d",
             "the triangles' distance never signed: inside the band reads as outside",
             (("es2particles/fields/field3d.py",
               "sign = np.where(np.einsum(\"ij,ij->i\", away, n) < 0, -1.0, 1.0)",
               "sign = np.ones(len(points))"),),
             ("tests/test_collision3d.py::test_a_box_mesh_is_the_box_near_its_surface",
              "tests/test_collision3d.py::test_mesh_field_matches_the_sphere_it_approximates")),
    Mutation("run-file-names-stateless-state", "run files",
             "a run file names the state settings of a scene that keeps no state (the flame's "
             "noise): the file is refused on reading",
             (("es2particles/run.py", "        if stateless and name in STATE_SETTINGS:",
               "        if False:"),),
             ("tests/test_runs.py::test_a_run_file_round_trips_every_option_at_a_value_other_than_its_default",)),
    Mutation("run-file-inert-rounding", "run files",
             "a run file writes the scene's default rounding where its state is float (the SPH "
             "with --format rgba16f): the file is refused on reading",
             (("es2particles/run.py", "    return out if stateless else acting_state_settings(scene, out)",
               "    return out"),),
             ("tests/test_runs.py::test_a_run_file_round_trips_every_option_at_a_value_other_than_its_default",)),
    # --- the OpenGL ES device (issue 43) --------------------------------------------------------
    Mutation("gles-no-blend", "OpenGL ES device",
             "a draw's blend state never switched on: every blended draw replaces",
             (("es2particles/gl/gles.py", "            gl.glEnable(BLEND)\n",
               "            pass\n"),),
             ("tests/test_gles.py", "tests/test_dejong.py")),
    Mutation("gles-depth-writes-always", "OpenGL ES device",
             "the depth mask left on for a draw that asks for no depth writes",
             (("es2particles/gl/gles.py", "gl.glDepthMask(1 if state.depth_write else 0)",
               "gl.glDepthMask(1)"),),
             ("tests/test_gles.py", "tests/test_smoke.py")),
    Mutation("gles-clear-keeps-depth", "OpenGL ES device",
             "a clear that leaves the depth buffer as it was",
             (("es2particles/gl/gles.py", "            bits |= DEPTH_BUFFER_BIT\n",
               "            pass\n"),),
             ("tests/test_gles.py", "tests/test_smoke.py")),
    Mutation("gles-half-read-as-bytes", "OpenGL ES device",
             "half-float textures read back through the byte path",
             (("es2particles/gl/gles.py", '        byte = texture.dtype == "f1"',
               '        byte = texture.dtype != "f4"'),),
             ("tests/test_gles.py",)),
    Mutation("point-probe-overclaims", "OpenGL ES device",
             "the point-size probe reports the whole probe row drawn, whatever the driver drew",
             (("es2particles/gl/egl.py", "        return int(lit.sum())",
               "        return int(lit.size)"),),
             ("tests/test_fountain.py::test_sprites_draw_at_their_size_up_to_the_probed_top_of_the_point_sizes",)),
    Mutation("point-probe-ignored", "OpenGL ES device",
             "the sprites clamped to the driver's reported point sizes, not the probed ones",
             (("es2particles/frame/plan.py", "        lo, hi = caps.drawn_point_size_range\n        pixels, spread = args",
               "        lo, hi = caps.point_size_range\n        pixels, spread = args"),),
             ("tests/test_context.py::test_sprites_are_clamped_to_the_probed_point_sizes_not_the_reported_ones",)),
    Mutation("attractor-state-16-bit", "bits32",
             "the stateful attractors' position back in 16-bit codes",
             (("es2particles/scenes/attractor.py", "    state_bits = 32  #",
               "    state_bits = 16  #"),),
             ("tests/test_jitter.py",)),
)

# The subset tests/test_mutations.py runs in the test command: one or two per area, the issue's
# named bugs first, chosen to fit CI's time.
CI_SUBSET = ("pack-half-code-high", "side-of-entry-gone", "substeps-two-cells", "entry-carry-sign",
             "curl-sign", "merge-keeps-larger", "life-ends-a-step-late",
             "iterations-not-ping-ponged", "wind-divergence-sign",
             "neighbour-search-past-the-cell", "boids-separation-attracts",
             "liquid-density-linear", "shafts-sprite-opacity-inverted",
             "trails-keep-a-ghost", "flame-ramp-half-texel", "air3d-stencil-without-z")


def make_copy(folder):
    for name in COPIED:
        source = ROOT / name
        if source.is_dir():
            shutil.copytree(source, folder / name,
                            ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "_shaders"))
        else:
            shutil.copy2(source, folder / name)


def apply(folder, mutation):
    """Make the replacements; return the original texts to put back."""
    originals = {}
    for path, old, new in mutation.edits:
        target = folder / path
        text = originals.get(path) or target.read_text()
        originals.setdefault(path, text)
        current = target.read_text()
        count = current.count(old)
        if count != 1:
            raise SystemExit(f"mutation {mutation.name}: {old!r} occurs {count} times in {path} "
                             f"(it must occur once): the code moved; update tests/mutations.py")
        target.write_text(current.replace(old, new))
    return originals


def run(folder, mutation, timeout=900):
    originals = apply(folder, mutation)
    env = {**os.environ, "PYTHONPATH": str(folder), "PYTHONDONTWRITEBYTECODE": "1"}
    env.pop("CI", None)  # a missing optional tool skips here: the mutation's own tests decide
    started = time.monotonic()
    try:
        stop = () if mutation.every else ("-x",)
        done = subprocess.run([sys.executable, "-m", "pytest", *stop, "-q", "-p", "no:cacheprovider",
                               *mutation.tests], cwd=folder, env=env, capture_output=True,
                              text=True, timeout=timeout)
        code, output = done.returncode, done.stdout + done.stderr
    except subprocess.TimeoutExpired:
        code, output = None, f"timed out after {timeout} s"
    finally:
        for path, text in originals.items():
            (folder / path).write_text(text)
    seconds = time.monotonic() - started
    verdict = {1: "caught", 0: "SURVIVED"}.get(code, "BROKEN")
    failed = [line.split(" ")[1] for line in output.splitlines() if line.startswith("FAILED ")]
    return verdict, seconds, failed, output


def table(rows):
    lines = ["| mutation | area | the bug | tests run | result | first failing test | s |",
             "|---|---|---|---|---|---|---|"]
    for mutation, verdict, seconds, failed in rows:
        first = failed[0].replace("tests/", "") if failed else "-"
        if len(failed) > 1:
            first += f" (and {len(failed) - 1} more)"
        tests = ", ".join(t.replace("tests/", "") for t in mutation.tests)
        lines.append(f"| {mutation.name} | {mutation.area} | {mutation.what} | {tests} | "
                     f"{verdict} | {first} | {seconds:.0f} |")
    return "\n".join(lines)


def run_all(mutations, echo=print):
    rows = []
    with tempfile.TemporaryDirectory(prefix="es2particles-mutations-") as folder:
        folder = Path(folder)
        make_copy(folder)
        for mutation in mutations:
            verdict, seconds, failed, output = run(folder, mutation)
            echo(f"{mutation.name}: {verdict} in {seconds:.0f} s"
                 + (f" ({failed[0]})" if failed else ""))
            if verdict == "BROKEN":
                echo(output[-3000:])
            rows.append((mutation, verdict, seconds, failed))
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m tests.mutations", description=__doc__.split("\n")[0])
    parser.add_argument("names", nargs="*", help="mutations to run (default: all)")
    parser.add_argument("--list", action="store_true", help="list the mutations and stop")
    args = parser.parse_args(argv)
    known = {m.name: m for m in MUTATIONS}
    unknown = [n for n in args.names if n not in known]
    if unknown:
        parser.error(f"no mutation named {', '.join(unknown)} (known: {', '.join(known)})")
    chosen = [known[n] for n in args.names] or list(MUTATIONS)
    if args.list:
        for m in chosen:
            print(f"{m.name:32} {m.area:14} {m.what}")
        return 0
    rows = run_all(chosen, echo=lambda line: print(line, file=sys.stderr, flush=True))
    print(table(rows))
    caught = sum(verdict == "caught" for _, verdict, _, _ in rows)
    print(f"\n{caught} of {len(rows)} mutations caught.")
    return 0 if caught == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
