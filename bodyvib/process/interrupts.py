"""Ctrl-C that never lands inside an FMU: interrupts deferred to safe points.

pythonfmu 0.7.0 runs an FMU's Python code in the host's interpreter, on its main thread.
Python raises ``KeyboardInterrupt`` wherever the main thread happens to be when SIGINT
arrives; inside the FMU's code pythonfmu turns it into fmi2Fatal and later frees the
instance's Python objects twice (a segfault, a false "status 4 (fatal)" error, a mixed
set of outputs). So the host decides where an interrupt lands: while :func:`deferred` is active (every ``bodyvib`` command runs inside it),
SIGINT only sets a flag, and the code raises ``KeyboardInterrupt`` itself where that is
safe, at :func:`check`: the co-simulation master between macro-steps, the long loops
(frequency blocks, GA generations and objective calls, FMU builds), and before the
outputs are committed.

A second signal changes nothing: the command is already on its way to its next safe
point (never more than a fraction of a second away: macro-steps, blocks, generations,
a child process's poll). Raising at once on a second Ctrl-C would land the
``KeyboardInterrupt`` anywhere again: inside an import or a garbage-collector callback it
prints "Exception ignored" tracebacks, leaves half-initialized modules, or makes Python
exit by SIGINT after the command has printed its line.

SIGTERM (what ``kill``, ``timeout`` and job schedulers send) and SIGHUP (the terminal
closed) are taken the same way: the command stops at the same safe points, removes its
temporary files and keeps its outputs all new or all old; :func:`exit_status` then gives
the shell's status of the first signal (130 for SIGINT, 143 for SIGTERM, 129 for SIGHUP)
and :func:`message` the one line to print.

Child processes (a compiler, pythonfmu's build) are run by :func:`run_process` in their
own process group, polled at the safe points' rhythm and killed as a group on a signal,
so none is left behind.

Only the main thread can handle signals: elsewhere :func:`deferred` does nothing.
"""

import contextlib
import os
import signal
import subprocess
import threading

__all__ = [
    "deferred",
    "critical",
    "check",
    "requested",
    "pending_from",
    "SIGNALS",
    "exit_status",
    "message",
    "run_process",
]

#: The signals taken at safe points: Ctrl-C, ``kill``/``timeout``/job schedulers, a
#: closed terminal (SIGHUP does not exist on Windows).
SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))

#: One line per signal, printed when a command stops on it.
_MESSAGES = {
    "SIGINT": "interrupted",
    "SIGTERM": "terminated (SIGTERM)",
    "SIGHUP": "hung up (SIGHUP)",
}

_count = 0  # signals received while deferred
_first = None  # the first of them (its number)
_depth = 0  # depth of deferred()


def _handler(signum, frame):
    global _count, _first
    _count += 1
    if _first is None:
        _first = signum


def _raise():
    raise KeyboardInterrupt


def requested() -> bool:
    """True once Ctrl-C was pressed inside :func:`deferred`.

    Returns
    -------
    bool
    """
    return _count > 0


def exit_status() -> int:
    """The shell's exit status of the first signal received: 128 + its number.

    Returns
    -------
    int
        130 for SIGINT (also when none was received), 143 for SIGTERM, 129 for SIGHUP.
    """
    return 128 + int(_first if _first is not None else signal.SIGINT)


def message() -> str:
    """The one line a command prints when it stops on the first signal received.

    Returns
    -------
    str
        ``interrupted`` (SIGINT), ``terminated (SIGTERM)`` or ``hung up (SIGHUP)``.
    """
    if _first is None:
        return _MESSAGES["SIGINT"]
    return _MESSAGES.get(signal.Signals(_first).name, f"stopped by signal {_first}")


def run_process(cmd, poll: float = 0.05, scratch=None, **kwargs) -> subprocess.CompletedProcess:
    """Run a child process (output captured as text) that a signal never leaves behind.

    The child and its own children (a compiler driver's cc1, as, ld) form a new process
    group, so a terminal's Ctrl-C does not reach them directly; the wait is polled, and
    once a signal was received (:func:`requested`) the whole group is killed, reaped,
    and ``KeyboardInterrupt`` is raised: a safe point.

    Parameters
    ----------
    cmd : list of str
        The command.
    poll : float
        Seconds between checks for a signal.
    scratch : str or os.PathLike, optional
        A folder (created if missing) for the child's temporary files (its ``TMPDIR``,
        ``TMP``, ``TEMP``), inside one the caller deletes: a killed compiler or
        pythonfmu leaves its temporary files there, not in the system's folder.
    **kwargs
        Passed to :class:`subprocess.Popen` (``cwd``, ``env``).

    Returns
    -------
    subprocess.CompletedProcess
        ``returncode``, ``stdout``, ``stderr`` (str).

    Raises
    ------
    KeyboardInterrupt
        A signal arrived before or while the child ran; the child's group is gone.
    """
    check()
    if scratch is not None:
        scratch = os.fspath(scratch)
        os.makedirs(scratch, exist_ok=True)
        kwargs["env"] = dict(
            kwargs.get("env") or os.environ, TMPDIR=scratch, TMP=scratch, TEMP=scratch
        )
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=hasattr(os, "killpg"),
        **kwargs,
    )
    try:
        while True:
            try:
                out, err = proc.communicate(timeout=poll)  # retrying loses no output
                break
            except subprocess.TimeoutExpired:
                if _count:
                    _raise()
    except BaseException:
        with contextlib.suppress(OSError):
            if hasattr(os, "killpg"):
                os.killpg(proc.pid, signal.SIGKILL)  # the group: no orphan cc1, as or ld
            else:  # Windows: no process groups of this kind
                proc.kill()
        proc.communicate()
        raise
    check()
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def check() -> None:
    """Raise ``KeyboardInterrupt`` here if Ctrl-C was pressed: the safe point of a loop.

    Raises
    ------
    KeyboardInterrupt
    """
    if _count:
        _raise()


def pending_from(count: int) -> None:
    """Carry signals received before :func:`deferred` was entered (start-up handler).

    Parameters
    ----------
    count : int or sequence of int
        Number of SIGINTs already received, or the signal numbers in order.
    """
    global _count, _first
    if isinstance(count, int):
        signums = [signal.SIGINT] * count
    else:
        signums = list(count)
    if signums and _first is None:
        _first = int(signums[0])
    _count += len(signums)


@contextlib.contextmanager
def deferred(exiting: bool = False):
    """Within the block, a signal of :data:`SIGNALS` sets a flag that :func:`check` turns
    into ``KeyboardInterrupt``.

    The previous handlers are restored when the block ends. Nested blocks share
    the flag. Off the main thread (a worker thread) nothing changes.

    Parameters
    ----------
    exiting : bool
        The process exits after the block (a command line's main): the signals are
        then ignored instead of restored. Python resets its handlers to the default while it
        finalizes, and a Ctrl-C in that moment killed the finished command by the signal
        (status -2), its work done and its outputs written.

    Yields
    ------
    None
    """
    global _depth, _count, _first
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in SIGNALS}
    if _depth == 0:
        _count, _first = 0, None
    for s in SIGNALS:
        signal.signal(s, _handler)
    _depth += 1
    try:
        yield
    finally:
        _depth -= 1
        for s in SIGNALS:
            old = previous[s] if previous[s] is not None else signal.SIG_DFL
            signal.signal(s, signal.SIG_IGN if exiting and _depth == 0 else old)


@contextlib.contextmanager
def critical():
    """A section no signal may cut short (an FMU alive, a commit, a cleanup).

    Signals are only ever taken at :func:`check` (never asynchronously), so this marks
    the section for the reader; it is kept for the callers that use it as a guard.

    Yields
    ------
    None
    """
    yield
