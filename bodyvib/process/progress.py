"""Progress of the long-running commands: tqdm bars on stderr (hidden off a terminal) and
one-line status messages.

A function that reports progress takes one parameter, ``progress``: False (the library's
default: silent), True (bars and messages on stderr) or a callable that receives each
message line (bars, if any, still on stderr).
"""

import sys
from typing import Callable, Union

__all__ = ["progress_bar", "progress_lines"]

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


def progress_bar(total: int, enabled: Progress, desc: str, unit: str = "step"):
    """A tqdm bar on stderr, or None when not wanted.

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

    Returns
    -------
    tqdm.tqdm or None
        Hidden when stderr is not a terminal (``disable=None``); refreshed at most every
        0.5 s; not left on the screen when closed.
    """
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(
        total=total,
        unit=unit,
        file=sys.stderr,
        disable=None,
        leave=False,
        desc=desc,
        mininterval=0.5,
    )
