"""ASTC textures: astcenc's blocks, uploaded compressed and sampled on the GPU, against astcenc's
own decode (which pins the row order) and against the source image."""

import math

import numpy as np
import pytest

from conftest import missing
from es2particles.gl import astc
from es2particles.gl.command import DrawCommand
from es2particles.errors import ParameterError

SAMPLE = """#version 100
// Test pass: every texel of u_source as it is (NEAREST, same size as the target).
precision highp float;
varying vec2 v_uv;
uniform sampler2D u_source;

void main()
{
    gl_FragColor = texture2D(u_source, v_uv);
}
"""
# Error against the source allowed per block size, in 1/255 steps, on the smooth image below:
# (max, mean). Measured with astcenc 4.2 -medium: (10, 1.64), (13, 1.96), (25, 3.02). Four unrelated
# channels are ASTC's hardest case (one endpoint line per partition in RGBA space), so the
# tolerance is the measurement with a margin for other encoder builds, not a format bound.
TOLERANCE = {(4, 4): (12, 2.0), (6, 6): (16, 2.5), (8, 8): (30, 3.5)}


@pytest.fixture(scope="module", autouse=True)
def astc_ready(ctx):
    reason = astc.unavailable(ctx)
    if reason:
        missing(reason)


def smooth_image(w=96, h=80):
    """Gradients and a slow sine per channel, not a multiple of every block in size."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    channels = [x / (w - 1), y / (h - 1), 0.5 + 0.4 * np.sin(x / 13 + y / 17),
                0.5 + 0.4 * np.cos(x / 19 - y / 11)]
    return np.round(np.stack(channels, axis=-1) * 255).astype(np.uint8)


def sample(gl, compressed, tmp_path):
    """The texels of ``compressed``, uploaded and drawn by the GPU into an RGBA8 target, as
    (h, w, 4), row t = 0 first."""
    frag = tmp_path / "sample.frag"
    frag.write_text(SAMPLE)
    group = gl.group()
    try:
        texture = group.compressed_texture(compressed)
        target = group.texture(texture.size)
        fbo = group.framebuffer(target)
        DrawCommand(group, "astc sample", str(frag)).draw(fbo, {"u_source": texture})
        w, h = texture.size
        return np.frombuffer(target.read(), dtype=np.uint8).reshape(h, w, 4).copy()
    finally:
        group.release()


@pytest.mark.parametrize("block", [(4, 4), (6, 6), (8, 8)])
def test_gpu_samples_what_astcenc_decodes(gl, tmp_path, block):
    image = smooth_image()
    compressed = astc.compress(image, block)
    decoded = astc.decompress(compressed)
    gpu = sample(gl, compressed, tmp_path).astype(int)
    to_twin = np.abs(gpu - decoded).max()
    assert to_twin <= 1, f"GPU vs astcenc -dl: max {to_twin}/255 (rows flipped if large)"
    error = np.abs(gpu - image)
    print(f"ASTC {block[0]}x{block[1]}: max {error.max()}/255, mean {error.mean():.3f}/255")
    most, mean = TOLERANCE[block]
    assert error.max() <= most and error.mean() <= mean, (
        f"ASTC {block}: error max {error.max()}/255, mean {error.mean():.3f}/255; allowed "
        f"{most}, {mean}")


def test_rows_are_not_flipped(gl, tmp_path):
    """Row 0 of the image is texture row t = 0: a top-heavy image stays top-heavy."""
    image = np.zeros((64, 48, 4), np.uint8)
    image[:32] = 255
    gpu = sample(gl, astc.compress(image, (4, 4)), tmp_path)
    assert gpu[:32].min() == 255 and gpu[32:].max() == 0


@pytest.mark.parametrize("block", [(4, 4), (6, 6), (8, 8), (12, 10)])
def test_sizes(block):
    compressed = astc.compress(smooth_image(), block)
    bw, bh = block
    assert compressed.bits_per_texel == 128 / (bw * bh)
    assert compressed.nbytes == math.ceil(96 / bw) * math.ceil(80 / bh) * 16
    assert compressed.internal_format == astc.BLOCKS[block]


def test_bad_arguments():
    image = smooth_image(16, 16)
    with pytest.raises(ParameterError, match="4x4, 5x4"):
        astc.compress(image, (7, 7))
    with pytest.raises(ParameterError, match="preset"):
        astc.compress(image, preset="best")
    for bad in (image.astype(np.float32), image[..., :3], image[0]):
        with pytest.raises(ParameterError, match=r"\(h, w, 4\) uint8"):
            astc.compress(bad)
    with pytest.raises(ParameterError, match="astc.Compressed"):
        astc.decompress(image)


def test_upload_takes_compressed_only(gl):
    with pytest.raises(ParameterError, match="astc.Compressed"):
        gl.compressed_texture(smooth_image(8, 8))


def test_owned_and_released(gl):
    compressed = astc.compress(smooth_image(16, 16), (4, 4))
    before = gl.live_objects().get("Texture", 0)
    group = gl.group()
    group.compressed_texture(compressed)
    assert gl.live_objects().get("Texture", 0) == before + 1
    group.release()
    assert gl.live_objects().get("Texture", 0) == before
