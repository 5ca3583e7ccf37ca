"""Outputs: checked before the work, written atomically, committed together.

Writes go to a temporary file in the destination's folder, then replace the
destination in one rename. A symlink is written through (its target is
replaced, the link stays); an existing file keeps its permission bits; a
destination that is a folder, a FIFO, a device or another special file, or a
read-only file, is refused. :func:`staged_writes` collects every write of a
block and commits them together at its end (all of them or, if the block
fails, none); :func:`check_output_path` checks an output before any work is
done.

A process concern of the commands, not of the FMUs: the FMU run-time
(:mod:`bodyvib.runtime`) only reads files (:mod:`bodyvib.runtime.jsonfile`).
"""

import contextlib
import json
import math
import os
import stat
import tempfile
import threading

from ..runtime.errors import BodyvibError
from ..runtime.inputfile import file_kind

__all__ = [
    "atomic_write_text",
    "atomic_write_bytes",
    "write_json",
    "staged_writes",
    "StagedWrites",
    "open_staged",
    "PendingFile",
    "check_output_path",
    "check_outputs",
    "staged_source",
]

_local = threading.local()  # the active StagedWrites of this thread, if any


def _destination(path: str):
    """``(real path, mode to keep or None)`` of a write to ``path``.

    Follows symlinks (the target is what gets replaced) and refuses anything
    but a regular, writable file or a missing one.
    """
    real = os.path.realpath(path)
    try:
        st = os.stat(real)
    except FileNotFoundError:
        return real, None
    if not stat.S_ISREG(st.st_mode):
        raise BodyvibError(
            f"'{path}' is {file_kind(st.st_mode)}, not a file; give a file path to write"
        )
    if not os.access(real, os.W_OK):
        raise BodyvibError(f"'{path}' is read-only; make it writable or write elsewhere")
    return real, stat.S_IMODE(st.st_mode)


def _temporary(real: str, mode, made=None):
    """A new temporary file beside ``real`` with the mode the result should have: ``(fd, path)``.

    The folders it creates are recorded, deepest first, on the active
    :class:`StagedWrites` and on the list ``made`` if given, to be removed with the file.
    """
    folder = os.path.dirname(real)
    missing = []  # the folders this write creates, deepest first
    f = folder
    while f and not os.path.isdir(f) and f != os.path.dirname(f):
        missing.append(f)
        f = os.path.dirname(f)
    os.makedirs(folder, exist_ok=True)
    stage = getattr(_local, "stage", None)
    if stage is not None:  # removed again if the block writes nothing
        stage._made.extend(missing)
    if made is not None:
        made.extend(missing)
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix=os.path.basename(real))
    try:
        if mode is None:  # mkstemp makes the file private (0600); give it a plain open()'s mode
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask
        os.chmod(tmp, mode)
    except BaseException:
        os.close(fd)
        os.unlink(tmp)
        raise
    return fd, tmp


def _oserror(exc: OSError, path: str) -> OSError:
    return OSError(exc.errno, exc.strerror or str(exc), path)


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (temporary file, then rename).

    Inside :func:`staged_writes` the rename waits for the block's commit.

    Parameters
    ----------
    path : str or os.PathLike
        Destination. Its folder is created if missing. A symlink is written
        through to its target; an existing file keeps its permission bits.
    data : bytes
        Content.

    Raises
    ------
    BodyvibError
        The destination is a folder, a FIFO, a device or another special file,
        or a read-only file.
    OSError
        The file cannot be written; its ``filename`` is ``path`` (not the
        temporary file), so the message names what the user asked for.
    """
    with open_staged(path, "wb") as f:  # the one place that writes, syncs and places
        f.write(data)


def _place(tmp: str, real: str, path: str) -> None:
    stage = getattr(_local, "stage", None)
    if stage is not None:
        stage._add(tmp, real, path)
        return
    try:
        os.replace(tmp, real)
    except BaseException as exc:
        _unlink(tmp)
        if isinstance(exc, OSError):
            raise _oserror(exc, path) from exc
        raise


def _backup(real: str):
    """A hard link to the file at ``real`` (to restore it), or None if there is none."""
    if not os.path.isfile(real):
        return None
    backup = f"{real}.bak-{os.getpid()}-{threading.get_ident()}"
    try:
        os.link(real, backup)
    except OSError:  # no hard links here (some file systems): no undo for this file
        return None
    return backup


def _unlink(tmp: str) -> None:
    with contextlib.suppress(OSError):
        os.unlink(tmp)


@contextlib.contextmanager
def open_staged(path, mode: str = "w", encoding: str = "utf-8"):
    """A file opened for streaming, placed at ``path`` atomically when done.

    The content goes to a temporary file beside ``path``; when the block ends
    normally the file replaces ``path`` (or, inside :func:`staged_writes`, is
    committed with the other outputs); if the block fails it is deleted.

    Parameters
    ----------
    path : str or os.PathLike
        Destination (the rules of :func:`atomic_write_bytes`).
    mode : str
        ``"w"`` (text) or ``"wb"`` (binary).
    encoding : str
        Text encoding.

    Yields
    ------
    file object
    """
    path = os.fspath(path)
    real, keep = _destination(path)
    try:
        fd, tmp = _temporary(real, keep)
    except OSError as exc:
        raise _oserror(exc, path) from exc
    try:
        with os.fdopen(
            fd, mode, **({} if "b" in mode else {"encoding": encoding, "newline": ""})
        ) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
    except BaseException as exc:
        _unlink(tmp)
        if isinstance(exc, OSError):
            raise _oserror(exc, path) from exc
        raise
    _place(tmp, real, path)


class PendingFile:
    """A file being written beside its destination, placed there by :meth:`place`.

    For outputs streamed during a long computation (a CSV of a co-simulation): the
    content goes to a temporary file beside ``path`` and replaces ``path`` only when
    :meth:`place` is called (inside :func:`staged_writes`, with the block's other
    outputs); :meth:`discard` (or leaving a ``with`` block by an exception) deletes it.

    Parameters
    ----------
    path : str or os.PathLike
        Destination (the rules of :func:`atomic_write_bytes`).
    mode : str
        ``"w"`` (text, UTF-8, no newline translation) or ``"wb"``.

    Attributes
    ----------
    file : file object
        Where to write.
    """

    def __init__(self, path, mode: str = "w"):
        self.path = os.fspath(path)
        self._real, keep = _destination(self.path)
        self._made = []  # the folders made for it: removed with it unless it is placed
        try:
            fd, self._tmp = _temporary(self._real, keep, self._made)
        except OSError as exc:
            raise _oserror(exc, self.path) from exc
        self.file = os.fdopen(
            fd, mode, **({} if "b" in mode else {"encoding": "utf-8", "newline": ""})
        )

    def place(self) -> None:
        """Flush, close and rename the file onto its destination (or stage it)."""
        try:
            self.file.flush()
            os.fsync(self.file.fileno())
            self.file.close()
        except BaseException as exc:
            self.discard()
            if isinstance(exc, OSError):
                raise _oserror(exc, self.path) from exc
            raise
        _place(self._tmp, self._real, self.path)
        self._tmp = None
        stage = getattr(_local, "stage", None)
        if stage is not None:  # staged: its folders go if the block's commit does not happen
            stage._made.extend(self._made)
        self._made = []

    def discard(self) -> None:
        """Close and delete the file; the destination keeps its old content.

        The folders made for the file go too, where they are empty.
        """
        with contextlib.suppress(OSError):
            self.file.close()
        if self._tmp is not None:
            _unlink(self._tmp)
            self._tmp = None
        made, self._made = self._made, []
        for folder in made:
            with contextlib.suppress(OSError):
                os.rmdir(folder)

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None or self._tmp is not None:
            self.discard()
        return False


class StagedWrites:
    """Writes collected by :func:`staged_writes`, committed together.

    Attributes
    ----------
    paths : list of str
        The destinations staged so far, as given.
    """

    def __init__(self):
        self._entries = []
        self._made = []  # folders created for the staged files
        self.paths = []

    def _add(self, tmp, real, path):
        for i, (old, r, _) in enumerate(self._entries):
            if r == real:  # written twice: the last write wins
                _unlink(old)
                del self._entries[i]
                break
        self._entries.append((tmp, real, path))
        self.paths.append(path)

    def commit(self) -> None:
        """Rename every staged file onto its destination: all of them or none.

        Every staged file is checked to be still there (its folder may have been
        removed while the command ran) before the first rename; a rename that fails
        after others succeeded undoes them (a replaced file gets its old content back
        from a hard link kept until the end, a new file is removed).

        Raises
        ------
        BodyvibError
            A staged file vanished before the commit; nothing was written.
        OSError
            A rename failed; every destination is as it was.
        """
        entries, self._entries = self._entries, []
        for tmp, _, path in entries:
            if not os.path.isfile(tmp):
                for t, _, _ in entries:
                    _unlink(t)
                self._remove_folders()
                raise BodyvibError(
                    f"'{path}' vanished before it was written (was its folder removed while "
                    "the command ran?); no output written"
                )
        done = []  # (real, backup or None) of the renames made
        try:
            for i, (tmp, real, path) in enumerate(entries):
                backup = _backup(real)
                try:
                    os.replace(tmp, real)
                except OSError as exc:
                    if backup is not None:
                        _unlink(backup)
                    for t, _, _ in entries[i:]:
                        _unlink(t)
                    raise _oserror(exc, path) from exc
                done.append((real, backup))
        except BaseException:
            for real, backup in reversed(done):
                with contextlib.suppress(OSError):
                    if backup is None:
                        os.unlink(real)
                    else:
                        os.replace(backup, real)
            raise
        for _, backup in done:
            if backup is not None:
                _unlink(backup)

    def discard(self) -> None:
        """Delete every staged file; the destinations stay as they were."""
        entries, self._entries = self._entries, []
        for tmp, _, _ in entries:
            _unlink(tmp)
        self._remove_folders()

    def _remove_folders(self) -> None:
        """Remove the folders made for the staged files, where they are empty."""
        made, self._made = self._made, []
        for folder in made:
            with contextlib.suppress(OSError):
                os.rmdir(folder)


@contextlib.contextmanager
def staged_writes(guard=None):
    """Collect the atomic writes of a block and commit them together at its end.

    Inside the block, :func:`atomic_write_bytes` (and everything built on it)
    writes each file to a temporary beside its destination; when the block
    ends normally all of them are renamed onto their destinations, one after
    the other; if it fails (an error, an interrupt) all are deleted and every
    destination keeps its old content. A block nested in another hands its
    writes to the outer one, which commits them with its own (``bodyvib build``:
    the FMUs and the SSP made of them, together or none).

    Parameters
    ----------
    guard : callable, optional
        A context-manager factory the commit runs in (e.g. one that defers
        interrupts for the few renames).

    Yields
    ------
    StagedWrites
    """
    outer = getattr(_local, "stage", None)
    stage = StagedWrites()
    _local.stage = stage
    try:
        yield stage
    except BaseException:
        _local.stage = outer
        stage.discard()
        raise
    _local.stage = outer
    if outer is not None:  # nested: the outer block commits these with its own, or none
        for entry in stage._entries:
            outer._add(*entry)
        outer._made.extend(stage._made)
        stage._entries, stage._made = [], []
        return
    try:
        with guard() if guard is not None else contextlib.nullcontext():
            stage.commit()
    except BaseException:
        stage.discard()
        raise


def staged_source(path) -> str:
    """Where the content written to ``path`` is now: its staged temporary file, if any.

    Inside :func:`staged_writes` a file written earlier in the block is not yet at its
    destination; code that reads it back (the SSP packs the FMUs just built) reads it
    here.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    str
        The temporary file holding the staged content, or ``path`` itself.
    """
    path = os.fspath(path)
    stage = getattr(_local, "stage", None)
    if stage is not None:
        real = os.path.realpath(path)
        for tmp, r, _ in reversed(stage._entries):
            if r == real:
                return tmp
    return path


def _same(a: str, b: str) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


def check_output_path(path, option: str, extensions=None, inputs=(), folder: bool = False) -> str:
    """Refuse an output path that cannot be written, before any work is done.

    Parameters
    ----------
    path : str or os.PathLike
        The output.
    option : str
        The parameter or option that named it (``"out"``, ``"--json"``), for the message
        (listed in the error's ``parameters``).
    extensions : sequence of str, optional
        Allowed extensions, lower case with the dot (``(".json",)``).
    inputs : iterable of (str, str)
        ``(option, path)`` of the command's inputs; the output must be none of them.
    folder : bool
        The output is a folder (``fit --report DIR``, ``build --dest DIR``)
        rather than a file.

    Returns
    -------
    str
        The real path (symlinks followed) of the output.

    Raises
    ------
    BodyvibError
        A wrong extension; the output is an input of the command; an existing
        folder, FIFO, device or other special file where a file is written
        (or a file where a folder is); a read-only file; a folder that cannot
        be created or written.
    """
    try:
        return _check_output_path(os.fspath(path), option, extensions, inputs, folder)
    except BodyvibError as exc:
        names = (option,) + tuple(opt for opt, _ in inputs)
        raise BodyvibError(str(exc), parameters=names) from None


def _named(option: str, path: str = "") -> str:
    """An output as a message names it: ``out='r.parquet'`` for a parameter, ``--json
    'f.json'`` for a flag; without a path, ``'out'`` or ``--json``."""
    parameter = option.isidentifier() and option.islower()
    if path:
        return f"{option}='{path}'" if parameter else f"{option} '{path}'"
    return f"'{option}'" if parameter else option


def _check_output_path(path: str, option: str, extensions, inputs, folder: bool) -> str:
    if not path:
        raise BodyvibError(f"{_named(option)}: empty path")
    for opt, inp in inputs:
        if inp is not None and os.path.exists(os.fspath(inp)) and _same(path, os.fspath(inp)):
            raise BodyvibError(
                f"{_named(option, path)} is the input of {_named(opt)}; writing it would "
                "destroy the input: give another output path"
            )
    if extensions and os.path.splitext(path)[1].lower() not in extensions:
        raise BodyvibError(f"{_named(option, path)} must end in {' or '.join(extensions)}")
    real = os.path.realpath(path)
    where = _named(option, path)
    if os.path.exists(real):
        mode = os.stat(real).st_mode
        if folder:
            if not stat.S_ISDIR(mode):
                raise BodyvibError(
                    f"{where} is {file_kind(mode) if not stat.S_ISREG(mode) else 'a file'}"
                    ", not a folder"
                )
            if not os.access(real, os.W_OK | os.X_OK):
                raise BodyvibError(f"{where}: folder is not writable")
            return real
        if not stat.S_ISREG(mode):
            raise BodyvibError(f"{where} is {file_kind(mode)}, not a file; give a file path")
        if not os.access(real, os.W_OK):
            raise BodyvibError(f"{where} is read-only; make it writable or write elsewhere")
    # the nearest existing folder must be a writable folder (missing ones are created)
    parent = os.path.dirname(real) if not folder else real
    while not os.path.exists(parent):
        parent = os.path.dirname(parent)
    if not os.path.isdir(parent):
        raise BodyvibError(f"{where}: '{parent}' is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise BodyvibError(f"{where}: folder '{parent}' is not writable")
    return real


def check_outputs(outputs, inputs=()) -> None:
    """Check several outputs of one command: each by :func:`check_output_path`, all different.

    Parameters
    ----------
    outputs : iterable of tuple
        ``(option, path, extensions)`` or ``(option, path, extensions, folder)``;
        entries whose path is None are skipped.
    inputs : iterable of (str, str)
        ``(option, path)`` of the command's inputs.

    Raises
    ------
    BodyvibError
        See :func:`check_output_path`; or two outputs naming the same file.
    """
    inputs = [(o, p) for o, p in inputs if p is not None]
    seen = {}
    for entry in outputs:
        option, path, exts = entry[:3]
        folder = entry[3] if len(entry) > 3 else False
        if path is None:
            continue
        real = check_output_path(path, option, exts, inputs, folder)
        if real in seen:
            raise BodyvibError(
                f"{_named(option)} and {_named(seen[real])} name the same file '{path}'; give "
                "each output its own path",
                parameters=(option, seen[real]),
            )
        seen[real] = option


def _refuse_nonfinite(obj, where="$"):
    """The JSON path of the first non-finite number in ``obj``, or None."""
    if isinstance(obj, float):
        return None if math.isfinite(obj) else where
    if isinstance(obj, dict):
        for k, v in obj.items():
            bad = _refuse_nonfinite(v, f"{where}.{k}")
            if bad:
                return bad
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            bad = _refuse_nonfinite(v, f"{where}[{i}]")
            if bad:
                return bad
    return None


def atomic_write_text(path, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically; see :func:`atomic_write_bytes`.

    Parameters
    ----------
    path : str or os.PathLike
    text : str
    """
    atomic_write_bytes(path, text.encode("utf-8"))


def write_json(path, obj) -> None:
    """Write ``obj`` as indented, standard JSON to ``path`` atomically.

    Parameters
    ----------
    path : str or os.PathLike
    obj : JSON-serializable object
        Finite numbers only: JSON has no NaN or Infinity.

    Raises
    ------
    BodyvibError
        ``obj`` holds NaN or an infinity (named by its place in the document);
        nothing is written.
    """
    try:
        text = json.dumps(obj, indent=2, sort_keys=False, allow_nan=False)
    except ValueError:
        bad = _refuse_nonfinite(obj) or "a value"
        raise BodyvibError(
            f"{os.fspath(path)}: {bad} is not a finite number; JSON cannot hold "
            "NaN or Infinity, nothing written"
        ) from None
    atomic_write_text(path, text + "\n")
