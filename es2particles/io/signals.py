"""Signals held back around what an interrupt must not cut in two: a driver's compile (by this
thread's mask), a few renames (by Python's handlers), and helper threads started with the mask
(so the kernel never hands them the process's signals). No numpy, no GL: the command imports
numpy itself inside :func:`signals_held`."""

from contextlib import contextmanager


@contextmanager
def signals_held():
    """SIGINT, SIGTERM and SIGALRM blocked in this thread while the block runs (a driver's
    compile), then delivered: Python then raises its KeyboardInterrupt between bytecodes, as for
    any other moment. A signal that landed inside llvmpipe's compile ended a run in a
    segmentation fault (3 in 150 runs of `run wind` killed 0.1-0.6 s in, every one in moderngl's
    program()); with the signals held, none in 300. SIGALRM too: the command re-delivers an
    interrupt that landed in an import by a 5 ms alarm.

    A thread started inside the block inherits the mask, and so never takes the process's
    signals: start every helper thread that lives through GL calls here. The kernel hands a
    process's signal to any thread that does not block it, and Python then runs its handler in
    the main thread at once, even inside program() (a phase timer's thread took it: a compile
    loop under SIGTERMs crashed in 4 runs of 6, and `run wind` 1 in 400). Off the main thread,
    or without pthread_sigmask, the block runs as it is."""
    import signal
    import threading

    if not hasattr(signal, "pthread_sigmask") or \
            threading.current_thread() is not threading.main_thread():
        yield
        return
    held = {signal.SIGINT, signal.SIGTERM} | ({signal.SIGALRM} if hasattr(signal, "SIGALRM")
                                               else set())
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


@contextmanager
def signals_deferred():
    """SIGINT and SIGTERM (and a Python-handled SIGALRM) held back while the block runs, then
    delivered as they would have been (the command turns both into KeyboardInterrupt): a few
    renames are not cut in two. In a thread other than the main one, where Python runs no
    signal handler, nothing is changed."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught = []

    def hold(signum, frame):
        caught.append(signum)

    previous = {}
    # SIGALRM too where Python handles it: the command delivers an interrupt that landed in an
    # import or a finalizer by a 5 ms timer (cli._terminate_as_interrupt), which fired inside
    # the writable-folder probe and left it behind (SIGTERM 0.12 s into `run wind`).
    alarm = [signal.SIGALRM] if hasattr(signal, "SIGALRM") and callable(
        signal.getsignal(signal.SIGALRM)) else []
    for number in (signal.SIGINT, signal.SIGTERM, *alarm):
        if signal.getsignal(number) is not None:  # None: a handler set outside Python, kept
            previous[number] = signal.signal(number, hold)
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        for number in dict.fromkeys(caught):
            signal.raise_signal(number)
