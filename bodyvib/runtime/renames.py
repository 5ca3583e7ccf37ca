"""Old parameter and field names that keep working for one release, with a warning.

A renamed parameter is declared once, where the function is defined
(``@renamed_parameters(h="step")``); a renamed field of a settings dataclass likewise
(``@renamed_fields(step_s="step")``). A call by the old name runs as if by the new one and
warns with a ``DeprecationWarning`` naming both. The names of the package and the rule for
unit suffixes are in docs/architecture.md ("Names").

Standard library only: this module travels inside the FMUs with the run-time.
"""

import functools
import warnings
from typing import Any, Callable, Dict, TypeVar, cast

__all__ = ["NOT", "renamed_parameters", "renamed_fields", "warn_renamed"]

F = TypeVar("F", bound=Callable[..., Any])
C = TypeVar("C", bound=type)


def warn_renamed(owner: str, old: str, new: str, stacklevel: int = 3) -> None:
    """Warn that ``owner``'s ``old`` is now called ``new``.

    Parameters
    ----------
    owner : str
        The function, class or file format that renamed it.
    old, new : str
        The old and the new name.
    stacklevel : int
        Passed to :func:`warnings.warn` (the default points at the caller's caller).

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as w:
    ...     warnings.simplefilter("always")
    ...     warn_renamed("f", "h", "step")
    >>> str(w[0].message)
    "f: 'h' is renamed 'step'; the old name will be removed in the next release"
    """
    warnings.warn(
        f"{owner}: {old!r} is renamed {new!r}; the old name will be removed in the next release",
        DeprecationWarning,
        stacklevel=stacklevel,
    )


#: An old name that meant the opposite of the new one: ``quiet=NOT("progress")``.
class NOT(str):
    """The new name of an old flag of the opposite sense (``quiet`` -> ``progress``).

    A call with both keeps the old behaviour: the new flag is on if either says so.
    """


def _rename_keywords(owner: str, renames: Dict[str, str], kwargs: dict) -> None:
    """Move each old keyword of ``kwargs`` to its new name, warning; refuse both given."""
    for old, new in renames.items():
        if old in kwargs:
            if new in kwargs and not isinstance(new, NOT):
                raise TypeError(f"{owner}() got {old!r} and its new name {new!r}: give {new!r}")
            warn_renamed(owner, old, str(new), stacklevel=4)
            value = kwargs.pop(old)
            kwargs[new] = bool(kwargs.get(new)) or not value if isinstance(new, NOT) else value


def renamed_parameters(**renames: str) -> Callable[[F], F]:
    """Decorator: accept each old keyword ``old="new"`` for one release, with a warning.

    Parameters
    ----------
    **renames : str
        Old parameter name -> new parameter name; a :class:`NOT` name for an old flag
        of the opposite sense.

    Returns
    -------
    callable
        The decorator. A call without an old keyword goes straight through.

    Examples
    --------
    >>> import warnings
    >>> @renamed_parameters(h="step")
    ... def advance(step):
    ...     return 2 * step
    >>> with warnings.catch_warnings(record=True) as w:
    ...     warnings.simplefilter("always")
    ...     advance(h=1.0), advance(step=1.0), w[0].category.__name__
    (2.0, 2.0, 'DeprecationWarning')
    """

    def decorate(func: F) -> F:
        owner = func.__qualname__

        @functools.wraps(func)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            if kwargs and not renames.keys().isdisjoint(kwargs):
                _rename_keywords(owner, renames, kwargs)
            return func(*args, **kwargs)

        return cast(F, wrapper)

    return decorate


def renamed_fields(**renames: str) -> Callable[[C], C]:
    """Class decorator for a dataclass: old field names as keywords and attributes, warned.

    The constructor (and so :func:`dataclasses.replace`) takes the old keyword, and
    reading the old attribute gives the new field's value.

    Parameters
    ----------
    **renames : str
        Old field name -> new field name.

    Returns
    -------
    callable
        The class decorator (apply it above ``@dataclass``).

    Examples
    --------
    >>> import warnings
    >>> from dataclasses import dataclass
    >>> @renamed_fields(step_s="step")
    ... @dataclass(frozen=True)
    ... class Settings:
    ...     step: float = 1e-3
    >>> with warnings.catch_warnings(record=True) as w:
    ...     warnings.simplefilter("always")
    ...     s = Settings(step_s=0.002)
    ...     s.step, s.step_s, len(w)
    (0.002, 0.002, 2)
    """

    def decorate(cls: C) -> C:
        init: Callable[..., None] = vars(cls)["__init__"]
        owner = cls.__qualname__

        @functools.wraps(init)
        def __init__(self: Any, *args: Any, **kwargs: Any) -> None:
            if kwargs and not renames.keys().isdisjoint(kwargs):
                _rename_keywords(owner, renames, kwargs)
            init(self, *args, **kwargs)

        type.__setattr__(cls, "__init__", __init__)
        for old, new in renames.items():
            setattr(cls, old, property(_old_attribute(owner, old, new)))
        return cls

    return decorate


def _old_attribute(owner: str, old: str, new: str) -> Callable[[Any], Any]:
    def read(self: Any) -> Any:
        warn_renamed(owner, old, new)
        return getattr(self, new)

    read.__doc__ = f"Deprecated: ``{new}``."
    return read
