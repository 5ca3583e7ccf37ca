"""Sizes the memory at hand can hold: refuse a computation up front, naming the limit.

A size typed by a user (``frf --points 1e8``, ``cosim --duration 1e9``, ``--speed 1e300``,
a fit configuration's quadrature) that reached numpy's allocator would end in a traceback
after minutes, or in the kernel's OOM killer. :func:`require_memory` compares an estimate of a
computation's working memory with :func:`available_memory` and refuses with both numbers.
"""

import os
from typing import Sequence

from ..runtime.errors import BodyvibError

__all__ = ["available_memory", "require_memory", "format_bytes", "MEMORY_FRACTION"]

#: Share of the available memory one computation may plan to use.
MEMORY_FRACTION = 0.5


def available_memory() -> int:
    """Bytes of memory available to a new allocation (``MemAvailable``), never below 256 MB.

    Returns
    -------
    int
        ``MemAvailable`` from ``/proc/meminfo`` (Linux), else free physical pages
        (``os.sysconf``), else 4 GB; also capped by a cgroup memory limit if one is set.
    """
    avail = None
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except OSError:
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            avail = 4 << 30
    for cg in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(cg) as f:
                text = f.read().strip()
            if text.isdigit():
                avail = min(avail, int(text))
        except OSError:
            continue
    return max(avail, 256 << 20)


def format_bytes(n: float) -> str:
    """``1.5 GB``-style text for a byte count.

    Parameters
    ----------
    n : float
        Bytes.

    Returns
    -------
    str
        Three significant digits and a decimal unit (kB = 1000 B).
    """
    n = float(n)
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if n < 1000 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1000
    return f"{n:.3g} PB"  # pragma: no cover


def require_memory(nbytes: float, what: str, fix: str, parameters: Sequence[str] = ()) -> None:
    """Refuse a computation whose working memory exceeds the share allowed.

    Parameters
    ----------
    nbytes : float
        Estimated peak working memory (may be ``inf``).
    what : str
        The computation and its size, e.g. ``"100000000 points (2 models of 12 states)"``.
    fix : str
        What to do instead, e.g. ``"use fewer points"``.
    parameters : sequence of str
        The parameters ``what`` and ``fix`` name (``BodyvibError.parameters``).

    Raises
    ------
    BodyvibError
        ``nbytes`` above :data:`MEMORY_FRACTION` of :func:`available_memory`.
    """
    limit = MEMORY_FRACTION * available_memory()
    if not nbytes <= limit:
        raise BodyvibError(
            f"{what} needs about {format_bytes(nbytes)} of memory; the limit is "
            f"{format_bytes(limit)} (half the memory available): {fix}",
            parameters=parameters,
        )
