"""``python -m es2particles``: the same command line as ``es2particles``."""

from .cli import console_main

console_main()
