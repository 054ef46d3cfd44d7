"""One still from more particles than one pipeline holds: the particles drawn in shares.

A still of a counted scene (the attractors: each point adds the same amount, no fading) with more
than ``SHARE`` particles is drawn share by share. Share s holds ``SHARE`` particles (the last one
the rest) and starts from its own seed (seed, s); reseeded, from its own offsets of the texel grid
(samples s * accumulate onwards of the R2 sequence). Each share gives the *count* of samples on
every pixel: whole numbers, exact in its float32 target while a pixel gets fewer than 2^24 (a
share of 2^22 points reaches that only with --accumulate 4 or more on a collapsed attractor, which
is refused). Counts add up in float64, exactly to 2^53, so their sum is the same in any order and
any grouping: one process adding the shares one by one and a cluster adding groups of them as its
tasks finish (``cluster.py``) write the same bytes. The sum, times --intensity, is tone-mapped once.

2^34 particles are 4096 shares; a share of 2^22 takes ~0.4 s reseeded and ~1.7 s stateful (20
steps) on llvmpipe here.
"""

import numpy as np

from ..errors import CapabilityError, ParameterError, check_range

SHARE = 2 ** 22  # particles in a share
MAX_PARTICLES = 2 ** 36  # of a shared still: 16384 shares
EXACT = 2 ** 24  # float32 holds every whole number below this


def share_sizes(args):
    """The particle count of each share of the still ``args`` asks for, or None where the still
    is one plain pipeline: an animation, a scene that is not drawn as counts, or no more than
    ``SHARE`` particles."""
    scene = args.scene_class
    counted = scene.render == "density" and tuple(scene.render_reads) == ("position",)
    if getattr(args, "frames", 1) != 1 or not counted or args.particles is None:
        return None
    particles = int(check_range("particles", args.particles, 1, MAX_PARTICLES, integer=True))
    if particles <= SHARE:
        return None
    if getattr(args, "save_state", None) is not None:
        raise ParameterError(f"--save-state writes one pipeline's state, at most {SHARE} "
                             f"particles; a still of {particles} is drawn in shares")
    whole, rest = divmod(particles, SHARE)
    return [SHARE] * whole + ([rest] if rest else [])


def share_counts(ctx, args, share, count):
    """(h, w) float32: how many samples of share ``share`` (``count`` particles) landed on each
    pixel."""
    from ..cli import _pipeline

    scene, pipeline = _pipeline(ctx, args, particles=count, share=share, intensity=1.0)
    with pipeline:
        if pipeline.renderer.format not in ("r32f", "rgba32f"):
            raise CapabilityError(f"a still of more than {SHARE} particles counts them in a "
                                  f"float32 target; {ctx.caps.renderer} can blend only into "
                                  f"{pipeline.renderer.format}")
        scene.before_frame(pipeline.sim, 0, 1)
        pipeline.warm_up()
        density = pipeline.density()
        w, h = pipeline.size
        channels = 1 if pipeline.renderer.format == "r32f" else 4
        counts = np.frombuffer(density.read(), np.float32).reshape(h, w, channels)[..., 0].copy()
    if counts.max() >= EXACT:
        raise ParameterError(f"a pixel got {counts.max():.0f} samples of one share, beyond the "
                             f"2^24 a float32 count holds exactly (the attractor collapses onto "
                             f"few pixels): lower --accumulate (now {args.accumulate})")
    return counts


def sum_counts(ctx, args, sizes, shares):
    """The float64 sum of the counts of ``shares`` (indices into ``sizes``), one by one."""
    total = None
    for share in shares:
        counts = share_counts(ctx, args, share, sizes[share]).astype(np.float64)
        total = counts if total is None else total + counts
    return total


def tone_map(ctx, args, total, particles):
    """The (h, w, 3) uint8 picture of summed counts ``total``: times --intensity, through the
    post passes of a plain run (tone curve for ``particles`` particles, gradient map, bloom)."""
    from ..cli import _post

    h, w = total.shape
    density = (total * float(args.intensity)).astype(np.float32)
    post = _post(ctx, args, (w, h), particles * args.intensity * args.accumulate / (w * h))
    try:
        texture = post.group.texture((w, h), "r32f", data=density.tobytes(), filter_nearest=False)
        return post.read(post.apply(texture))
    finally:
        post.release()


def still(ctx, args, sizes):
    """The picture of a shared still made in this process: the shares one by one (with progress
    where there are many), summed, then tone-mapped."""
    from ..io.progress import progress

    shares = range(len(sizes))
    if len(sizes) > 8:
        shares = progress(shares, len(sizes), "shares", unit="share")
    return tone_map(ctx, args, sum_counts(ctx, args, sizes, shares), sum(sizes))
