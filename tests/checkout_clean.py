"""A pytest plugin (``-p checkout_clean`` in pyproject.toml, loaded before any conftest) that
keeps the suite from writing into the checkout (issue 46): this process's compiled modules (the
tests' rewritten ones included) go to the user's cache folder, outside the checkout, and stay
there between sessions (a session's own folder made every session recompile and rewrite all it
imports: 12 s of the fast tier's 37 collecting); the commands its tests start write none (they
read the ones there are: a prefix folder of their own made each recompile the standard library,
and widened the window in which an interrupt ends the interpreter before any of our code);
Hypothesis keeps its examples and collected constants in a folder of the session's, not in
.hypothesis/, removed when the session ends; and the pytest cache is off
(``-p no:cacheprovider``)."""

import atexit
import os
import shutil
import sys
import tempfile

HOME = tempfile.mkdtemp(prefix="es2particles-tests-")
atexit.register(shutil.rmtree, HOME, True)


def _compiled_folder():
    """$XDG_CACHE_HOME (or ~/.cache)/es2particles-tests/pycache where it can be made, else the
    session's folder."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    folder = os.path.join(base, "es2particles-tests", "pycache")
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError:
        return os.path.join(HOME, "pycache")
    return folder if os.access(folder, os.W_OK) else os.path.join(HOME, "pycache")


sys.pycache_prefix = _compiled_folder()  # this process's, the tests' own included
os.environ["PYTHONDONTWRITEBYTECODE"] = "1"  # the commands it starts

try:
    from hypothesis import configuration, settings
except ImportError:  # the test extra brings it; without it, its tests skip
    pass
else:
    configuration.set_hypothesis_home_dir(os.path.join(HOME, "hypothesis"))
    settings.register_profile("es2particles", database=None)
    settings.load_profile("es2particles")
