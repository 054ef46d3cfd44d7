"""A pytest plugin (``-p checkout_clean`` in pyproject.toml, loaded before any conftest) that
keeps the suite from writing into the checkout (issue 46): this process's compiled modules go
to a folder of the session's, and the commands its tests start write none (they read the ones
there are: a prefix folder of their own made each recompile the standard library, and widened
the window in which an interrupt ends the interpreter before any of our code); Hypothesis keeps
its examples and collected constants in that folder, not in .hypothesis/; the folder is removed
when the session ends; and the pytest cache is off (``-p no:cacheprovider``)."""

import atexit
import os
import shutil
import sys
import tempfile

HOME = tempfile.mkdtemp(prefix="es2particles-tests-")
atexit.register(shutil.rmtree, HOME, True)
sys.pycache_prefix = os.path.join(HOME, "pycache")  # this process's, the tests' own included
os.environ["PYTHONDONTWRITEBYTECODE"] = "1"  # the commands it starts

try:
    from hypothesis import configuration, settings
except ImportError:  # the test extra brings it; without it, its tests skip
    pass
else:
    configuration.set_hypothesis_home_dir(os.path.join(HOME, "hypothesis"))
    settings.register_profile("es2particles", database=None)
    settings.load_profile("es2particles")
