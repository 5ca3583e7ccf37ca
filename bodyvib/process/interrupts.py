"""Ctrl-C that never lands inside an FMU: interrupts deferred to safe points.

pythonfmu 0.7.0 runs an FMU's Python code in the host's interpreter, on its main thread.
Python raises ``KeyboardInterrupt`` wherever the main thread happens to be when SIGINT
arrives; inside the FMU's code pythonfmu turns it into fmi2Fatal and later frees the
instance's Python objects twice (measured: about one segfault in six interrupts of
``bodyvib cosim``, false "status 4 (fatal)" errors, mixed output sets). So the fix is in
the host: while :func:`deferred` is active (every ``bodyvib`` command runs inside it),
SIGINT only sets a flag, and the code raises ``KeyboardInterrupt`` itself where that is
safe, at :func:`check`: the co-simulation master between macro-steps, the long loops
(frequency blocks, GA generations and objective calls, FMU builds), and before the
outputs are committed.

A second Ctrl-C while the first is pending raises at once, unless an FMU is alive or
outputs are being committed (:func:`critical`): there it stays deferred, and the master
reaches its next check within a few milliseconds.

Only the main thread can handle signals: elsewhere :func:`deferred` does nothing.
"""

import contextlib
import signal
import threading

__all__ = ["deferred", "critical", "check", "requested", "pending_from"]

_count = 0      # SIGINTs received while deferred
_critical = 0   # depth of critical sections (an FMU alive, outputs being committed)
_depth = 0      # depth of deferred()


def _handler(signum, frame):
    global _count
    _count += 1
    if _count > 1 and _critical == 0:
        raise KeyboardInterrupt  # the user insists, and nothing here can be corrupted


def requested() -> bool:
    """True once Ctrl-C was pressed inside :func:`deferred`.

    Returns
    -------
    bool
    """
    return _count > 0


def check() -> None:
    """Raise ``KeyboardInterrupt`` here if Ctrl-C was pressed: the safe point of a loop.

    Raises
    ------
    KeyboardInterrupt
    """
    if _count:
        raise KeyboardInterrupt


def pending_from(count: int) -> None:
    """Carry interrupts counted before :func:`deferred` was entered (start-up handler).

    Parameters
    ----------
    count : int
        Number of SIGINTs already received.
    """
    global _count
    _count += int(count)


@contextlib.contextmanager
def deferred(exiting: bool = False):
    """Within the block, SIGINT sets a flag that :func:`check` turns into ``KeyboardInterrupt``.

    The previous SIGINT handler is restored when the block ends. Nested blocks share
    the flag. Off the main thread (a worker thread) nothing changes.

    Parameters
    ----------
    exiting : bool
        The process exits after the block (a command line's main): SIGINT is then
        ignored instead of restored. Python resets its handlers to the default while it
        finalizes, and a Ctrl-C in that moment killed the finished command by the signal
        (status -2), its work done and its outputs written.

    Yields
    ------
    None
    """
    global _depth, _count
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.getsignal(signal.SIGINT)
    if _depth == 0:
        _count = 0
    signal.signal(signal.SIGINT, _handler)
    _depth += 1
    try:
        yield
    finally:
        _depth -= 1
        signal.signal(signal.SIGINT, signal.SIG_IGN if exiting and _depth == 0 else previous)


@contextlib.contextmanager
def critical():
    """A section no ``KeyboardInterrupt`` may enter asynchronously (an FMU alive, a commit).

    Yields
    ------
    None
    """
    global _critical
    _critical += 1
    try:
        yield
    finally:
        _critical -= 1
