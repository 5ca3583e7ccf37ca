"""One private temporary folder per command, removed when the command ends however it ends.

Every temporary file or folder of a command -- FMUs built for a run, fmpy's extracted
FMUs, pythonfmu's and the compiler's build folders, a child process's own temporary
files (through ``TMPDIR``) -- goes into a folder of its own, and :func:`private_tempdir`
removes that folder when the command ends: normally, on an error, or on Ctrl-C, SIGTERM
or SIGHUP taken at a safe point (:mod:`bodyvib.process.interrupts`). The code that makes a
temporary folder still deletes it itself; this is the guarantee behind it, for a signal
that ended a cleanup half-way or a child killed before it cleaned up.

The folder's path must survive a ``file:`` URI: an FMU gets the folder it was extracted to
as a percent-encoded URI (``fmuResourceLocation``), and pythonfmu's binary decodes only
``%20``, so a ``:``, ``#``, ``?``, ``%`` or non-ASCII letter in ``TMPDIR`` made it miss its
resources (and crash the host). :func:`uri_unsafe_characters` names such characters; the
private folder then goes into the first safe system temporary folder instead.
"""

import contextlib
import os
import shutil
import tempfile
import urllib.parse

from ..runtime.errors import BodyvibError
from .interrupts import critical

__all__ = ["private_tempdir", "PREFIX", "uri_unsafe_characters", "uri_safe_tempdir"]

#: Name prefix of a command's private temporary folder.
PREFIX = "bodyvib-run-"

_ENV = ("TMPDIR", "TMP", "TEMP")

#: Where the private folder goes when the temporary folder's path is not URI-safe.
_FALLBACKS = ("/tmp", "/var/tmp", "/dev/shm")


def uri_unsafe_characters(path) -> str:
    """The characters of ``path`` that do not survive its ``file:`` URI in every FMU we run.

    A correct ``file:`` URI percent-encodes every character but letters, digits, ``-._~``
    and ``/``; pythonfmu 0.7.0 decodes only ``%20`` (a space), so the folder of an FMU
    extracted to a path with any other encoded character is not found from its URI.

    Parameters
    ----------
    path : str or os.PathLike
        An absolute folder path.

    Returns
    -------
    str
        The unsafe characters in the order they first occur (empty: the path is safe).

    Examples
    --------
    >>> uri_unsafe_characters("/tmp/x/a:b#c d")
    ':#'
    >>> uri_unsafe_characters("/tmp/with space")
    ''
    """
    out = ""
    for ch in os.fspath(path):
        if ch != " " and urllib.parse.quote(ch, safe="/") != ch and ch not in out:
            out += ch
    return out


def uri_safe_tempdir() -> str:
    """The temporary folder for FMUs: :func:`tempfile.gettempdir`, or a safe system one.

    Returns
    -------
    str
        ``tempfile.gettempdir()`` when its path is URI-safe (:func:`uri_unsafe_characters`),
        else the first of ``/tmp``, ``/var/tmp``, ``/dev/shm`` that is a writable, safe folder.

    Raises
    ------
    BodyvibError
        No safe temporary folder: the message names the characters and the fix.
    """
    given = tempfile.gettempdir()
    bad = uri_unsafe_characters(given)
    if not bad:
        return given
    for folder in _FALLBACKS:
        if (
            not uri_unsafe_characters(folder)
            and os.path.isdir(folder)
            and os.access(folder, os.W_OK | os.X_OK)
        ):
            return folder
    raise BodyvibError(
        f"the temporary folder '{given}' has {' '.join(repr(c) for c in bad)} in its path, "
        "which FMUs cannot read back from their resource URI; set TMPDIR to a folder "
        "without it"
    )


@contextlib.contextmanager
def private_tempdir():
    """Within the block, :mod:`tempfile` and child processes use a fresh private folder.

    The folder is made inside the current temporary folder (or, if its path is not
    URI-safe, inside a safe system one: :func:`uri_safe_tempdir`); :data:`tempfile.tempdir`
    and the ``TMPDIR``, ``TMP`` and ``TEMP`` variables point to it during the block
    and are restored after it, and the folder is removed with everything in it (in a
    :func:`bodyvib.process.interrupts.critical` section: a second signal does not cut
    the removal short).

    Yields
    ------
    str
        The folder.

    Raises
    ------
    BodyvibError
        No URI-safe temporary folder (:func:`uri_safe_tempdir`).

    Examples
    --------
    >>> import os, tempfile
    >>> with private_tempdir() as d:
    ...     tempfile.gettempdir() == d
    True
    >>> os.path.exists(d)
    False
    """
    folder = tempfile.mkdtemp(prefix=PREFIX, dir=uri_safe_tempdir())
    saved_dir = tempfile.tempdir
    saved_env = {k: os.environ.get(k) for k in _ENV}
    tempfile.tempdir = folder
    os.environ.update({k: folder for k in _ENV})
    try:
        yield folder
    finally:
        with critical():
            tempfile.tempdir = saved_dir
            for k, v in saved_env.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v
            shutil.rmtree(folder, ignore_errors=True)
