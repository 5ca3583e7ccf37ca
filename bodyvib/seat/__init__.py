"""Measured seat vibration: reading a seat-pan acceleration and what it does at the head.

:mod:`~bodyvib.seat.signal` reads a uniformly sampled vertical seat acceleration
from CSV or ASAM MDF4 (``asammdf``), with any other axes of the seated person measured
beside it (by standard names or a mapping), and refuses, with one line each, what the
figures cannot take (non-uniform or decreasing time, NaN, a missing channel, a
rate below 80 Hz, a record under 1 s); :mod:`~bodyvib.seat.response` runs it
through body models exactly (the transmissibility acts on acceleration as on
displacement) and gives the ISO 2631-1 figures of seat and head.

Import from the package (``from bodyvib.seat import respond``): the names in ``__all__``
are its public interface, and the modules that hold them are internal and may move.
"""

from bodyvib._lazy import lazy_exports

_MODULES = {
    "response": ("DEFAULT_MODELS", "BodyResponse", "Response", "head_acceleration", "respond"),
    "signal": (
        "AXES",
        "MIN_DURATION_S",
        "MIN_RATE_HZ",
        "UNIFORM_TOLERANCE",
        "SeatSignal",
        "assign_channels",
        "check_signal",
        "parse_channels",
        "read_csv_signal",
        "read_mdf_signal",
        "read_signal",
    ),
}

__all__, __getattr__, __dir__ = lazy_exports(__name__, _MODULES)
