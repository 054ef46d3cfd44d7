"""Points and sprites without vertex texture fetch (the article's Tegra row): the state read back
into vertex buffers each frame and decoded by the same read_q() from attributes. The density is
the fetch path's, count for count, and the sprites' picture byte for byte; a context with no
vertex texture units takes this path by itself, and what needs textures in the sprites' vertex
shader (the depth sort, the shadow map) is refused without it in one line."""

import numpy as np
import pytest

from es2particles.errors import CapabilityError
from es2particles.frame.pipeline import Pipeline
from es2particles.frame.plan import plan_frame
from es2particles.frame.settings import FrameSettings
from es2particles.gl.context import Capabilities
from es2particles.scenes import Clifford, Collision, Collision3D, DeJong, Fountain, Smoke


@pytest.mark.gl
@pytest.mark.parametrize("scene, settings", [
    (DeJong(), {}), (DeJong(reseed=True), {"accumulate": 3}), (Clifford(), {"fmt": "rgba32f"}),
    (DeJong(reseed=True), {"fmt": "rgba16f"}), (Collision(), {"steps": 60})], ids=lambda v: str(v)[:30])
def test_the_density_read_back_is_the_fetched_one(gl, scene, settings):
    densities, images = [], []
    for fetch in ("on", "off"):
        with Pipeline(gl, scene, particles=2 ** 15, size=(128, 128), vertex_fetch=fetch,
                      **settings) as pipeline:
            points = pipeline.plan.stage("points")
            assert bool(points.attributes) == (fetch == "off") and \
                bool(points.inputs) == (fetch == "on")
            frames = list(pipeline.frames(2, steps_per_frame=3))
            densities.append(np.frombuffer(pipeline.executor.read("density"), np.float32))
            images.append(pipeline.image())
    assert len(frames) == 2 and densities[0].sum() > 0
    assert np.array_equal(densities[0], densities[1]) and np.array_equal(*images)


def test_a_context_without_vertex_texture_units_reads_the_state_back():
    caps = Capabilities.assumed(max_vertex_texture_units=0)
    plan = plan_frame(Collision(), FrameSettings(particles=4096), caps)
    points = plan.stage("points")
    assert set(points.attributes) == {"a_position", "a_life"} and not points.inputs
    line = next(line for line in plan.describe() if "points:" in line)
    assert "no vertex texture fetch: position and life read back each frame" in line
    assert "2 texture reads, 32 KiB a frame" in line
    with pytest.raises(CapabilityError, match="--vertex-fetch on: this context has no vertex "
                                              "texture units"):
        plan_frame(DeJong(), FrameSettings(particles=4096, vertex_fetch="on"), caps)


@pytest.mark.gl
@pytest.mark.parametrize("scene, settings", [
    (Fountain(), {}), (Fountain(), {"fmt": "rgba32f"}), (Fountain(buffer_scale=0.5), {}),
    (Collision3D(), {"steps": 30})], ids=lambda v: str(v)[:40])
def test_sprites_read_back_draw_the_fetched_picture(gl, scene, settings):
    images = []
    for fetch in ("on", "off"):
        with Pipeline(gl, scene, particles=4096, size=(128, 128), vertex_fetch=fetch,
                      **settings) as pipeline:
            sprites = pipeline.plan.stage("sprites")
            assert bool(sprites.attributes) == (fetch == "off")
            next(pipeline.frames())
            images.append(pipeline.image())
    assert images[0].max() > 0 and np.array_equal(*images)


def test_sprites_without_vertex_units_read_back_and_sorting_is_refused():
    caps = Capabilities.assumed(max_vertex_texture_units=0)
    plan = plan_frame(Fountain(), FrameSettings(particles=4096), caps)
    assert set(plan.stage("sprites").attributes) == {"a_position", "a_position_1", "a_life"}
    line = next(line for line in plan.describe() if "sprites:" in line)
    assert "no vertex texture fetch: position, life read back each frame" in line
    with pytest.raises(CapabilityError, match=r"--vertex-fetch off: the depth sort and the "
                                              r"shadow map of this scene's sprites read textures "
                                              r"in their vertex shader"):
        plan_frame(Smoke(), FrameSettings(particles=4096, vertex_fetch="off"))
    with pytest.raises(CapabilityError, match=r"^this context has no vertex texture units: the "
                                              r"depth sort and the shadow map"):
        plan_frame(Smoke(), FrameSettings(particles=4096), caps)
