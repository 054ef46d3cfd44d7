"""docs/command-line.md is the output of docs/cli_reference.py, which writes it from the parameter
declarations and the real parser, and it lists every option `es2particles run SCENE --help`
offers. Fast tier: no GL library is loaded."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

from es2particles.scenes import BUILT_IN

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "docs" / "cli_reference.py"
PAGE = ROOT / "docs" / "command-line.md"
GL_LIBRARIES = ("libEGL", "libGL", "libgallium", "llvmpipe", "swrast")

# The script run as `python docs/cli_reference.py` would run, then the GL libraries the process
# has loaded written to stderr's last line.
RUN_SCRIPT = """
import runpy, sys
runpy.run_path(sys.argv[1], run_name="__main__")
sys.stdout.flush()
maps = open("/proc/self/maps").read() if sys.platform.startswith("linux") else ""
sys.stderr.write("\\nloaded: " + ",".join(l for l in sys.argv[2].split(",") if l in maps))
"""


def test_the_page_is_the_script_s_output_and_no_gl_is_loaded():
    result = subprocess.run([sys.executable, "-c", RUN_SCRIPT, str(SCRIPT),
                             ",".join(GL_LIBRARIES)], cwd=ROOT, capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stderr.strip().splitlines()[-1] == "loaded:", result.stderr
    assert result.stdout == PAGE.read_text(encoding="utf-8"), (
        "docs/command-line.md is not the script's output: regenerate it with "
        "`python docs/cli_reference.py > docs/command-line.md`")


def test_the_page_says_under_its_title_how_to_regenerate_it():
    title, _, note = PAGE.read_text(encoding="utf-8").splitlines()[:3]
    assert title == "# The command line"
    assert "docs/cli_reference.py" in note and "> docs/command-line.md" in note


def section(text, scene):
    """The text of ``### scene`` up to the next heading of its level or above."""
    match = re.search(rf"^### {re.escape(scene)}\n(.*?)(?=^#{{1,3}} |\Z)", text, re.M | re.S)
    assert match, f"command-line.md has no section ### {scene}"
    return match.group(1)


@pytest.mark.slow
@pytest.mark.parametrize("scene", list(BUILT_IN))
def test_every_option_of_run_help_is_in_the_scene_s_section(scene):
    result = subprocess.run([sys.executable, "-m", "es2particles", "run", scene, "--help"],
                            cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    # The option column of argparse's help: options start a line, indented by two spaces.
    options = set(re.findall(r"^  (--[a-z0-9][a-z0-9-]*)", result.stdout, re.M))
    assert "--out" in options and len(options) > 10, result.stdout
    text = section(PAGE.read_text(encoding="utf-8"), scene)
    missing = sorted(o for o in options if f"`{o}`" not in text)
    assert not missing, f"### {scene} of command-line.md lacks {missing}"
