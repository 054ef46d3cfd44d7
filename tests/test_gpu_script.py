"""benchmarks/gpu.sh, the prepared run for a machine with an NVIDIA GPU (issue 47): its dry run
here (llvmpipe, small sizes) goes end to end within its 10 minutes and writes RESULTS.md and
results.json, marked as a dry run, into the folder it is given (never into the checkout)."""

import json
import subprocess
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.gl
@pytest.mark.slow
def test_the_dry_run_writes_its_figures_within_its_limit(tmp_path):
    start = time.monotonic()
    hypothesis_before = (ROOT / ".hypothesis").exists()
    done = subprocess.run(["bash", str(ROOT / "benchmarks" / "gpu.sh"), "--dry-run", "--out",
                           str(tmp_path)], capture_output=True, text=True, timeout=600)
    took = time.monotonic() - start
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    results = (tmp_path / "RESULTS.md").read_text()
    assert results.startswith("# GPU results (DRY RUN")
    data = json.loads((tmp_path / "results.json").read_text())
    assert data["dry_run"] is True
    names = {f["name"] for f in data["figures"]}
    for name in ("dejong 2^14", "dejong 2^16", "wind 64^2 2^14", "wind 128^2 2^14",
                 "fountain sprites", "dejong step bytes", "smoke with its sort"):
        assert name in names, sorted(names)
    measured = [f for f in data["figures"] if f["value"] is not None]
    assert all(f["value"] > 0 for f in measured)
    assert all(f["goal"] is None for f in data["figures"])  # no goal is judged on llvmpipe
    assert "passed" in (tmp_path / "gpu-run.log").read_text()  # the core tests ran
    # their Hypothesis tests kept their home out of the checkout (tests/checkout_clean.py)
    assert hypothesis_before or not (ROOT / ".hypothesis").exists()
    print(f"dry run: {took:.0f} s, {len(measured)} figures")
    assert took < 600
