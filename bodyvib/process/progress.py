"""Progress of the long-running commands: a tqdm bar on a terminal, lines in a log, and
one-line status messages.

A function that reports progress takes one parameter, ``progress``: False (the library's
default: silent), True (bars and messages on stderr) or a callable that receives each
message line (bars, if any, still on stderr). On a terminal a bar redraws in place; off a
terminal (a log file, a CI job, a batch system's output) a bar is hidden, and a command
that may run for minutes asks for :class:`LogLines` instead: one plain line every so many
seconds.
"""

import sys
import time
from typing import Callable, Union

__all__ = ["progress_bar", "progress_lines", "LogLines"]

#: What a ``progress`` parameter takes.
Progress = Union[bool, None, Callable[[str], None]]


def progress_lines(progress: Progress) -> Callable[[str], None]:
    """Where the status messages of a ``progress`` setting go.

    Parameters
    ----------
    progress : bool, None or callable
        False or None: nowhere; True: a line on stderr each; a callable: that callable.

    Returns
    -------
    callable
        Takes one message line.

    Examples
    --------
    >>> said = []
    >>> progress_lines(said.append)("built"); progress_lines(False)("lost"); said
    ['built']
    """
    if callable(progress):
        return progress
    if progress:
        return _to_stderr
    return _nowhere


def _to_stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _nowhere(line: str) -> None:
    pass


class LogLines:
    """Progress as plain lines on stderr, at most one every ``every`` seconds.

    The part of tqdm's interface the commands use (``update``, ``set_postfix_str``,
    ``close``). Nothing is printed for a run shorter than ``every``; a run that printed
    a line ends with one for its last state.

    Parameters
    ----------
    total : int
        Units of work of the whole run.
    desc : str
        The lines' first word.
    unit : str
        The unit of work (``"case"``: ``120/400 cases``).
    initial : int
        Units already done (a resumed run).
    every : float
        Seconds between two lines.
    file : file object, optional
        Where the lines go (``sys.stderr`` at the time of each line by default).

    Examples
    --------
    >>> import io
    >>> out = io.StringIO()
    >>> log = LogLines(400, "sweep", "case", initial=100, every=0.0, file=out)
    >>> log.update(100)
    >>> print(out.getvalue().split(",")[0])
    sweep: 200/400 cases (50 %)
    """

    def __init__(self, total, desc, unit="step", initial=0, every=10.0, file=None):
        self.total, self.desc, self.unit, self.every, self.file = total, desc, unit, every, file
        self.n = self.start_n = initial
        self.start = self.last = time.monotonic()
        self.shown = None  # the count of the last line printed
        self.postfix = ""

    def update(self, n: int = 1) -> None:
        """Count ``n`` more units; print a line if ``every`` seconds passed since the last."""
        self.n += n
        now = time.monotonic()
        if now - self.last >= self.every:
            self.last = now
            self._line(now)

    def set_postfix_str(self, s: str, refresh: bool = False) -> None:
        """Text appended to the next line (tqdm's name; ``refresh`` is ignored)."""
        self.postfix = s

    def close(self) -> None:
        """The last state, if a line was printed and the count moved since."""
        if self.shown is not None and self.shown != self.n:
            self._line(time.monotonic())

    def _line(self, now: float) -> None:
        elapsed = now - self.start
        pct = 100.0 * self.n / self.total if self.total else 100.0
        text = f"{self.desc}: {self.n}/{self.total} {self.unit}s ({pct:.0f} %), {elapsed:.0f} s"
        done = self.n - self.start_n
        if 0 < done and self.n < self.total:
            text += f", about {elapsed * (self.total - self.n) / done:.0f} s left"
        if self.postfix:
            text += f", {self.postfix}"
        print(text, file=self.file or sys.stderr, flush=True)
        self.shown = self.n


def progress_bar(
    total: int,
    enabled: Progress,
    desc: str,
    unit: str = "step",
    initial: int = 0,
    log_every: float = 0.0,
    leave: bool = False,
):
    """A tqdm bar on stderr, lines for a log, or None when not wanted.

    Parameters
    ----------
    total : int
        Units of work of the whole run.
    enabled : bool, None or callable
        A ``progress`` setting: false gives None (no bar, no tqdm import).
    desc : str
        The bar's title.
    unit : str
        The unit of work.
    initial : int
        Units already done.
    log_every : float
        When stderr is not a terminal: 0 (the default) hides the bar, a positive number
        gives :class:`LogLines` at most one line every ``log_every`` seconds.
    leave : bool
        Keep the bar on the screen when it is closed.

    Returns
    -------
    tqdm.tqdm or LogLines or None
        The bar is hidden when stderr is not a terminal (``disable=None``) and refreshed
        at most every 0.5 s.
    """
    if not enabled:
        return None
    if log_every > 0 and not sys.stderr.isatty():
        return LogLines(total, desc, unit, initial, log_every)
    from tqdm import tqdm

    return tqdm(
        total=total,
        initial=initial,
        unit=unit,
        file=sys.stderr,
        disable=None,
        leave=leave,
        desc=desc,
        mininterval=0.5,
    )
