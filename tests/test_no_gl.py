"""The fast tier where no GL library loads (issue 46): ``tests/data/nogl.c`` is a dlopen that
refuses every GL library (libGL, libEGL, libOpenGL, libGLES, libgbm), as on a machine that has
none; compiled here and preloaded, the fast tier (``-m "not gl and not browser and not slow"``)
must pass. Blocking only ctypes' loads, as an earlier check did, missed glcontext's own dlopen:
a test that opened a context itself passed it."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import missing

pytestmark = pytest.mark.slow
HERE = Path(__file__).resolve().parent


def test_the_fast_tier_passes_where_no_gl_library_loads(tmp_path):
    compiler = shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        missing("a C compiler to build tests/data/nogl.c")
    shim = tmp_path / "nogl.so"
    subprocess.run([compiler, "-shared", "-fPIC", "-O2", "-o", str(shim),
                    str(HERE / "data" / "nogl.c"), "-ldl"], check=True)
    env = {**os.environ, "LD_PRELOAD": str(shim)}
    probe = subprocess.run([sys.executable, "-c", "import ctypes; ctypes.CDLL('libEGL.so.1')"],
                           env=env, capture_output=True, text=True)
    assert probe.returncode != 0, "the shim let libEGL load"
    tier = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:randomly", "-m",
                           "not gl and not browser and not slow", str(HERE)], env=env,
                          capture_output=True, text=True, timeout=600, cwd=HERE.parent)
    assert tier.returncode == 0, tier.stdout[-3000:] + tier.stderr[-2000:]
