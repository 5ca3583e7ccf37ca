"""Atomic file writing (a crash or a full disk never leaves half a file behind) and JSON reading.

Numpy-free and dependency-free (relative imports only), so FMUs can ship it.
"""

import json
import os
import tempfile

from .errors import BodyvibError

__all__ = ["atomic_write_text", "atomic_write_bytes", "write_json", "read_json"]


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (temporary file, then rename).

    Parameters
    ----------
    path : str or os.PathLike
        Destination. Its folder is created if missing.
    data : bytes
        Content.

    Raises
    ------
    OSError
        The file cannot be written; its ``filename`` is ``path`` (not the
        temporary file), so the message names what the user asked for.
    """
    path = os.fspath(path)
    try:
        _write_replace(path, data)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), path) from exc


def _write_replace(path: str, data: bytes) -> None:
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix=os.path.basename(path))
    try:
        # mkstemp makes the file private (0600); give it the mode a plain open() would
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_text(path, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically; see :func:`atomic_write_bytes`.

    Parameters
    ----------
    path : str or os.PathLike
    text : str
    """
    atomic_write_bytes(path, text.encode("utf-8"))


def write_json(path, obj) -> None:
    """Write ``obj`` as indented JSON to ``path`` atomically.

    Parameters
    ----------
    path : str or os.PathLike
    obj : JSON-serializable object
    """
    atomic_write_text(path, json.dumps(obj, indent=2, sort_keys=False) + "\n")


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
