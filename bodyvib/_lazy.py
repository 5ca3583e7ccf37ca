"""Lazy exports of a package: its public names, imported from their module on first use.

A package ``__init__`` names the public names each of its modules defines and takes its ``__all__``,
``__getattr__`` and ``__dir__`` from :func:`lazy_exports`, so importing the package costs
nothing until a name is used (the command line imports only what a command needs).
"""

import importlib
import sys
from typing import Callable, List, Mapping, Sequence, Tuple

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, modules: Mapping[str, Sequence[str]], subpackages: Sequence[str] = ()
) -> Tuple[List[str], Callable[[str], object], Callable[[], list]]:
    """The ``__all__``, ``__getattr__`` and ``__dir__`` of a package that imports lazily.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    modules : mapping of str to sequence of str
        Submodule (relative to ``package``) -> the public names it defines, as the
        ``from .submodule import ...`` lines of an eager package would list them.
    subpackages : sequence of str
        Subpackages that are public names too, imported on first use like the names.

    Returns
    -------
    (list of str, callable, callable)
        ``__all__`` (the names sorted, then the subpackages), the module's
        ``__getattr__`` and its ``__dir__``.

    Examples
    --------
    >>> all_, getattr_, dir_ = lazy_exports("bodyvib", {"runtime.network": ("linear_model",)})
    >>> all_
    ['linear_model']
    >>> getattr_("linear_model").__name__
    'linear_model'
    """
    home = {name: module for module, names in modules.items() for name in names}
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
