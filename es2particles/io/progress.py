"""A progress bar with a time-left estimate: tqdm when installed (the ``progress`` extra) and
stderr is a terminal, else plain lines (rewritten in place on a terminal; in a log, one line per
tenth of the work, never a carriage return)."""

import sys
import time


def progress(iterable, total, label, unit="frame"):
    """Yield from ``iterable`` while showing progress towards ``total`` items."""
    terminal = sys.stderr.isatty()
    try:
        from tqdm import tqdm
    except ImportError:
        tqdm = None
    if tqdm is not None and terminal:
        from .signals import signals_held

        with signals_held():  # tqdm's monitor thread never takes the process's signals
            bar = tqdm(iterable, total=total, desc=label, unit=unit, file=sys.stderr)
        yield from bar
        return
    yield from _plain(iterable, total, label, unit, terminal)


def _plain(iterable, total, label, unit, terminal):
    start = time.perf_counter()
    every = max(1, total // 10)
    for done, item in enumerate(iterable, 1):
        yield item
        if not terminal and done % every and done != total:
            continue
        elapsed = time.perf_counter() - start
        left = elapsed / done * (total - done)
        line = f"{label}: {done}/{total} {unit}s, {elapsed:.1f} s, about {left:.1f} s left"
        sys.stderr.write(f"\r{line}" if terminal else f"{line}\n")
        sys.stderr.flush()
    if terminal:
        sys.stderr.write("\n")
