"""Time a de Jong frame by stage on the GPU pipeline and a numpy float32 reference of the same job.

Run: ``python benchmarks/bench.py [--sizes 16,18,20] [--repeats 5]``. Prints a table (median, min,
max of the repeats after a warm-up, GL work finished inside each timing) and writes it as Markdown
to ``out/bench/dejong.md``. Ratios are numpy time / our time, measured in the same process, since
these machines are shared and noisy: compare ratios, not seconds.
"""

import argparse
import io
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from PIL import Image

from es2particles import open_context
from es2particles.pipeline import Pipeline
from es2particles.post import Bloom
from es2particles.ramps import load_ramp
from es2particles.scenes.dejong import ARTICLE_COEFFICIENTS, DeJong, dejong_map

SIZE = (1024, 1024)


def timed(function, repeats):
    function()  # warm-up
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return statistics.median(times), min(times), max(times)


class NumpyReference:
    """The same frame in numpy float32: map, bincount density, log tone curve, ramp, blur bloom."""

    def __init__(self, count, rng):
        self.p = rng.uniform(-2, 2, (count, 2)).astype(np.float32)
        self.ramp = load_ramp("inferno")[:, :3]
        self.k = tuple(np.float32(c) for c in ARTICLE_COEFFICIENTS)

    def step(self):
        self.p = dejong_map(self.p, self.k, 3).astype(np.float32)

    def render(self):
        w, h = SIZE
        ij = ((self.p + 2) * np.float32(w / 4)).astype(np.int32).clip(0, w - 1)
        self.density = np.bincount(ij[:, 1] * w + ij[:, 0], minlength=w * h).reshape(h, w)

    def post(self):
        mean = len(self.p) / self.density.size
        t = np.log1p(np.float32(4) * self.density / mean) / np.log1p(np.float32(4 * 256))
        image = self.ramp[(np.clip(t, 0, 1) * 255).astype(np.uint8)].astype(np.float32) / 255
        half = image.reshape(SIZE[1] // 2, 2, SIZE[0] // 2, 2, 3).mean(axis=(1, 3))
        bright = half * (half.mean(axis=2, keepdims=True) > 0.6)
        kernel = np.exp(-0.5 * (np.arange(-12, 13) / 3.0) ** 2).astype(np.float32)
        kernel /= kernel.sum()
        blur = np.apply_along_axis(np.convolve, 0, bright, kernel, "same")
        blur = np.apply_along_axis(np.convolve, 1, blur, kernel, "same")
        glow = blur.repeat(2, axis=0).repeat(2, axis=1)
        self.image = (np.minimum(image + 0.8 * glow, 1) * 255).astype(np.uint8)


def png_bytes(image):
    buffer = io.BytesIO()
    Image.fromarray(image).save(buffer, format="PNG")
    return buffer.getvalue()


def bench(ctx, log2n, repeats):
    count = 2 ** log2n
    rows = []
    with Pipeline(ctx, DeJong(), count, SIZE, bloom=Bloom()) as gpu:
        finish = ctx.mgl.finish
        step = timed(lambda: (gpu.step(1), finish()), repeats)
        render = timed(lambda: (gpu.renderer.draw(gpu.sim.buffers["position"]), finish()), repeats)
        density = gpu.renderer.target
        post = timed(lambda: (gpu.post.apply(density), finish()), repeats)
        final = gpu.post.apply(density)
        readback = timed(lambda: gpu.post.read(final), repeats)
        image = gpu.post.read(final)
        encode = timed(lambda: png_bytes(image), repeats)
        frame = timed(lambda: (gpu.step(1), gpu.render(), png_bytes(gpu.image())), repeats)
    ref = NumpyReference(count, np.random.default_rng(0))
    ref.render()
    ours = {"step": step, "render": render, "post": post, "readback": readback, "PNG encode": encode,
            "whole frame": frame}
    theirs = {"step": timed(ref.step, repeats), "render": timed(ref.render, repeats),
              "post": timed(ref.post, repeats), "readback": None,
              "PNG encode": timed(lambda: png_bytes(ref.image), repeats),
              "whole frame": timed(lambda: (ref.step(), ref.render(), ref.post(),
                                            png_bytes(ref.image)), repeats)}
    for stage, (median, lo, hi) in ours.items():
        peer = theirs[stage]
        ratio = f"{peer[0] / median:.2f}" if peer else "-"
        peer_text = f"{peer[0] * 1e3:.1f}" if peer else "-"
        rows.append((f"2^{log2n}", stage, f"{median * 1e3:.1f}", f"{lo * 1e3:.1f}",
                     f"{hi * 1e3:.1f}", peer_text, ratio))
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="16,18,20", help="log2 of the particle counts")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    header = ("N", "stage", "ours median ms", "min", "max", "numpy ms", "numpy / ours")
    with open_context() as ctx:
        print(f"renderer: {ctx.caps.renderer}; frame {SIZE[0]}x{SIZE[1]}, de Jong, 3 iterations, "
              "bloom on", file=sys.stderr)
        rows = [row for n in args.sizes.split(",") for row in bench(ctx, int(n), args.repeats)]
        renderer = ctx.caps.renderer
    widths = [max(len(str(r[i])) for r in rows + [header]) for i in range(len(header))]
    for row in [header] + rows:
        print("  ".join(str(v).rjust(w) for v, w in zip(row, widths)))
    out = Path("out/bench")
    out.mkdir(parents=True, exist_ok=True)
    lines = [f"Renderer: {renderer}", "", "| " + " | ".join(header) + " |",
             "|" + "---|" * len(header)] + ["| " + " | ".join(row) + " |" for row in rows]
    (out / "dejong.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
