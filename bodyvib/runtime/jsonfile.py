"""Reading JSON files with one clear error for every way they can be unreadable.

The only file access the FMU run-time needs (a slave reads its baked model file);
writing outputs is the commands' business (:mod:`bodyvib.process.outputs`).
"""

import json
import os
from typing import Any, Union

from .errors import BodyvibError
from .inputfile import check_input_file

__all__ = ["read_json", "MAX_DEPTH"]

#: Deepest nesting of arrays and objects accepted. bodyvib's files nest four levels at
#: most (a model's elements: object, list, object, value); beyond a few hundred, Python's
#: parser (and every walk of the document) ends in RecursionError.
MAX_DEPTH = 32


def _depth(value: object) -> int:
    """Nesting depth of a parsed JSON value, without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, dict):
            v = list(v.values())
        if isinstance(v, list):
            deepest = max(deepest, d)
            stack.extend((x, d + 1) for x in v if isinstance(x, (list, dict)))
    return deepest


def read_json(path: Union[str, os.PathLike], what: str = "file") -> Any:
    """Read a JSON file, turning every way it can be unreadable into one clear error.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    what : str
        What the file is, for the message (``"model file"``, ``"configuration"``).

    Returns
    -------
    object
        The parsed JSON value.

    Raises
    ------
    BodyvibError
        The file is not a readable regular file (:func:`.inputfile.check_input_file`:
        a FIFO would wait forever), cannot be opened, is not UTF-8 text, is not valid JSON
        (with the line and column), or nests deeper than :data:`MAX_DEPTH`.
    """
    path = check_input_file(path, what)
    deep = BodyvibError(
        f"{path}: arrays or objects nested more than {MAX_DEPTH} levels "
        f"deep; a {what} nests a few levels: is this the right file?"
    )
    try:
        with open(path, encoding="utf-8") as f:
            value = json.load(f)
    except RecursionError:
        raise deep from None
    except OSError as exc:
        raise BodyvibError(f"cannot read {what} '{path}': {exc.strerror}") from None
    except UnicodeDecodeError:
        raise BodyvibError(f"{path}: not a text (UTF-8) JSON {what}") from None
    except json.JSONDecodeError as exc:
        raise BodyvibError(
            f"{path}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
        ) from None
    if _depth(value) > MAX_DEPTH:
        raise deep
    return value
