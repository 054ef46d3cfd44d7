"""The demo scripts run as a user runs them (`python demos/NAME.py`), smaller: each module's
size constants are lowered, its main() runs in a temporary folder, and its files are there."""

import importlib.util
from pathlib import Path

import pytest

pytestmark = [pytest.mark.gl, pytest.mark.slow]
DEMOS = Path(__file__).resolve().parent.parent / "demos"
SMALL = {"PARTICLES": 4096, "SIZE": (128, 96), "FRAMES": 4}


@pytest.mark.parametrize("name, files", [
    ("dejong", ("dejong.png", "dejong.webp")),
    ("collision", ("collision.png", "collision.webp")),
    ("fountain", ("fountain.png", "fountain.webp")),
])
def test_a_demo_writes_its_files(name, files, tmp_path, monkeypatch):
    spec = importlib.util.spec_from_file_location(f"demo_{name}", DEMOS / f"{name}.py")
    demo = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(demo)
    for constant, value in SMALL.items():
        if hasattr(demo, constant):
            monkeypatch.setattr(demo, constant, value)
    monkeypatch.chdir(tmp_path)
    demo.main()
    for file in files:
        assert (tmp_path / "out" / file).stat().st_size > 0, file
