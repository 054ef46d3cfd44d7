"""The pass graph's planning, with no GL: ordering, time of reads, pruning, and its errors."""

import pytest

from es2particles import GraphError, ParameterError, PassGraph


def fountain_like():
    g = PassGraph()
    for name in ("acceleration", "velocity", "position", "colour", "debug"):
        g.quantity(name, -1, 1)
    # Declared out of order on purpose: the plan must order by this-step reads.
    g.add("integrate_position", "p.frag", writes="position", reads=["position"],
          reads_new=["velocity"])
    g.add("integrate_velocity", "v.frag", writes="velocity", reads=["velocity"],
          reads_new=["acceleration"])
    g.add("forces", "a.frag", writes="acceleration", reads=["position"])
    g.add("tint", "c.frag", writes="colour", reads_new=["velocity"])
    g.add("debug_view", "d.frag", writes="debug", reads=["acceleration"])
    return g


def names(passes):
    return [p.name for p in passes]


def test_order_follows_this_step_reads():
    plan = fountain_like().plan(["position"])
    assert names(plan.passes) == ["forces", "integrate_velocity", "integrate_position"]


def test_pruning_leaves_out_passes_and_textures_the_outputs_do_not_need():
    plan = fountain_like().plan(["position"])
    assert names(plan.left_out_passes) == ["tint", "debug_view"]
    assert plan.left_out_quantities == ["colour", "debug"]
    assert set(plan.buffers) == {"acceleration", "velocity", "position"}
    text = str(plan)
    assert "left out: pass tint, pass debug_view, quantity colour, quantity debug" in text


def test_last_step_reads_get_two_textures_this_step_reads_one():
    plan = fountain_like().plan(["position"])
    # position and velocity are read as last step's values: ping-pong. acceleration is only read
    # this step, within the step that writes it: one texture is enough.
    assert plan.buffers == {"acceleration": 1, "velocity": 2, "position": 2}
    assert plan.texture_count == 5


def test_a_last_step_read_pulls_in_its_writer_transitively():
    # debug reads last step's acceleration, whose pass reads last step's position, whose pass
    # reads this step's velocity: all of them must be simulated; only colour is not needed.
    plan = fountain_like().plan(["debug"])
    assert names(plan.passes) == ["forces", "integrate_velocity", "integrate_position",
                                  "debug_view"]
    assert names(plan.left_out_passes) == ["tint"]
    assert plan.buffers == {"acceleration": 2, "velocity": 2, "position": 2, "debug": 1}


def test_last_step_reads_do_not_order_passes():
    g = PassGraph()
    g.quantity("a", 0, 1)
    g.quantity("b", 0, 1)
    g.add("write_a", "a.frag", writes="a", reads=["b"])
    g.add("write_b", "b.frag", writes="b", reads=["a"])  # a loop through last step: fine
    assert names(g.plan().passes) == ["write_a", "write_b"]


def test_cycle_through_this_step_reads_is_an_error():
    g = PassGraph()
    g.quantity("a", 0, 1)
    g.quantity("b", 0, 1)
    g.add("write_a", "a.frag", writes="a", reads_new=["b"])
    g.add("write_b", "b.frag", writes="b", reads_new=["a"])
    with pytest.raises(GraphError, match="cycle.*write_a -> write_b -> write_a"):
        g.plan()


def test_read_that_nobody_writes_is_an_error():
    g = PassGraph()
    g.quantity("a", 0, 1)
    g.quantity("b", 0, 1)
    g.add("write_a", "a.frag", writes="a", reads=["b"])
    with pytest.raises(GraphError, match="reads 'b', but no pass writes it"):
        g.plan()


def test_undeclared_quantities_and_outputs_are_errors():
    g = PassGraph()
    g.quantity("a", 0, 1)
    g.add("write_a", "a.frag", writes="a", reads=["ghost"])
    with pytest.raises(GraphError, match="reads 'ghost', which is not a declared quantity"):
        g.plan()
    g2 = PassGraph()
    g2.quantity("a", 0, 1)
    g2.add("write_a", "a.frag", writes="a")
    with pytest.raises(GraphError, match="output 'nope' is not a declared quantity"):
        g2.plan(["nope"])
    with pytest.raises(ParameterError, match="outputs"):
        g2.plan([])


def test_duplicate_names_are_errors():
    g = PassGraph()
    g.quantity("a", 0, 1)
    g.add("one", "a.frag", writes="a")
    with pytest.raises(GraphError, match="two passes are named 'one'"):
        g.add("one", "b.frag", writes="a")
    with pytest.raises(GraphError, match="declared twice"):
        g.quantity("a", 0, 1)


def test_a_pass_cannot_read_its_own_output_this_step():
    g = PassGraph()
    g.quantity("a", 0, 1)
    g.add("self", "a.frag", writes="a", reads_new=["a"])
    with pytest.raises(GraphError, match="which it writes itself"):
        g.plan()


def test_bad_quantity_ranges_are_errors():
    g = PassGraph()
    with pytest.raises(ParameterError, match="hi must be greater than lo"):
        g.quantity("a", 1, 1)
    with pytest.raises(ParameterError, match="must be finite"):
        g.quantity("b", 0, float("inf"))
    with pytest.raises(ParameterError, match="GLSL identifier"):
        g.quantity("not a name", 0, 1)


def test_a_range_whose_zero_lies_between_codes_is_said_with_one_that_holds_it():
    """Issue 44, item 7: a clock declared over [-6, 60] and written as 0.0 read back as
    -0.00028 (0 is 5911.27 codes up), and 0.8% of a user's particles never came alive. The
    declaration warns, naming a range that holds 0: checked here in float32 as a shader decodes
    (lo + code / 65024 * span), not through the package's codec."""
    import re
    import warnings

    import numpy as np

    from es2particles.errors import RangeWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        PassGraph().quantity("clock", -6, 60, components=1)
        PassGraph().quantity("symmetric", -6, 6, components=1)
        PassGraph().quantity("from_zero", 0, 60, components=1)
    assert [w.category for w in caught] == [RangeWarning], [str(w.message) for w in caught]
    text = str(caught[0].message)
    assert "reads back as -0.000277" in text, text
    wider = float(re.search(r"or \[-6, ([0-9.]+)\]", text).group(1))
    lo, span = np.float32(-6), np.float32(wider) - np.float32(-6)
    code = round(6 / (wider + 6) * 65024)
    assert lo + np.float32(code / 65024) * span == 0.0
    assert abs(6 / (wider + 6) * 65024 - code) < 1e-6  # on a code, not near one


def test_no_built_in_scene_declares_a_range_that_misses_zero():
    import warnings

    from es2particles.errors import RangeWarning
    from es2particles.scenes import BUILT_IN, scene_class

    with warnings.catch_warnings():
        warnings.simplefilter("error", RangeWarning)
        for name in BUILT_IN:
            scene_class(name)().graph()
