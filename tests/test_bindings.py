"""Loud seams: the generated interface of a pass, and one error policy for every mismatch between
what a stage is given and what its shader uses. Each error names the stage, the file and the name.
"""

import numpy as np
import pytest

from bounds import U, rounding_error
from conftest import shader
from es2particles import GraphError, ParameterError, PassGraph, ShaderError, Simulation
from es2particles.gl.bindings import pass_interface
from es2particles.gl.command import DrawCommand
from es2particles.gl.device import DrawState
from es2particles.frame.pipeline import Pipeline
from es2particles.scenes import DeJong


def drift_graph(**uniforms):
    g = PassGraph()
    g.quantity("position", -1, 1)
    g.add("drift", "examples/drift.frag", writes="position", reads=["position"],
          uniforms=uniforms)
    return g


def user_pass(tmp_path, body, **declaration):
    frag = tmp_path / "user.frag"
    frag.write_text("#version 100\n" + body + "\n")
    g = PassGraph()
    g.quantity("position", -1, 1)
    g.quantity("velocity", -1, 1)
    g.add("velocity", shader("keep_velocity.frag"), writes="velocity", reads=["velocity"])
    g.add("user", str(frag), writes="position", **declaration)
    return g


def test_the_interface_is_written_from_the_declaration():
    """No GL: what a pass's shader is given, by name and type."""
    g = PassGraph()
    g.quantity("position", -1, 1, components=3)
    g.quantity("mass", 0, 2, components=1)
    g.texture("field", np.zeros((4, 4, 4), np.uint8))
    g.add("move", "user.frag", writes="position", reads=["position"], reads_new=["mass"],
          textures=["field"], uniforms={"u_dt": 0.1, "u_gravity": (0, -9.8, 0),
                                        "u_taps": np.zeros((6, 2))})
    rgba8 = pass_interface(g.passes[0], g.quantities, "rgba8", part=1)
    text = rgba8.text
    for line in ("uniform sampler2D u_position;", "uniform sampler2D u_position_1;",
                 "vec3 read_position(vec2 uv)", "float read_mass(vec2 uv)",
                 "uniform sampler2D u_field;", "uniform float u_dt;", "uniform vec3 u_gravity;",
                 "uniform vec2 u_taps[6];", "void write_position(vec3 value)",
                 "varying vec2 v_uv;"):
        assert line in text, line
    assert "state_encode(v.zw, u_position_lo.zw" in text  # part 2 writes z (and padding)
    assert rgba8.samplers["u_mass"] == ("quantity", "mass", 0, True)
    floats = pass_interface(g.passes[0], g.quantities, "rgba32f", part=0)
    assert "u_position_1" not in floats.text  # one float texture holds all three
    assert "state_clamp(v, u_position_lo, u_position_span)" in floats.text


def test_the_readme_mistake_names_the_shader_line_and_what_was_given(gl):
    # The README once set u_velocity while drift.frag uses u_delta: that did nothing, silently.
    with pytest.raises(ShaderError) as info:
        Simulation(gl, drift_graph(u_velocity=(0.01, 0.0)), 16)
    message = str(info.value)
    print(message)
    # The driver's own words: Mesa's "undeclared identifier", NVIDIA's "undefined variable".
    assert "drift.frag:" in message and "u_delta" in message
    assert "undeclared" in message or "undefined" in message, message
    assert "u_velocity" in message  # what the graph declared for it


def test_a_uniform_the_shader_never_uses_is_an_error(gl):
    with pytest.raises(ParameterError, match=r"pass 'drift' \(examples/drift.frag\): uniform "
                                             r"'u_speed' is given, but the shader never uses it"):
        Simulation(gl, drift_graph(u_delta=(0.0, 0.0), u_speed=1.0), 16)


def test_a_misspelled_set_uniform_is_an_error(gl):
    with Simulation(gl, drift_graph(u_delta=(0.0, 0.0)), 16) as sim:
        with pytest.raises(ParameterError, match="no pass of this graph declares a uniform "
                                                 "'u_detla' .declared: u_delta"):
            sim.set_uniform("u_detla", (0.1, 0.0))
        with pytest.raises(ParameterError, match="uniform u_delta is a vec2"):
            sim.set_uniform("u_delta", 0.5)


def test_an_unfed_sampler_is_an_error(gl, tmp_path):
    g = user_pass(tmp_path, "uniform sampler2D u_noise;\n"
                  "void main() { write_position(texture2D(u_noise, v_uv).xy); }")
    with pytest.raises(ParameterError, match=r"pass 'user' .*user.frag\): sampler 'u_noise' is "
                                             "used by the shader but nothing feeds it"):
        Simulation(gl, g, 16, outputs=["position"])


def test_a_pass_that_writes_nothing_is_an_error(gl, tmp_path):
    g = user_pass(tmp_path, "void main() { gl_FragColor = vec4(0.5); }")
    with pytest.raises(ShaderError, match=r"pass 'user' .*user.frag\) never calls "
                                          r"write_position\(value\)"):
        Simulation(gl, g, 16, outputs=["position"])


def test_a_read_the_shader_never_makes_is_an_error(gl, tmp_path):
    g = user_pass(tmp_path, "void main() { write_position(vec2(0.0)); }", reads=["velocity"])
    with pytest.raises(ParameterError, match="declares it reads quantity 'velocity' but its "
                                             "shader never uses read_velocity"):
        Simulation(gl, g, 16, outputs=["position"])


def test_declaring_what_the_graph_declares_is_an_error_naming_the_line(gl, tmp_path):
    g = user_pass(tmp_path, "uniform sampler2D u_velocity;\n"
                  "void main() { write_position(read_velocity(v_uv)); }", reads=["velocity"])
    with pytest.raises(ShaderError, match=r"user.frag:2: .*declares 'u_velocity', which the "
                                          "graph declares"):
        Simulation(gl, g, 16, outputs=["position"])


def test_an_undeclared_texture_is_a_graph_error():
    g = PassGraph()
    g.quantity("position", -1, 1)
    g.add("p", "examples/drift.frag", writes="position", textures=["feild"])
    with pytest.raises(GraphError, match="samples texture 'feild', which is not declared"):
        g.plan()


def test_post_stage_uniforms_follow_the_same_policy(gl):
    group = gl.group()
    try:
        bright = DrawCommand(group, "post stage bloom bright", "post/bright.frag")
        bright.set("u_threshold", 0.5)
        with pytest.raises(ParameterError, match=r"post stage bloom bright \(post/bright.frag\): "
                                                 "uniform 'u_treshold' is given, but the shader "
                                                 "does not declare it"):
            bright.set("u_treshold", 0.5)
        target = group.texture((4, 4))
        with pytest.raises(ParameterError, match="sampler 'u_source' is used by the shader but "
                                                 "nothing feeds it"):
            bright.draw(group.framebuffer(target), {})
    finally:
        group.release()


def test_gl_state_is_restored_when_an_exception_passes_through(gl):
    group = gl.group()
    try:
        target = group.texture((4, 4), "rgba32f")
        fbo = group.framebuffer(target)
        constant = DrawCommand(group, "test", "lib/constant.frag")
        constant.set("u_colour", (0.25, 0.25, 0.25, 0.25))
        with pytest.raises(RuntimeError):
            with gl.device.scope(fbo, DrawState(blend="add", depth_test=True, point_size=True)):
                raise RuntimeError("between enable and disable")
        if gl.mgl is None:  # the ES device draws only through scope: ask GL itself
            assert not gl.device.gl.glIsEnabled(0x0BE2), "blending was left on"
            assert not gl.device.gl.glIsEnabled(0x0B71), "the depth test was left on"
            return
        gl.clear(fbo, (0, 0, 0, 0))
        fbo.use()
        for _ in range(2):  # without blending, the second draw replaces the first
            constant.vertex_array.render()
        value = np.frombuffer(gl.read(target), np.float32)[0]
        assert value == 0.25, "blending was left on"
    finally:
        group.release()


class NoLife(DeJong):
    name = "nolife"
    render_reads = ("position", "life")


def test_a_render_input_no_pass_writes_is_a_plan_time_error(gl):
    before = gl.live_objects()
    with pytest.raises(GraphError, match="the renderer reads 'life', which scene 'nolife' does "
                                         "not declare"):
        Pipeline(gl, NoLife(), particles=64, size=(16, 16))
    assert gl.live_objects() == before


def test_a_pipeline_releases_everything_it_made(gl):
    # What the context caches for every pipeline (programs, the full-screen triangle's buffer)
    # is made by a first one: run alone (or first of a worker, as on the GPU machine's 12), the
    # test counted that cache as a leak.
    with Pipeline(gl, DeJong(), particles=256, size=(32, 32)) as pipeline:
        pipeline.warm_up()
    before = gl.live_objects()
    with Pipeline(gl, DeJong(), particles=256, size=(32, 32)) as pipeline:
        pipeline.warm_up()
        image = pipeline.image()
    assert image.shape == (32, 32, 3) and image.any()
    after = gl.live_objects()
    after.pop("Program", None), before.pop("Program", None)  # programs are cached
    assert after == before


def test_pipeline_takes_the_scene_defaults_resolved_once(gl):
    from es2particles.fields.field2d import CollisionField
    from es2particles.scenes import Collision
    from es2particles.scenes.collision import RECT

    scene = Collision(field=CollisionField(RECT, [], resolution=(8, 8)))
    def point_size(pipeline):
        return pipeline.plan.stage("points").uniforms["u_point_size"]

    with Pipeline(gl, scene, size=(16, 16)) as pipeline:
        assert point_size(pipeline) == 2.0  # once 1: the CLI alone knew the default
        assert pipeline.sim.count == 2 ** 17 and pipeline.sim.rounding == "dither"
        assert pipeline.steps == scene.defaults.steps == 300
        assert pipeline.plan.rendering.reads == ("position", "life")
    with Pipeline(gl, scene, particles=64, size=(16, 16), point_size=3.0, steps=0,
                  rounding="nearest") as pipeline:
        assert (point_size(pipeline), pipeline.sim.count, pipeline.steps,
                pipeline.sim.rounding) == (3.0, 64, 0, "nearest")


def command(sim, index=0):
    """The draw command of a simulation's ``index``-th draw of a step."""
    return sim.executor.commands[sim.stages[index].name]


def test_simulations_sharing_a_program_keep_their_own_uniforms(gl):
    """The context compiles a program once for every user with the same sources; uniform values
    live in the program, so each user's must be set again when another set them last."""
    a = Simulation(gl, drift_graph(u_delta=(0.01, 0.0)), 16)
    b = Simulation(gl, drift_graph(u_delta=(0.03, 0.0)), 4096)  # same program, other values
    try:
        assert command(a).program is command(b).program
        for sim in (a, b):
            sim.upload("position", np.zeros((sim.count, 2)))
        for _ in range(10):
            a.step()
            b.step()
        moved_a, moved_b = a.download("position")[:, 0].mean(), b.download("position")[:, 0].mean()
    finally:
        a.release()
        b.release()
    assert abs(moved_a - 0.1) < 1e-3 and abs(moved_b - 0.3) < 1e-3, (moved_a, moved_b)


def test_meshes_sharing_a_program_keep_their_colours(gl):
    from es2particles.frame.pipeline import Renderer
    from es2particles.render.camera import Camera
    from es2particles.render.meshes import box
    from es2particles.render.sprites import Sprites
    from es2particles.scenes import Fountain

    scene = Fountain()
    meshes = [box((-1.0, 1.0, 0.0), (0.4, 0.4, 0.4), colour=(1.0, 0.0, 0.0)),
              box((1.0, 1.0, 0.0), (0.4, 0.4, 0.4), colour=(0.0, 0.0, 1.0))]
    camera = Camera(eye=(0.0, 1.0, 6.0), target=(0.0, 1.0, 0.0))
    with Simulation(gl, scene.graph(), 1) as sim:
        sim.upload("life", np.array([[0.0, 0.0]]))  # dead: not drawn
        sprites = Sprites(meshes=meshes, light=(0, 1, 6), background=(0, 0, 0))
        with Renderer(gl, sprites, sim, size=(128, 128), point_size=24.0) as renderer:
            renderer.draw(camera)
            image = renderer.read().astype(int)
    (lx, ly), (rx, ry) = np.round(camera.project(np.array([[-1.0, 1, 0.4], [1.0, 1, 0.4]]),
                                                 (128, 128))[0]).astype(int)
    assert image[ly, lx, 0] > 100 and image[ly, lx, 2] < 20, image[ly, lx]
    assert image[ry, rx, 2] > 100 and image[ry, rx, 0] < 20, image[ry, rx]


def test_the_checks_never_reject_a_valid_shader(gl, tmp_path):
    """Declarations in comments or inactive branches, several per statement or across lines,
    and a write through a macro are all valid GLSL and must pass."""
    g = user_pass(tmp_path, """/* an old version:
uniform vec2 u_delta;
*/
#if 0
uniform sampler2D u_position;
#endif
uniform float u_gain; uniform float u_bias;
uniform vec2 u_a,
             u_b;
#define OUT write_position
void main() { OUT(read_position(v_uv) * u_gain + u_bias + u_a + u_b); }""", reads=["position"])
    # user_pass's graph declares no uniforms: this shader declares its own four, each given a
    # value of its own so that the step's result shows every one was set and used.
    values = {"u_gain": 0.5, "u_bias": 0.125, "u_a": (0.25, -0.5), "u_b": (-0.0625, 0.1875)}
    with Simulation(gl, g, 16, outputs=["position"]) as sim:
        pass_command = command(sim)
        for name, value in values.items():
            pass_command.set(name, value)
        sim.upload("position", np.random.default_rng(3).uniform(-0.5, 0.5, (16, 2)))
        start = sim.download("position")
        sim.step()
        got = sim.download("position")
    want = (start * values["u_gain"] + values["u_bias"] + np.add(values["u_a"], values["u_b"]))
    # One write of a value of [-1, 1] in RGBA8, and float32's few roundings of the sum.
    bound = rounding_error("rgba8", -1, 1) + 4 * U
    error = np.abs(got - want).max()
    assert error <= bound, f"the user pass wrote {error:.3g} off its inputs (allowed {bound:.3g})"


def test_clashing_generated_names_are_an_error_naming_both():
    g = PassGraph()
    g.quantity("pos", -1, 1, components=3)
    g.quantity("pos_1", -1, 1)
    g.add("p", "x.frag", writes="pos", reads=["pos", "pos_1"])
    with pytest.raises(GraphError, match="u_pos_1 would be declared twice, for part 2 of quantity "
                                         "'pos' and for part 1 of quantity 'pos_1'"):
        pass_interface(g.passes[0], g.quantities, "rgba8")
    g = PassGraph()
    g.quantity("position", -1, 1)
    g.add("p", "x.frag", writes="position", uniforms={"u_step": 1.0})
    with pytest.raises(GraphError, match="u_step would be declared twice"):
        pass_interface(g.passes[0], g.quantities, "rgba8")
