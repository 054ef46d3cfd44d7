"""One still from more particles than one pipeline holds: the particles drawn in shares.

A still of a counted scene (the attractors: each point adds the same amount, no fading) with more
than ``SHARE`` particles is drawn share by share. Share s holds ``SHARE`` particles (the last one
the rest) and starts from its own seed (seed, s); reseeded, from its own offsets of the texel grid
(samples s * accumulate onwards of the R2 sequence). Each share gives the *count* of samples on
every pixel: whole numbers, exact in its float32 target while a pixel gets fewer than 2^24 (a
share of 2^22 points reaches that only with --accumulate 4 or more on a collapsed attractor, which
is refused). Counts add up in float64, exactly to 2^53, so their sum is the same in any order and
any grouping: one process adding the shares one by one and a cluster adding groups of them as its
tasks finish (``cluster/tasks.py``) write the same bytes. The sum, times --intensity, is tone-mapped once.

2^34 particles are 4096 shares; a share of 2^22 takes ~0.4 s reseeded and ~1.7 s stateful (20
steps) on llvmpipe here.
"""

import numpy as np

from ..errors import CapabilityError, ParameterError, check_range
from ..frame.settings import resolve

SHARE = 2 ** 22  # particles in a share
MAX_PARTICLES = 2 ** 36  # of a shared still: 16384 shares
EXACT = 2 ** 24  # float32 holds every whole number below this


def share_sizes(run, save_state=False):
    """The particle count of each share of the still ``run`` asks for, or None where the still
    is one plain pipeline: an animation, a scene that is not drawn as counts, or no more than
    ``SHARE`` particles (or the scene's default). ``save_state``: a state file is asked for too
    (one pipeline's, refused for a shared still)."""
    from ..frame.settings import DEFAULT
    from ..render.points import Density

    particles = run.settings.particles
    if run.frames != 1 or particles is DEFAULT:
        return None
    lo = 0 if run.scene_class().runs_alone else 1  # 0: the grids alone, one pipeline
    particles = int(check_range("--particles", particles, lo, MAX_PARTICLES, integer=True))
    if particles <= SHARE:
        return None
    rendering = run.make_scene().rendering()
    if not (isinstance(rendering, Density) and rendering.reads == ("position",)):
        return None
    if save_state:
        raise ParameterError(f"--save-state writes one pipeline's state, at most {SHARE} "
                             f"particles; a still of {particles} is drawn in shares")
    whole, rest = divmod(particles, SHARE)
    return [SHARE] * whole + ([rest] if rest else [])


def share_counts(ctx, run, share, count):
    """(h, w) float32: how many samples of share ``share`` (``count`` particles) landed on each
    pixel."""
    scene, pipeline = run.pipeline(ctx, particles=count, share=share, intensity=1.0)
    with pipeline:
        fmt = pipeline.plan.resources["density"].format
        if fmt not in ("r32f", "rgba32f"):
            raise CapabilityError(f"a still of more than {SHARE} particles counts them in a "
                                  f"float32 target; {ctx.caps.renderer} can blend only into "
                                  f"{fmt}")
        pipeline.begin(1)
        density = pipeline.density()
        w, h = pipeline.size
        channels = 1 if fmt == "r32f" else 4
        counts = np.frombuffer(ctx.read(density), np.float32).reshape(h, w, channels)[..., 0]
        counts = counts.copy()
    if counts.max() >= EXACT:
        accumulate = resolve(run.settings, None, "accumulate")
        raise ParameterError(f"a pixel got {counts.max():.0f} samples of one share, beyond the "
                             f"2^24 a float32 count holds exactly (the attractor collapses onto "
                             f"few pixels): lower --accumulate (now {accumulate})")
    return counts


def sum_counts(ctx, run, sizes, shares):
    """The float64 sum of the counts of ``shares`` (indices into ``sizes``), one by one."""
    total = None
    for share in shares:
        counts = share_counts(ctx, run, share, sizes[share]).astype(np.float64)
        total = counts if total is None else total + counts
    return total


def tone_map(ctx, run, total, particles):
    """The (h, w, 3) uint8 picture of summed counts ``total``: times --intensity, through the
    post stages of a plain run (tone curve for ``particles`` particles, gradient map, bloom),
    planned and drawn as a frame whose density is the sum."""
    from ..frame.executor import Executor
    from ..frame.pipeline import read_rgb
    from ..frame.plan import PlanBuilder, Resource
    from ..frame.bloom import plan_bloom
    from ..render.post import plan_post

    h, w = total.shape
    scene = run.make_scene()
    b = PlanBuilder(run.scene, run.settings, ctx.caps, scene.rendering(), scene.defaults)
    intensity = float(b.setting("intensity"))
    density = (total * intensity).astype(np.float32)
    b.resource(Resource("density", "image", (w, h), "r32f", linear=True, data=density,
                        what="the shares' summed counts"))
    present = plan_post(b, "density", particles * intensity * b.setting("accumulate") / (w * h),
                        b.setting("exposure"), b.setting("gradient"),
                        scene.rendering().background)
    present = plan_bloom(b, present, b.setting("bloom"))
    with Executor(ctx, b.finish(present=present)) as executor:
        return read_rgb(ctx, executor.render())


def still(ctx, run, sizes):
    """The picture of a shared still made in this process: the shares one by one (with progress
    where there are many), summed, then tone-mapped."""
    from ..io.progress import progress

    shares = range(len(sizes))
    if len(sizes) > 8:
        shares = progress(shares, len(sizes), "shares", unit="share")
    return tone_map(ctx, run, sum_counts(ctx, run, sizes, shares), sum(sizes))
