"""``es2particles report``: error against run time, and the stability suite, as REPORT.md with
charts. Tooling around the engine, not part of it: ``measure.py`` (timings and error figures),
``stability.py`` (the suite's cases, which tests/test_stability.py asserts too), ``charts.py``
(matplotlib, optional), ``document.py`` (the report itself)."""

from .document import run

__all__ = ["run", "document", "measure", "stability", "charts"]
