"""The README is the front door: at most 150 lines, and its two set-up commands are the lines CI
runs (.ci/run). Its other blocks run in tests/test_docs.py with the docs'."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_the_readme_is_a_front_door():
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= 150, f"README.md has {len(lines)} lines"


def test_ci_runs_the_readme_commands_as_written():
    readme = (ROOT / "README.md").read_text()
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    commands = re.findall(r"```sh\n(.+?)\n```", readme)[:2]
    assert commands[0].startswith("sh setup.sh && ") and commands[1].startswith("sh setup.sh test")
    assert any(line.startswith(commands[0]) for line in ci), f"{commands[0]!r} is not in .ci/run"
    assert commands[1] in ci, f"{commands[1]!r} is not a line of .ci/run"
