"""The frame plan and its executor's call stream, on a recording device (no GL library loaded):
which texture each sampler reads and which framebuffer each draw writes, in which order, the
ping-pong of a step and of the sort's passes, draws per part, the strict uniform policy, culling,
and what is released. The numbers these draws make are tested on GL in the other files."""

import re
import subprocess
import sys

import numpy as np
import pytest

from conftest import shader, wide_graph
from es2particles import GraphError, ParameterError, PassGraph, Simulation
from es2particles.frame.executor import Executor
from es2particles.frame.pipeline import Pipeline
from es2particles.frame.plan import Ref, Rendering, Resource, Stage, plan_frame
from es2particles.frame.settings import FrameSettings
from es2particles.gl.command import DrawCommand
from es2particles.render.camera import Camera
from es2particles.scenes import Clifford, Collision, Collision3D, DeJong, Fountain, Smoke


def draws(recording):
    return recording.device.of("draw")


def sampled(call):
    """sampler name -> the texture handle a recorded draw bound to it (by its unit)."""
    program = call["program"]
    active = program.device.uniforms(program)
    return {name: call["textures"][unit] for name, unit in call["uniforms"].items()
            if active[name].sampler}


def target_texture(call):
    return call["framebuffer"].details["colour"]


# --- a step: ping-pong and parts ------------------------------------------------------------

@pytest.fixture
def counter_shaders(tmp_path, monkeypatch):
    """Two one-line passes: speed from last step's speed, position from last step's position and
    this step's speed."""
    (tmp_path / "speed.frag").write_text(
        "#version 100\nvoid main() { write_speed(read_speed(v_uv) + 0.25); }\n")
    (tmp_path / "position.frag").write_text(
        "#version 100\nvoid main() { write_position(read_position(v_uv) + read_speed(v_uv)); }\n")
    g = PassGraph()
    g.quantity("position", 0, 4, components=1)
    g.quantity("speed", 0, 4, components=1)
    g.add("speed", str(tmp_path / "speed.frag"), writes="speed", reads=["speed"])
    g.add("position", str(tmp_path / "position.frag"), writes="position", reads=["position"],
          reads_new=["speed"])
    return g


def test_a_step_reads_last_step_s_fronts_and_this_step_s_writes_then_swaps(recording,
                                                                            counter_shaders):
    with Simulation(recording, counter_shaders, 16) as sim:
        speed, position = sim.buffers["speed"], sim.buffers["position"]
        fronts = {"speed": speed.fronts[0], "position": position.fronts[0]}
        backs = {"speed": speed.written[0], "position": position.written[0]}
        recording.device.calls.clear()
        sim.step()
        first, second = draws(recording)
        assert target_texture(first) is backs["speed"]  # speed is written first (position
        assert sampled(first) == {"u_speed": fronts["speed"]}  # reads this step's speed)
        assert target_texture(second) is backs["position"]
        assert sampled(second) == {"u_position": fronts["position"],
                                   "u_speed": backs["speed"]}  # this step's: the written one
        # the swap: next step reads what this one wrote, and writes where it read
        recording.device.calls.clear()
        sim.step()
        third, fourth = draws(recording)
        assert target_texture(third) is fronts["speed"] and \
            sampled(third) == {"u_speed": backs["speed"]}
        assert sampled(fourth) == {"u_position": backs["position"], "u_speed": fronts["speed"]}


@pytest.mark.parametrize("fmt, parts", [("rgba8", 2), ("rgba32f", 1)])
def test_a_quantity_of_three_components_is_drawn_once_per_part(recording, fmt, parts):
    with Simulation(recording, wide_graph(), 64, fmt=fmt) as sim:
        backs = list(sim.buffers["position"].written)
        recording.device.calls.clear()
        sim.step()
        written = [target_texture(c) for c in draws(recording) if target_texture(c) in backs]
        assert written == backs and len(written) == parts
        assert [s.target.part for s in sim.stages if s.target.resource == "position"] == \
            list(range(parts))


def test_a_pass_the_outputs_do_not_need_is_never_compiled(recording):
    g = PassGraph()
    g.quantity("position", -1, 1)
    g.quantity("broken", 0, 1)
    g.add("drift", "examples/drift.frag", writes="position", reads=["position"],
          uniforms={"u_delta": (0.01, 0.0)})
    g.add("never", shader("broken.frag"), writes="broken", reads=["position"])
    with Simulation(recording, g, 16, outputs=["position"]) as sim:
        sim.step()
        assert [s.name for s in sim.stages] == ["pass 'drift'"]
    programs = recording.device.of("program")
    assert not any("broken" in c["program"].details["fragment"] for c in programs)


# --- the frame: stages in order, the sort's ping-pong, what each sampler reads ---------------

def smoke_pipeline(recording, **settings):
    return Pipeline(recording, Smoke(), particles=1000, size=(64, 48), steps=0, **settings)


def test_the_smoke_frame_runs_its_stages_in_the_plan_s_order(recording):
    with smoke_pipeline(recording) as pipeline:
        recording.device.calls.clear()
        pipeline.render()
        names = [c["stage"] for c in draws(recording)]
        plan = pipeline.plan
        merges = len(plan.stage("sort merge").repeat)
        assert names == (["sort key"] + ["sort merge"] * merges + ["shadow map", "mesh 1",
                                                                   "mesh 2", "sprites"])
        clears = [c["framebuffer"] for c in recording.device.of("clear")]
        image = pipeline.executor.resources["image"].framebuffer()
        assert clears == [pipeline.executor.resources["shadow map"].framebuffer(), image]


def test_the_sort_ping_pongs_after_every_draw_and_the_sprites_read_its_result(recording):
    with smoke_pipeline(recording, ) as pipeline:
        order = pipeline.executor.resources["order"]
        recording.device.calls.clear()
        pipeline.render()
        calls = draws(recording)
        sort_calls = [c for c in calls if c["stage"].startswith("sort")]
        for before, after in zip(sort_calls, sort_calls[1:]):
            # each pass reads what the one before wrote, and writes the other texture
            assert sampled(after)["u_order"] is target_texture(before)
            assert target_texture(after) is not target_texture(before)
        sprites = calls[-1]
        assert sampled(sprites)["u_order"] is order.fronts[0] is target_texture(sort_calls[-1])
        shadow = pipeline.executor.resources["shadow map"].fronts[0]
        assert sampled(sprites)["u_shadow_map"] is shadow
        assert sampled(sprites)["u_sprite"] is sampled(sprites)["u_shadow_sprite"]
        positions = pipeline.sim.buffers["position"].fronts
        assert [sampled(sprites)[s] for s in ("u_position", "u_position_1")] == positions
        # the merge passes' (p, k): the network's schedule, in order
        merge = pipeline.plan.stage("sort merge")
        got = [(c["uniforms"]["u_p"], c["uniforms"]["u_k"]) for c in sort_calls[1:]]
        assert got == [(r["u_p"], r["u_k"]) for r in merge.repeat]


def test_a_sort_spread_over_frames_draws_k_passes_a_frame_and_goes_on_where_it_stopped(
        recording):
    with Pipeline(recording, Smoke(sort=7), particles=1000, size=(64, 48), steps=0) as p:
        schedule = [(r["u_p"], r["u_k"]) for r in p.plan.stage("sort merge").repeat]
        seen = []
        for frame in range(3):
            recording.device.calls.clear()
            p.render(frame, 3)
            merges = [c for c in draws(recording) if c["stage"] == "sort merge"]
            assert len(merges) == 7
            seen += [(c["uniforms"]["u_p"], c["uniforms"]["u_k"]) for c in merges]
        assert seen == [schedule[i % len(schedule)] for i in range(21)]


def test_the_camera_and_the_moving_sphere_are_set_per_frame(recording):
    with smoke_pipeline(recording) as pipeline:
        camera = pipeline.camera(0, 1)
        pipeline.step(30)
        recording.device.calls.clear()
        pipeline.render()
        by_stage = {c["stage"]: c for c in draws(recording)}
        aspect = 64 / 48
        assert by_stage["sprites"]["uniforms"]["u_view_projection"] == camera.uniform(aspect)
        assert by_stage["sprites"]["uniforms"]["u_eye"] == camera.eye
        # The sphere's mesh is placed by lib/motion.glsl from the smoke's sway at t = 30 dt
        # (the physics' own uniforms); the floor does not move.
        p = pipeline.scene.params
        sphere = by_stage["mesh 2"]["uniforms"]
        assert sphere["u_motion_time"] == 30 * p.dt
        assert sphere["u_motion_offset"] == tuple(p.sphere[:3])
        assert sphere["u_motion_sway"] == tuple(p.sway)
        assert sphere["u_motion_pivot"] == (0.0, 0.0, 0.0, 1.0)
        assert not any(name.startswith("u_motion") for name in by_stage["mesh 1"]["uniforms"])


def test_a_frame_loop_steps_between_frames_and_sets_each_frame_s_uniforms(recording):
    scene = DeJong(animate_to=(1.5, -2.2, 2.3, -2.0))
    with Pipeline(recording, scene, particles=256, size=(32, 32), steps=3,
                  bloom=None) as pipeline:
        recording.device.calls.clear()
        frames = list(pipeline.frames(3, steps_per_frame=2))
        assert frames == [0, 1, 2]
        names = [c["stage"] for c in draws(recording)]
        passes = [n for n in names if n.startswith("pass")]
        # the warm-up, then steps between frames; two draws a step (32-bit x, then y)
        assert len(passes) == 2 * (3 + 2 + 2)
        per_frame = [c["uniforms"]["u_coefficients"] for c in draws(recording)
                     if c["stage"].startswith("pass")]
        assert per_frame[0] == scene.coefficients_at(0, 3)
        assert per_frame[-1] == pytest.approx(scene.coefficients_at(2, 3))
        assert names.count("points") == 3 and names.count("tone map") == 3


# --- the strict policy, culling, settings, releases -------------------------------------------

def test_a_uniform_the_shader_does_not_use_is_an_error_naming_stage_file_and_name(recording):
    group = recording.group()
    command = DrawCommand(group, "post stage bloom bright", "post/bright.frag")
    command.set("u_threshold", 0.5)
    with pytest.raises(ParameterError, match=r"post stage bloom bright \(post/bright.frag\): "
                                             r"uniform 'u_treshold' is given, but the shader "
                                             r"does not declare it"):
        command.set("u_treshold", 0.5)
    with pytest.raises(ParameterError, match="sampler 'u_source' is used by the shader but "
                                             "nothing feeds it"):
        command.draw(group.framebuffer(group.texture((4, 4))), {})
    with pytest.raises(ParameterError, match="'u_sauce', which the shader does not declare"):
        command.draw(group.framebuffer(group.texture((4, 4))),
                     {"u_source": group.texture((4, 4)), "u_sauce": group.texture((4, 4))})
    group.release()


class Unread(Rendering):
    """A rendering with a stage whose target nothing reads: the plan leaves it out."""

    kind = "a test rendering"

    def plan(self, b, defaults):
        from es2particles.render.points import Density

        present = Density((-2, -2, 2, 2)).plan(b, defaults)
        b.resource(Resource("scratch", "target", (4, 4), "rgba8"))
        b.stage(Stage("scratch", "post", "post/bright.frag", inputs={"u_source": Ref(present)},
                      target=Ref("scratch"), uniforms={"u_threshold": 0.5}))
        return present

    settings = ("point_size", "intensity", "exposure", "gradient", "accumulate", "vertex_fetch")


class UnreadScene(DeJong):
    name = "unread"

    def rendering(self):
        return Unread()


def test_culling_walks_back_from_the_picture_and_says_what_it_left_out():
    plan = plan_frame(UnreadScene(), FrameSettings(particles=64, size=(16, 16)))
    assert "scratch" not in [s.name for s in plan.stages]
    assert "post stage scratch (nothing reads scratch)" in plan.left_out
    assert ("gradient map (off: the picture as drawn), bloom (switched off), post stage "
            "scratch (nothing reads scratch)") in str(plan)


@pytest.mark.parametrize("scene, setting, option", [
    (Fountain(), dict(exposure=2.0), "--exposure"),
    (Fountain(), dict(intensity=2.0), "--intensity"),
    (Smoke(), dict(intensity=2.0), "--intensity"),
    (Collision3D(field_resolution=16), dict(accumulate=2), "--accumulate"),
    (Smoke(), dict(exposure=2.0), "--exposure"),
])
def test_a_setting_the_scene_does_not_use_is_refused_naming_it(scene, setting, option):
    with pytest.raises(ParameterError, match=re.escape(f"{option}: scene '{scene.name}' does not "
                                                       "use this setting (it draws 3D sprites")):
        plan_frame(scene, FrameSettings(**setting))


def test_every_built_in_scene_plans_with_no_gl_and_names_its_stages():
    kinds = {}
    for scene in (DeJong(), DeJong(reseed=True), Clifford(), Fountain(),
                  Collision3D(field_resolution=16), Smoke(), Smoke(tau=0.0)):
        plan = plan_frame(scene, FrameSettings(particles=4096, size=(64, 64)))
        kinds[scene.name] = {s.kind for s in plan.stages}
        assert plan.present in plan.resources
        text = str(plan)
        for stage in plan.frame_stages:
            assert f". {stage.name}: " in text
    assert kinds["dejong"] == {"pass", "points", "post"}
    assert kinds["fountain"] == {"pass", "mesh", "sprites"}
    assert kinds["smoke"] == {"pass", "sort key", "sort merge", "shadow map", "mesh", "sprites"}


def test_an_executor_releases_everything_it_made(recording):
    """After the pipeline, only what the context keeps for every user is alive: its compiled
    programs and the full-screen triangle's buffer; after the context, nothing."""
    with smoke_pipeline(recording) as pipeline:
        pipeline.render()
        assert len(recording.device.live) > 30
    kept = {h.number: h.kind for h in recording._owned}
    assert set(recording.device.live) == set(kept)
    assert sorted(set(kept.values())) == ["buffer", "program"]
    assert list(kept.values()).count("buffer") == 1
    device = recording.device
    recording.release()
    assert device.live == set()


def test_a_released_executor_refuses_to_draw(recording):
    with smoke_pipeline(recording) as pipeline:
        executor = pipeline.executor
    with pytest.raises(Exception, match="released"):
        executor.step()


def test_the_camera_a_plan_is_drawn_from_is_the_frame_s(recording):
    """A renderer over a simulation's state, drawn from two cameras: the sprites' matrix is each
    camera's, for the image's aspect."""
    from es2particles.frame.pipeline import Renderer
    from es2particles.render.sprites import Sprites

    scene = Fountain()
    with Simulation(recording, scene.graph(), 16) as sim, \
            Renderer(recording, Sprites(), sim, size=(80, 40), point_size=4.0) as renderer:
        for eye in ((0.0, 2.0, 6.0), (3.0, 1.0, 4.0)):
            camera = Camera(eye=eye, target=(0.0, 1.0, 0.0))
            recording.device.calls.clear()
            renderer.draw(camera)
            sprites = draws(recording)[-1]
            assert sprites["uniforms"]["u_view_projection"] == camera.uniform(2.0)


def test_plans_and_the_executor_load_no_gl_library():
    """In a fresh process: every built-in scene's frame planned and run on a recording device,
    and neither moderngl nor an EGL or GL library is loaded."""
    code = """
import sys
from es2particles.frame.pipeline import Pipeline
from es2particles.gl.context import Capabilities, Context
from es2particles.gl.device import RecordingDevice
from es2particles.scenes import Clifford, Collision3D, DeJong, Fountain, Smoke
with Context(RecordingDevice(Capabilities.assumed())) as ctx:
    for scene in (DeJong(), Clifford(), Fountain(), Collision3D(field_resolution=16), Smoke()):
        with Pipeline(ctx, scene, particles=256, size=(32, 32), steps=2) as p:
            list(p.frames(2))
maps = open("/proc/self/maps").read()
loaded = [lib for lib in ("libEGL", "libGL", "libgallium", "llvmpipe") if lib in maps]
print("moderngl" in sys.modules, loaded)
"""
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "False []", result.stdout


def test_a_stage_reading_a_resource_the_frame_lacks_is_a_graph_error():
    from es2particles.frame.plan import PlanBuilder
    from es2particles.gl.context import Capabilities

    b = PlanBuilder("test", FrameSettings(), Capabilities.assumed())
    b.resource(Resource("out", "target", (4, 4), "rgba8"))
    with pytest.raises(GraphError, match="sampler u_source reads 'missing', which the frame "
                                         "does not have"):
        b.stage(Stage("s", "post", "post/bright.frag", inputs={"u_source": Ref("missing")},
                      target=Ref("out")))


def test_executor_runs_a_plan_it_is_given(recording):
    """An executor of a plan made by hand: one resource, one stage drawn into it."""
    from es2particles.frame.plan import PlanBuilder

    b = PlanBuilder("test", FrameSettings(), recording.caps)
    b.resource(Resource("in", "image", (2, 2), "rgba8", data=np.zeros((2, 2, 4), np.uint8)))
    b.resource(Resource("out", "target", (2, 2), "rgba8"))
    b.stage(Stage("bright", "post", "post/bright.frag", inputs={"u_source": Ref("in")},
                  target=Ref("out"), uniforms={"u_threshold": 0.25}))
    with Executor(recording, b.finish(present="out")) as executor:
        recording.device.calls.clear()
        executor.render()
        (call,) = draws(recording)
        assert sampled(call) == {"u_source": executor.resources["in"]}
        assert target_texture(call) is executor.resources["out"].fronts[0]
        assert call["uniforms"]["u_threshold"] == 0.25


def test_a_renderer_takes_only_the_settings_its_rendering_uses(recording):
    """A renderer draws someone else's simulation: the particles, format, steps and seed are
    the simulation's, so giving one is refused, as is a bad value of a setting it uses and an
    accumulation (its samples would step the simulation), before anything is drawn."""
    from es2particles.errors import Es2ParticlesError
    from es2particles.frame.pipeline import Renderer
    from es2particles.render.points import Density

    scene = DeJong()
    with Simulation(recording, scene.graph(), 64) as sim:
        with pytest.raises(ParameterError, match="particles: a renderer over a simulation"):
            Renderer(recording, scene.rendering(), sim, size=(32, 32), particles=128)
        with pytest.raises(ParameterError, match="gradient 'rainbowish' is unknown"):
            Renderer(recording, Density(scene.view), sim, size=(32, 32), gradient="rainbowish")
        # an accumulated image's samples are steps, which only the simulation's owner takes
        with pytest.raises(ParameterError, match="accumulate 4: a renderer over a simulation "
                                                 "does not step it"):
            Renderer(recording, Density(scene.view), sim, size=(32, 32), accumulate=4)
        renderer = Renderer(recording, Density(scene.view), sim, size=(32, 32), exposure=2.0)
    with pytest.raises(Es2ParticlesError, match="the Simulation this Renderer draws was "
                                                "released"):
        renderer.draw()
    renderer.release()
    with pytest.raises(Es2ParticlesError, match="this Renderer was released"):
        renderer.draw()


def test_a_3d_scene_without_a_camera_says_so(recording):
    from es2particles.render.sprites import Sprites
    from es2particles.scenes import Fill, Scene

    class Cloud(Scene):
        name, renders = "cloud", Sprites

        def graph(self, caps=None):
            g = PassGraph()
            g.quantity("position", -1, 1, components=3)
            g.add("still", "examples/drift.frag", writes="position", reads=["position"],
                  uniforms={"u_delta": (0.0, 0.0, 0.0)})
            return g

        def rendering(self):
            return Sprites(roles={"position": "position"})

        def start(self, count, rng):
            return {"position": Fill(-1, 1)}

    with Pipeline(recording, Cloud(), particles=16, size=(16, 16)) as pipeline:
        with pytest.raises(GraphError, match="scene 'cloud' draws in 3D but gives no camera"):
            next(pipeline.frames())


def test_the_frame_loop_checks_its_frames(recording):
    with Pipeline(recording, DeJong(), particles=16, size=(16, 16)) as pipeline:
        with pytest.raises(ParameterError, match="frames must be in \\[1, inf\\], got 0"):
            next(pipeline.frames(0))
        with pytest.raises(ParameterError, match="wanted frames must lie in \\[0, 2\\], got 1..5"):
            next(pipeline.frames(3, wanted=[1, 5]))


def test_a_light_size_needs_a_camera():
    from es2particles.frame.plan import frame_value
    from es2particles.gl.context import Capabilities

    with pytest.raises(ParameterError, match="'light_size' needs a camera"):
        frame_value(("light_size", 1.0, 1.0, 0.0, 256), None, caps=Capabilities.assumed())


def test_points_without_vertex_fetch_read_this_frame_s_state_back_before_drawing(recording):
    """The attribute path: before the points draw, the front texture of each read quantity part
    is read and written into that attribute's buffer, the one the draw's vertex array holds."""
    with Pipeline(recording, Collision(), particles=64, size=(16, 16), steps=1,
                  vertex_fetch="off") as pipeline:
        next(pipeline.frames())
        executor = pipeline.executor
        calls = recording.device.calls
        draw = next(i for i, c in enumerate(calls) if c.op == "draw"
                    and c["stage"] == "points")
        fronts = {executor.front(q): q for q in ("position", "life")}
        reads = [c["texture"] for c in calls[:draw] if c.op == "read"][-2:]
        writes = [c["handle"] for c in calls[:draw] if c.op == "write"][-2:]
        assert {fronts.get(t) for t in reads} == {"position", "life"}
        buffers = {executor.buffers[("points", a)] for a in ("a_position", "a_life")}
        assert set(writes) == buffers
        content = calls[draw]["vertex_array"].details["content"]
        assert {(row[1], row[2]) for row in content} == {("4f1", "a_position"),
                                                         ("4f1", "a_life")}
