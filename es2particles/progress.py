"""A progress bar with a time-left estimate: tqdm when installed (the ``progress`` extra), else a
plain line rewritten on stderr."""

import sys
import time


def progress(iterable, total, label, unit="frame"):
    """Yield from ``iterable`` while showing progress towards ``total`` items."""
    try:
        from tqdm import tqdm
    except ImportError:
        yield from _plain(iterable, total, label, unit)
        return
    yield from tqdm(iterable, total=total, desc=label, unit=unit, file=sys.stderr)


def _plain(iterable, total, label, unit):
    start = time.perf_counter()
    for done, item in enumerate(iterable, 1):
        yield item
        elapsed = time.perf_counter() - start
        left = elapsed / done * (total - done)
        sys.stderr.write(f"\r{label}: {done}/{total} {unit}s, {elapsed:.1f} s, about {left:.1f} s left")
        sys.stderr.flush()
    sys.stderr.write("\n")
