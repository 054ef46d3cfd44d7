"""``python -m es2particles``: the same command line as ``es2particles``."""

import sys

from .cli import main

sys.exit(main())
