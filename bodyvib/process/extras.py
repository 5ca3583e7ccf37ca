"""The optional parts of bodyvib, and the one line that says which one a task needs.

``pip install bodyvib`` brings what building, co-simulating, checking, the frequency
responses and the comfort figures need. The rest comes with an extra
(``pip install 'bodyvib[sweep]'``): the packages below are imported only inside the
functions that use them, and those functions call :func:`require` first, so a missing
extra is one :class:`MissingExtraError` naming the extra and the command that installs it,
never a traceback from deep inside a run.
"""

import importlib.util

from bodyvib.runtime.errors import BodyvibError

__all__ = ["EXTRAS", "MissingExtraError", "missing", "require"]

#: Extra -> the modules it brings, as import names (pyproject.toml's optional-dependencies).
EXTRAS = {
    "sweep": ("dask", "distributed", "pyarrow", "pandas", "numba", "threadpoolctl"),
    "fit": ("deap", "cma", "pymoo", "threadpoolctl"),
    "roads": ("pycrg",),
    "mdf": ("asammdf",),
}


class MissingExtraError(BodyvibError, ImportError):
    """A task needs an optional part of bodyvib that is not installed.

    A :class:`~bodyvib.runtime.errors.BodyvibError` (the command line prints it as one line
    and exits with status 2) and an ``ImportError`` (what it is to Python code).

    Attributes
    ----------
    task : str
        What needed the extras, the message's subject.
    extras : tuple of str
        The extras not installed.
    """

    def __init__(self, message: str, task: str = "", extras: tuple = ()):
        super().__init__(message)
        self.task, self.extras = task, tuple(extras)


def missing(extra: str) -> list:
    """The modules of ``extra`` that cannot be imported here.

    Parameters
    ----------
    extra : str
        A key of :data:`EXTRAS`.

    Returns
    -------
    list of str
        Import names, in the order of :data:`EXTRAS`; empty when the extra is installed.

    Examples
    --------
    >>> from bodyvib.process.extras import missing
    >>> missing("sweep") == [] or "pyarrow" in missing("sweep") or "numba" in missing("sweep")
    True
    """
    return [m for m in EXTRAS[extra] if importlib.util.find_spec(m) is None]


def require(task: str, *extras: str) -> None:
    """Refuse ``task`` unless every extra it needs is installed, before any work.

    Parameters
    ----------
    task : str
        What needs the extras, as the message's subject (``"bodyvib sweep"``,
        ``"reading an OpenCRG file"``).
    *extras : str
        Keys of :data:`EXTRAS`.

    Raises
    ------
    MissingExtraError
        One line: the task, the extras it needs, the modules not installed and the
        ``pip install`` command that brings them.

    Examples
    --------
    >>> from bodyvib.process.extras import MissingExtraError, require
    >>> try:
    ...     require("bodyvib sweep", "sweep")
    ... except MissingExtraError as exc:
    ...     print(str(exc).split(":")[0])
    ... else:
    ...     print("bodyvib sweep needs the sweep extra")
    bodyvib sweep needs the sweep extra
    """
    absent = {e: missing(e) for e in extras}
    lacking = [e for e in extras if absent[e]]
    if not lacking:
        return
    modules = sorted({m for e in lacking for m in absent[e]})
    plural = "s" if len(lacking) > 1 else ""
    raise MissingExtraError(
        f"{task} needs the {' and '.join(lacking)} extra{plural}: "
        f"pip install 'bodyvib[{','.join(lacking)}]' ({', '.join(modules)} not installed)",
        task,
        lacking,
    )
