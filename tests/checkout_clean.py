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


def _forget_own_bytecode():
    """pytest compiled this plugin into tests/__pycache__ before its first line ran (a ``-p``
    plugin's asserts are rewritten, and the prefix below was not set yet): remove that file,
    and the folder where nothing else is in it."""
    here = os.path.dirname(os.path.abspath(__file__))
    folder = os.path.join(here, "__pycache__")
    name = os.path.splitext(os.path.basename(__file__))[0]
    try:
        for entry in os.listdir(folder):
            if entry.startswith(name + "."):
                os.remove(os.path.join(folder, entry))
        os.rmdir(folder)
    except OSError:  # not there, or not empty: someone else's
        pass


atexit.register(_forget_own_bytecode)


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
