"""The one check of an input file before it is opened: a readable regular file.

Opening a FIFO (named pipe) for reading waits until something writes to it, a device
may never end and a socket cannot be opened at all; bodyvib reads regular files only and
refuses the others by name before opening them. The same names describe a special file
where an output should go (:mod:`bodyvib.process.outputs`).
"""

import os
import stat
from typing import Union

from .errors import BodyvibError

__all__ = ["check_input_file", "file_kind"]

_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def file_kind(mode: int) -> str:
    """What a file of this ``st_mode`` is, in words.

    Parameters
    ----------
    mode : int
        ``os.stat(path).st_mode``.

    Returns
    -------
    str
        ``"a folder"``, ``"a FIFO (named pipe)"``, ``"a character device"``,
        ``"a block device"``, ``"a socket"``, ``"a file"`` or ``"not a regular file"``.

    Examples
    --------
    >>> import stat
    >>> file_kind(stat.S_IFIFO | 0o600)
    'a FIFO (named pipe)'
    """
    if stat.S_ISREG(mode):
        return "a file"
    for test, words in _KINDS:
        if test(mode):
            return words
    return "not a regular file"


def check_input_file(path: Union[str, os.PathLike], what: str = "input file") -> str:
    """Refuse an input that is not a readable regular file, before opening it.

    Parameters
    ----------
    path : str or os.PathLike
        The input (symlinks are followed).
    what : str
        What the file is, for the message (``"signal file"``, ``"model file"``).

    Returns
    -------
    str
        ``path`` as a string.

    Raises
    ------
    BodyvibError
        The file does not exist, is a folder, a FIFO, a device, a socket, or cannot be
        read (permissions).

    Examples
    --------
    >>> try:
    ...     check_input_file("/dev/null", "signal file")
    ... except BodyvibError as exc:
    ...     print(exc)
    signal file '/dev/null' is a character device, not a file; give a regular file
    """
    path = os.fspath(path)
    try:
        mode = os.stat(path).st_mode
    except OSError as exc:  # a missing file too: "No such file or directory"
        raise BodyvibError(f"cannot read {what} '{path}': {exc.strerror}") from None
    if not stat.S_ISREG(mode):
        raise BodyvibError(f"{what} '{path}' is {file_kind(mode)}, not a file; give a regular file")
    if not os.access(path, os.R_OK):
        raise BodyvibError(f"{what} '{path}' is not readable; check its permissions")
    return path
