"""Library seams found by adversarial testing (issue 16's first cases): several contexts, released
objects, and arguments Python would quietly coerce."""

import subprocess
import sys

import numpy as np
import pytest

from es2particles import (ContextError, Es2ParticlesError, ParameterError, PassGraph, Simulation,
                          open_context)


def drift(delta):
    g = PassGraph()
    g.quantity("position", -1, 1)
    g.add("drift", "examples/drift.frag", writes="position", reads=["position"],
          uniforms={"u_delta": (delta, 0.0)})
    return g


def test_each_simulation_runs_on_its_own_context(gl):
    """GL calls go to the context made current last: with two open, a simulation ran on the
    other's (it moved 0.3 where 0.1 was meant)."""
    other = open_context()
    try:
        a = Simulation(gl, drift(0.01), 16)
        b = Simulation(other, drift(0.03), 16)
        for sim in (a, b):
            sim.upload("position", np.zeros((16, 2)))
        a.run(10)
        b.run(10)
        assert abs(a.download("position")[:, 0].mean() - 0.1) < 1e-3
        assert abs(b.download("position")[:, 0].mean() - 0.3) < 1e-3
        b.release()
        a.release()
    finally:
        other.release()  # gl is current here: other must free its objects in itself
    # Releasing a context deleted its GL names in whichever context was current, here gl's:
    # a simulation made after it on gl then computed zeros.
    with Simulation(gl, drift(0.01), 16) as after:
        after.upload("position", np.zeros((16, 2)))
        after.run(10)
        assert abs(after.download("position")[:, 0].mean() - 0.1) < 1e-3


def test_released_objects_refuse_with_one_clear_error(gl):
    sim = Simulation(gl, drift(0.01), 16)
    sim.release()
    sim.release()  # twice is safe
    with pytest.raises(Es2ParticlesError, match="this Simulation was released"):
        sim.run(1)
    other = open_context()
    orphan = Simulation(other, drift(0.01), 16)
    other.release()
    with pytest.raises(ContextError, match="this context was released"):
        orphan.step()
    orphan.release()  # its objects went with the context: nothing to do, no error


@pytest.mark.parametrize("steps", [2.7, float("nan"), float("inf"), -1, True, "3"])
def test_run_takes_a_whole_number_of_steps(gl, steps):
    with Simulation(gl, drift(0.0), 4) as sim:
        with pytest.raises(ParameterError, match="steps must be"):
            sim.run(steps)
        assert sim.steps_done == 0


@pytest.mark.parametrize("count", [True, float("inf"), float("nan"), 2.5, "64"])
def test_particle_counts_are_whole_numbers(gl, count):
    with pytest.raises(ParameterError, match="particles must be"):
        Simulation(gl, drift(0.0), count)


def test_one_output_may_be_named_by_a_string(gl):
    with Simulation(gl, drift(0.0), 4, outputs="position") as sim:
        assert sim.plan.outputs == ("position",)


@pytest.mark.gl
def test_python_dash_m_runs_the_command_line():
    result = subprocess.run([sys.executable, "-m", "es2particles", "plan", "dejong",
                             "--particles", "16", "--size", "8x8"], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert "scene: dejong" in result.stdout
