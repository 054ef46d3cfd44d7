"""The README: its test command is the one CI runs, and every Python block in it runs."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent


def test_ci_runs_the_readme_test_command():
    readme = (ROOT / "README.md").read_text()
    ci = (ROOT / ".ci" / "run").read_text()
    commands = re.findall(r"```sh\n(.+?)\n```", readme)
    assert len(commands) == 2, "the README gives exactly two set-up commands"
    assert commands[1] in ci.splitlines(), f"{commands[1]!r} is not a line of .ci/run"


def python_blocks():
    readme = (ROOT / "README.md").read_text()
    return re.findall(r"```python\n(.+?)\n```", readme, re.S)


def test_readme_has_python_examples():
    assert len(python_blocks()) >= 2


@pytest.mark.gl
@pytest.mark.parametrize("index", range(len(python_blocks())))
def test_every_python_block_of_the_readme_runs(index, tmp_path):
    """Each block runs as a user would: a fresh folder, the installed package, a new process."""
    code = python_blocks()[index]
    result = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, f"README block {index} failed:\n{code}\n{result.stderr}"
    if "mean x after 50 steps" in code:
        # The example's particles must move: 50 steps of 0.01 (it once moved nothing, silently).
        mean = float(re.search(r"mean x after 50 steps: (\S+)", result.stdout).group(1))
        assert abs(mean - 0.5) < 0.005, result.stdout
    if "drift.png" in code:
        from PIL import Image

        with Image.open(tmp_path / "drift.png") as image:
            pixels = np.asarray(image)
        assert pixels.shape == (256, 256, 3) and 0.01 < (pixels.max(axis=2) > 16).mean() < 0.9
