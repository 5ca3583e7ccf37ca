"""Lazy exports of a package: its public names, imported from their module on first use.

A package ``__init__`` names where each public name lives and takes its ``__all__``,
``__getattr__`` and ``__dir__`` from :func:`lazy_exports`, so importing the package costs
nothing until a name is used (the command line imports only what a command needs).
"""

import importlib
import sys
from typing import Callable, Dict, List, Sequence, Tuple

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, home: Dict[str, str], subpackages: Sequence[str] = ()
) -> Tuple[List[str], Callable[[str], object], Callable[[], list]]:
    """The ``__all__``, ``__getattr__`` and ``__dir__`` of a package that imports lazily.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    home : dict of str to str
        Public name -> the submodule (relative to ``package``) that defines it.
    subpackages : sequence of str
        Subpackages that are public names too, imported on first use like the names.

    Returns
    -------
    (list of str, callable, callable)
        ``__all__`` (the names sorted, then the subpackages), the module's
        ``__getattr__`` and its ``__dir__``.

    Examples
    --------
    >>> all_, getattr_, dir_ = lazy_exports("bodyvib", {"linear_model": "runtime.network"})
    >>> all_
    ['linear_model']
    >>> getattr_("linear_model").__name__
    'linear_model'
    """
    names = sorted(home) + list(subpackages)

    def __getattr__(name: str) -> object:
        if name in home:
            return getattr(importlib.import_module(f"{package}.{home[name]}"), name)
        if name in subpackages:
            return importlib.import_module(f"{package}.{name}")
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list:
        return sorted(set(vars(sys.modules[package])) | set(names))

    return names, __getattr__, __dir__
