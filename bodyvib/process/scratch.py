"""One private temporary folder per command, removed when the command ends however it ends.

Every temporary file or folder of a command -- FMUs built for a run, fmpy's extracted
FMUs, pythonfmu's and the compiler's build folders, a child process's own temporary
files (through ``TMPDIR``) -- goes into a folder of its own, and :func:`private_tempdir`
removes that folder when the command ends: normally, on an error, or on Ctrl-C, SIGTERM
or SIGHUP taken at a safe point (:mod:`bodyvib.process.interrupts`). The code that makes a
temporary folder still deletes it itself; this is the guarantee behind it, for a signal
that ended a cleanup half-way or a child killed before it cleaned up.
"""

import contextlib
import os
import shutil
import tempfile

from .interrupts import critical

__all__ = ["private_tempdir", "PREFIX"]

#: Name prefix of a command's private temporary folder.
PREFIX = "bodyvib-run-"

_ENV = ("TMPDIR", "TMP", "TEMP")


@contextlib.contextmanager
def private_tempdir():
    """Within the block, :mod:`tempfile` and child processes use a fresh private folder.

    The folder is made inside the current temporary folder; :data:`tempfile.tempdir`
    and the ``TMPDIR``, ``TMP`` and ``TEMP`` variables point to it during the block
    and are restored after it, and the folder is removed with everything in it (in a
    :func:`bodyvib.process.interrupts.critical` section: a second signal does not cut
    the removal short).

    Yields
    ------
    str
        The folder.

    Examples
    --------
    >>> import os, tempfile
    >>> with private_tempdir() as d:
    ...     tempfile.gettempdir() == d
    True
    >>> os.path.exists(d)
    False
    """
    folder = tempfile.mkdtemp(prefix=PREFIX)
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
