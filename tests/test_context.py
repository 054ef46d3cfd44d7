"""The headless context: its capability report, the store-rule probe, and a clear error without GL."""

import moderngl
import numpy as np
import pytest

import es2particles.gl.egl as context_module
from es2particles import ContextError, open_context


def test_capabilities_are_reported(gl):
    caps = gl.caps
    assert caps.max_texture_size >= 2048
    assert caps.max_vertex_texture_units >= 1, "vertex texture fetch is required"
    assert caps.renderable["rgba8"] and caps.blendable["rgba8"]
    assert caps.store_rule in ("round-to-nearest", "truncate", "floor256")
    text = str(caps)
    assert caps.profile in ("compatibility", "core", "es")
    for label in ("profile", "renderer", "max texture size", "vertex texture image units",
                  "rgba16f render target / additive blend", "8-bit store of a float channel"):
        assert label in text


# GLSL ES 1.00, section 4.5.2: the least each precision qualifier must give, as (log2 of the
# range, bits of relative precision); an int's range only.
LEAST = {"high float": (62, 16), "medium float": (14, 10), "low float": (1, 8),
         "high int": (16, None), "medium int": (10, None), "low int": (8, None)}


def test_info_reports_the_articles_table_as_text_and_json(gl):
    """The shaders' precisions come from the context (glGetShaderPrecisionFormat): highp float
    there is float32 (numpy's finfo: 23 bits, 2^127), every precision at least GLSL ES 1.00's
    minimum; the article's extensions each get a row; ``info --json`` is one JSON object."""
    import json
    import subprocess
    import sys

    table = gl.caps.precision
    f32 = np.finfo(np.float32)
    assert table["fragment"]["high float"] == (f32.maxexp - 1, f32.maxexp - 1, f32.nmant)
    assert gl.caps.fragment_highp
    for shader in ("vertex", "fragment"):
        for name, (range_bits, precision_bits) in LEAST.items():
            lo, hi, bits = table[shader][name]
            assert min(lo, hi) >= range_bits, (shader, name, table[shader][name])
            assert precision_bits is None or bits >= precision_bits, (shader, name)
    text = str(gl.caps)
    for label in ("fragment float precision (high / medium / low)", "OES_texture_half_float",
                  "EXT_color_buffer_half_float", "OES_rgb8_rgba8"):
        assert label in text
    out = subprocess.run([sys.executable, "-m", "es2particles", "info", "--json"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout)
    assert report["precision"]["fragment"]["high float"] == {"range log2": [127, 127],
                                                            "bits": 23}
    assert set(report["article extensions"]) >= {"OES_texture_float", "OES_rgb8_rgba8"}
    assert report["formats"]["rgba8"] == {"render target": True, "additive blend": True}


def test_without_fragment_highp_packed_state_is_refused_in_one_line():
    """The article's Tegra row: no highp float in fragment shaders. A 16-bit code cannot be
    unpacked in mediump's 10 bits, so rgba8 is refused naming the float format, and auto takes
    a float format."""
    from es2particles.errors import CapabilityError
    from es2particles.frame.settings import resolve_format
    from es2particles.gl.context import Capabilities

    tegra = {"vertex": {n: (127, 127, 23) for n in LEAST},
             "fragment": {**{n: (15, 15, 10) for n in LEAST}, "high float": (0, 0, 0)}}
    caps = Capabilities.assumed(probe_precision=lambda: tegra)
    assert not caps.fragment_highp
    with pytest.raises(CapabilityError, match=r"format 'rgba8' packs each value in 16 bits, "
                       r"which fragment shaders without highp float cannot unpack \(this "
                       r"context's best is mediump, 10 bits\): use --format auto"):
        resolve_format(caps, "rgba8")
    assert resolve_format(caps, "rgba16f")[0] == "rgba16f"
    float_less = Capabilities.assumed(probe_precision=lambda: tegra,
                                      renderable={"rgba8": True})
    with pytest.raises(CapabilityError):
        resolve_format(float_less, "rgba8")
    with pytest.raises(CapabilityError, match="--format auto: assumed renders to no state "
                                              "format it can unpack"):
        resolve_format(float_less, "auto")
    assert resolve_format(Capabilities.assumed(), "rgba8")[0] == "rgba8"
    # a quantity declared 32-bit is kept packed even in a float run: refused there too
    from es2particles.frame.graph import PassGraph
    from es2particles.frame.plan import plan_graph

    g = PassGraph()
    g.quantity("t", 0.0, 1.0, components=1, bits=32)
    g.add("keep", "x.frag", writes="t", reads=["t"])
    with pytest.raises(CapabilityError, match=r"quantity 't' is kept packed in rgba8_32"):
        plan_graph(g, 64, fmt="rgba16f", caps=caps)


@pytest.mark.gl
def test_no_context_says_what_to_install(monkeypatch):
    def no_gl(*args, **kwargs):
        raise Exception("libEGL.so: cannot open shared object file")

    monkeypatch.setattr(moderngl, "create_context", no_gl)
    monkeypatch.setenv("ES2PARTICLES_BACKEND", "gl")  # auto would go on to OpenGL ES
    with pytest.raises(ContextError) as info:
        open_context()
    message = str(info.value)
    assert "libegl1" in message and "libgl1-mesa-dri" in message and "libegl-mesa0" in message
    assert "egl: libEGL.so: cannot open shared object file" in message


def test_a_chosen_backend_is_tried_alone(monkeypatch):
    """gl tries moderngl's EGL back-end, then its default one, and never OpenGL ES; gles never
    asks moderngl; a name that is neither is refused naming where it came from."""
    import es2particles.gl.gles as gles

    tried = []

    def record(*args, **kwargs):
        tried.append(kwargs.get("backend", "default"))
        raise Exception("nope")

    class NoES:
        def __init__(self, device=None):
            tried.append("gles")
            raise ContextError("no ES here")

    monkeypatch.setattr(moderngl, "create_context", record)
    monkeypatch.setattr(gles, "GLESDevice", NoES)
    with pytest.raises(ContextError, match="no headless OpenGL context"):
        context_module.open_context(backend="gl")
    assert set(tried) == {"egl", "default"}  # each once per profile
    tried.clear()
    with pytest.raises(ContextError, match="OpenGL ES: no ES here"):
        context_module.open_context(backend="gles")
    assert tried == ["gles"]
    tried.clear()
    with pytest.raises(ContextError, match="no headless OpenGL context.*OpenGL ES: no ES here"):
        context_module.open_context(backend="auto")
    assert tried[-1] == "gles" and set(tried) == {"egl", "default", "gles"}
    monkeypatch.setenv("ES2PARTICLES_BACKEND", "vulkan")
    with pytest.raises(ContextError, match="ES2PARTICLES_BACKEND must be one of gl, gles, auto, "
                                           "got 'vulkan'"):
        context_module.open_context()


@pytest.mark.gl
def test_auto_opens_opengl_es_where_moderngl_cannot_make_a_context(monkeypatch):
    """A driver with ES and no desktop profile moderngl can use (a Raspberry Pi's, a Mali board
    under Panfrost): auto gets an OpenGL ES context, and info says so."""
    def no_desktop(*args, **kwargs):
        raise Exception("no desktop OpenGL here")

    monkeypatch.setattr(moderngl, "create_context", no_desktop)
    with context_module.open_context(backend="auto") as ctx:
        assert ctx.backend == "gles" and ctx.caps.version.startswith("OpenGL ES")
        assert "gles" in str(ctx.caps).split("\n")[0]


@pytest.mark.gl
def test_core_profile_is_the_fallback(monkeypatch):
    """A driver that refuses a compatibility context, or gives one older than GL 3.3, gets core."""
    real = moderngl.create_context
    asked = []

    def refuse_compatibility(require=None, **kwargs):
        asked.append(require)
        if require < context_module.MIN_GL_VERSION:
            raise Exception("no compatibility profile here")
        return real(require=require, **kwargs)

    monkeypatch.setattr(moderngl, "create_context", refuse_compatibility)
    monkeypatch.setenv("ES2PARTICLES_BACKEND", "gl")
    ctx = context_module.open_context()
    try:
        assert ctx.profile == "core" and asked == [300, 330]
        assert "Core Profile" in ctx.caps.version or "Mesa" not in ctx.caps.version
    finally:
        ctx.release()


@pytest.mark.gl
def test_context_releases_everything_and_twice_is_safe():
    ctx = open_context()
    ctx.texture((4, 4))
    ctx.program("lib/fullscreen.vert", "lib/constant.frag")
    assert ctx.live_objects()
    ctx.release()
    ctx.release()
    assert ctx.live_objects() == {}


@pytest.mark.gl
def test_formats_are_probed_when_first_asked_for_and_alike_either_way():
    """A run probes only the formats it uses; a format asked for late gets the same answer as a
    report that probes them all (both are real draws into a target of that format)."""
    with open_context() as lazy, open_context() as full:
        lazy.make_current()
        assert dict(lazy.caps.renderable) == {}  # nothing drawn yet
        assert lazy.caps.blendable.get("r32f") is not None
        assert set(dict(lazy.caps.renderable)) == {"r32f"}
        assert lazy.caps.renderable.get("no-such-format") is None
        full.make_current()
        report = str(full.caps)  # the report asks for every format
        lazy.make_current()
        for fmt in ("rgba8", "rgba16f", "rgba32f", "r32f"):
            assert f"{fmt} render target / additive blend" in report
            assert lazy.caps.renderable[fmt] == full.caps.renderable[fmt]
            assert lazy.caps.blendable[fmt] == full.caps.blendable[fmt]


@pytest.mark.gl
def test_egl_libraries_named_and_found_again_where_missing(monkeypatch):
    """On Linux the EGL back-end is given the libraries' usual names (no `ldconfig -p` run);
    where a name does not load, the context is asked for again the way glcontext finds them."""
    real = moderngl.create_context
    asked = []

    def missing_soname(**kwargs):
        asked.append(kwargs.get("libegl"))
        if kwargs.get("libegl"):
            raise Exception(f"{kwargs['libegl']} not loaded")
        return real(**kwargs)

    monkeypatch.setattr(moderngl, "create_context", missing_soname)
    monkeypatch.setenv("ES2PARTICLES_BACKEND", "gl")
    ctx = context_module.open_context()
    try:
        assert asked == ["libEGL.so.1", None]
        assert ctx.caps.renderer
    finally:
        ctx.release()


@pytest.mark.parametrize("size", [(7, 5), (64, 32)])
def test_rgb_read_is_the_texture_without_alpha_rows_flipped(gl, size):
    """read_rgb asks the driver for RGB alone (odd widths too: rows packed, alignment 1), then
    puts the top row first: against numpy's slice of the uploaded bytes."""
    from es2particles.frame.pipeline import read_rgb

    w, h = size
    texels = np.random.default_rng(w).integers(0, 256, (h, w, 4), dtype=np.uint8)
    group = gl.group()
    try:
        tex = group.texture(size, "rgba8", data=texels.tobytes())
        assert np.array_equal(
            np.frombuffer(gl.read(tex, components=3), np.uint8).reshape(h, w, 3),
            texels[:, :, :3])
        image = read_rgb(gl, tex)
        assert image.flags.writeable and image.flags.c_contiguous
        assert np.array_equal(image, texels[::-1, :, :3])
    finally:
        group.release()


def test_recording_device_reads_the_first_components(recording):
    """The recording device's read of fewer components slices what was written, texel by
    texel, as the GL one does."""
    texels = np.arange(3 * 2 * 4, dtype=np.uint8).reshape(2, 3, 4)
    tex = recording.texture((3, 2), "rgba8", data=texels.tobytes())
    assert recording.read(tex, components=3) == texels[:, :, :3].tobytes()
    assert recording.read(tex) == texels.tobytes()


def test_without_fragment_highp_a_sort_order_is_refused_in_one_line():
    """The sort's comparators decode 16-bit keys and carry particle indices (to 2^24) in
    fragment shaders: without highp float neither the depth sort nor a neighbour grid can run,
    whatever the state's format; refused naming the way out."""
    from es2particles.errors import CapabilityError
    from es2particles.frame.plan import plan_frame
    from es2particles.frame.settings import FrameSettings
    from es2particles.gl.context import Capabilities
    from es2particles.scenes.boids import Boids

    tegra = {"vertex": {n: (127, 127, 23) for n in LEAST},
             "fragment": {**{n: (15, 15, 10) for n in LEAST}, "high float": (0, 0, 0)}}
    caps = Capabilities.assumed(probe_precision=lambda: tegra)
    with pytest.raises(CapabilityError, match=r"a sort order .* need highp float: this "
                                              r"context's best is mediump, 10 bits"):
        plan_frame(Boids(), FrameSettings(particles=1024, size=(32, 32), format="rgba16f"), caps)
    plan_frame(Boids(), FrameSettings(particles=1024, size=(32, 32), format="rgba16f"),
               Capabilities.assumed())  # where fragment shaders have highp it plans


def test_sprites_are_clamped_to_the_probed_point_sizes_not_the_reported_ones():
    """NVIDIA's ES context reports point sizes 1..10 and draws 2048 px points: the sprites' and
    the shadow map's sizes carry the probed top to their shaders' clamp; a probe that saw less
    than the report, or none, leaves the report."""
    from es2particles.frame.plan import frame_value
    from es2particles.gl.context import Capabilities
    from es2particles.render.camera import Camera

    nvidia_es = Capabilities.assumed(point_size_range=(1.0, 10.0), probe_point_size=lambda: 4096)
    assert nvidia_es.drawn_point_size_range == (1.0, 4096.0)
    camera = Camera(eye=(0.0, 1.0, 5.0), target=(0.0, 1.0, 0.0))
    for spec in (("sprite_size", 24.0, 0.0), ("jogl_sprite_size", 24.0, 0.0, 0.0, 0.0, 5.0),
                 ("light_size", 1.0, 1.0, 0.0, 256)):
        assert frame_value(spec, camera, caps=nvidia_es)[-2:] == (1.0, 4096.0), spec
    assert Capabilities.assumed(point_size_range=(1.0, 255.0),
                                probe_point_size=lambda: 64).drawn_point_size_range == (1.0, 255.0)
    assert Capabilities.assumed().drawn_point_size_range == (1.0, 255.0)


@pytest.mark.gl
def test_a_draw_scope_an_interrupt_left_open_closes_quietly_after_the_release():
    """A signal that lands in the draw scope's __enter__, after its generator yielded and before
    the with statement took it, leaves the generator for the collector to close, after the
    interrupted run released its context: closing it then switches nothing off and raises
    nothing (it printed "Exception ignored ... 'NoneType' object has no attribute
    'enable_only'" after "es2particles: interrupted", 1 run in 30 of the interrupt test)."""
    from es2particles.gl.device import DrawState

    ctx = open_context(backend="gl")
    group = ctx.group()
    target = group.framebuffer(group.texture((4, 4)))
    scope = ctx.device.scope(target, DrawState(blend="add", point_size=True, sprites=True))
    scope.__enter__()  # the with statement never took it
    ctx.release()
    scope.gen.close()  # what the collector does
