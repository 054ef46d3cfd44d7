"""A pytest plugin (``-p checkout_clean`` in pyproject.toml, loaded before any conftest) that
keeps the suite from writing into the checkout (issue 46): compiled modules go to a folder of
the session's, for this process and the commands its tests start, not __pycache__ folders;
Hypothesis keeps its examples and collected constants there too, not in .hypothesis/; and the
pytest cache is off (``-p no:cacheprovider``). The folder is removed when the session ends."""

import atexit
import os
import shutil
import sys
import tempfile

HOME = tempfile.mkdtemp(prefix="es2particles-tests-")
atexit.register(shutil.rmtree, HOME, True)
os.environ["PYTHONPYCACHEPREFIX"] = sys.pycache_prefix = os.path.join(HOME, "pycache")

try:
    from hypothesis import configuration, settings
except ImportError:  # the test extra brings it; without it, its tests skip
    pass
else:
    configuration.set_hypothesis_home_dir(os.path.join(HOME, "hypothesis"))
    settings.register_profile("es2particles", database=None)
    settings.load_profile("es2particles")
