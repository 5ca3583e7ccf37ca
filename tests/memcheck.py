"""Run a program under valgrind's memcheck and pick out its errors (test helper).

Used to show that hosts of the pythonfmu FMUs exit without touching freed memory: the
outcome of a use after free depends on the heap's history (an abort in a few runs out
of ten), valgrind sees it on every run.
"""

import os
import re
import shutil
import subprocess

import pytest

__all__ = ["memcheck", "freed_memory_errors"]


def memcheck(argv, env=None, cwd=None, timeout=600):
    """Start ``argv`` under ``valgrind --tool=memcheck``; skip the test if valgrind is missing.

    Returns the :class:`subprocess.Popen` (stdout and stderr piped, text), so that several
    runs can go side by side; ``communicate()`` it. ``PYTHONMALLOC=malloc`` is set so that
    Python's own allocator does not hide blocks from valgrind.
    """
    valgrind = shutil.which("valgrind")
    if valgrind is None:
        pytest.skip("valgrind not found")
    env = dict(os.environ if env is None else env, PYTHONMALLOC="malloc")
    return subprocess.Popen(
        [valgrind, "--tool=memcheck", "--error-limit=no", "--num-callers=40", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=cwd,
    )


def freed_memory_errors(valgrind_log, where):
    """The memcheck reports of reads or writes in freed blocks that mention ``where``.

    Parameters
    ----------
    valgrind_log : str
        valgrind's stderr.
    where : str
        A function name that must occur in the report (its stack, or the stacks where the
        block was allocated and freed).

    Returns
    -------
    list of str
        One entry per matching report.
    """
    reports = re.split(r"\n==\d+== \n", valgrind_log)
    return [
        r
        for r in reports
        if re.search(r"Invalid (read|write|free)", r) and " free'd" in r and where in r
    ]
