"""Serialized FMU states with a checksum: a flipped bit is refused, never restored.

``fmi2SerializeFMUstate`` of a pythonfmu FMU writes its state as JSON; a host may store
the bytes on disk or send them over a network. JSON alone would take a flipped bit in a
digit for a valid state with a changed value, so :func:`pack_state` prefixes the JSON with a magic tag and its SHA-256 digest;
:func:`unpack_state` refuses bytes whose tag or digest does not match, so every change of
a bit anywhere (tag, digest or JSON) is refused.

Part of the FMU run-time: standard library only.
"""

import hashlib
import json

from .errors import BodyvibError

__all__ = ["MAGIC", "pack_state", "unpack_state"]

#: First bytes of a serialized bodyvib state (format version 1).
MAGIC = b"bodyvib-state-1\n"

_DIGEST = 32  # SHA-256, bytes


def pack_state(state: dict) -> bytes:
    """Bytes of a state: :data:`MAGIC`, the SHA-256 digest of the JSON, the JSON.

    Parameters
    ----------
    state : dict
        A JSON-serializable state (:meth:`bodyvib.runtime.engine.FmuCore.get_state`).

    Returns
    -------
    bytes
        What ``fmi2SerializeFMUstate`` hands the host; :func:`unpack_state` reads it.

    Examples
    --------
    >>> unpack_state(pack_state({"time": 0.5}))
    {'time': 0.5}
    """
    payload = json.dumps(state, allow_nan=True).encode("utf-8")
    return MAGIC + hashlib.sha256(payload).digest() + payload


def unpack_state(data: bytes) -> dict:
    """The state packed by :func:`pack_state`, checked.

    Parameters
    ----------
    data : bytes
        What the host stored of :func:`pack_state`'s bytes (``fmi2DeSerializeFMUstate``).

    Returns
    -------
    dict
        The state as it was packed.

    Raises
    ------
    BodyvibError
        Not a bodyvib state (no tag), a digest that does not match (the bytes were
        changed: a flipped bit, a truncation), or JSON that does not parse.

    Examples
    --------
    >>> data = bytearray(pack_state({"time": 0.5}))
    >>> data[-3] ^= 1
    >>> unpack_state(bytes(data))
    Traceback (most recent call last):
    ...
    bodyvib.runtime.errors.BodyvibError: serialized FMU state refused: its checksum does not match (the bytes were changed or truncated)
    """
    data = bytes(data)
    if not data.startswith(MAGIC):
        raise BodyvibError(
            "serialized FMU state refused: not a bodyvib FMU state (its tag is missing)"
        )
    digest, payload = data[len(MAGIC) : len(MAGIC) + _DIGEST], data[len(MAGIC) + _DIGEST :]
    if len(digest) != _DIGEST or hashlib.sha256(payload).digest() != digest:
        raise BodyvibError(
            "serialized FMU state refused: its checksum does not match (the "
            "bytes were changed or truncated)"
        )
    try:
        return json.loads(payload.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        raise BodyvibError("serialized FMU state refused: not JSON") from None
