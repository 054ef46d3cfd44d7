"""The API reference builds with pdoc (the ``docs`` extra; in the ``test`` extra too), offline and
with no GL context: every module imports without opening one, and the main pages carry their
docstrings.

Build it by hand into the ignored ``docs/api/`` as the README says: ``pdoc es2particles -o
docs/api`` (each package's ``__all__`` names its submodules, which pdoc walks; the names the
packages load lazily are reached as attributes and documented in their own modules).
"""

import importlib
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import missing, needs

ROOT = Path(__file__).resolve().parent.parent
GL_LIBRARIES = ("libEGL", "libGL", "libgallium", "llvmpipe", "swrast")


def modules(root="es2particles"):
    """Every module of the package, by walking its folders (``__main__`` left out: importing it
    runs the program)."""
    package = importlib.import_module(root)
    found = [root]
    for info in pkgutil.walk_packages(package.__path__, root + "."):
        if info.name.rpartition(".")[2] != "__main__":
            found.append(info.name)
    return found


def pdoc_command(out):
    """The README's command."""
    return [sys.executable, "-m", "pdoc", "es2particles", "-o", str(out)]


def test_every_module_imports_without_opening_a_gl_context():
    """In a fresh process: every module imported, and no GL or EGL library loaded (a context, or
    a probe of the driver, at import would load them; pdoc imports every module)."""
    code = ("import importlib, sys\n"
            "for name in sys.argv[1].split(','):\n"
            "    importlib.import_module(name)\n"
            "maps = open('/proc/self/maps').read()\n"
            "print(','.join(l for l in sys.argv[2].split(',') if l in maps))\n")
    if not Path("/proc/self/maps").exists():
        missing("no /proc/self/maps to read the loaded libraries from (a Linux /proc)")
    result = subprocess.run([sys.executable, "-c", code, ",".join(modules()),
                             ",".join(GL_LIBRARIES)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "", f"importing the modules loaded {result.stdout.strip()}"


@pytest.mark.slow
def test_pdoc_builds_the_api_reference(tmp_path):
    needs("pdoc", "test")
    out = tmp_path / "api"
    result = subprocess.run(pdoc_command(out), cwd=tmp_path, capture_output=True, text=True,
                            timeout=600)
    assert result.returncode == 0, result.stderr
    # A module pdoc could not import is a warning, not a failure: refuse it here.
    for problem in ("Couldn't import", "Error loading", "Cannot find spec", "Traceback",
                    "does not resolve", "Warn"):
        assert problem not in result.stderr, result.stderr
    pages = {p.relative_to(out).as_posix() for p in out.rglob("*.html")}
    wanted = {name.replace(".", "/") + ".html" for name in modules()}
    assert not wanted - pages, f"no page for {sorted(wanted - pages)}"
    assert "index.html" in pages

    def page(name):
        return (out / name).read_text(encoding="utf-8")

    assert "declared once" in page("es2particles/params.html")
    assert "FramePlan" in page("es2particles/frame/plan.html")
    assert "emitter family" in page("es2particles/scenes/emitter.html")
    assert "frame settings" in page("es2particles/frame/settings.html")
    assert "GPU particle systems" in page("es2particles.html")
