"""Reading JSON files with one clear error for every way they can be unreadable.

The only file access the FMU run-time needs (a slave reads its baked model file);
writing outputs is the commands' business (:mod:`bodyvib.process.outputs`).
"""

import json
import os

from .errors import BodyvibError

__all__ = ["read_json"]


def read_json(path, what: str = "file"):
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
        The file cannot be opened, is not UTF-8 text, or is not valid JSON
        (with the line and column).
    """
    path = os.fspath(path)
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except OSError as exc:
        raise BodyvibError(f"cannot read {what} '{path}': {exc.strerror}") from None
    except UnicodeDecodeError:
        raise BodyvibError(f"{path}: not a text (UTF-8) JSON {what}") from None
    except json.JSONDecodeError as exc:
        raise BodyvibError(
            f"{path}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
        ) from None
