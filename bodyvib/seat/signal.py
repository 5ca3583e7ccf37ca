"""Measured seat-pan vertical acceleration: reading (CSV, ASAM MDF4) and the checks it must pass.

A :class:`SeatSignal` is a uniformly sampled acceleration record in m/s2. It
comes from

* a CSV file: a header row of column names, one of them the time (``time``,
  ``t``, or a name starting with ``time``, optionally with a unit such as
  ``time [s]``), the acceleration in another (``channel``, or the only other
  column); ``#`` lines are comments;
* an ASAM MDF4 file (``.mf4``/``.mdf``), read through ``asammdf``: the channel
  named ``channel`` with its own time stamps.

:func:`check_signal` refuses, each with one line naming the problem and the
fix, what the exact response and the ISO 2631-1 figures cannot take: time
that does not increase or is not uniform (steps varying by more than
:data:`UNIFORM_TOLERANCE`), NaN or infinite samples, a sampling rate below
:data:`MIN_RATE_HZ` (Wk weights the seat's vertical vibration up to its
100 Hz band limit; at 80 Hz the record holds up to 40 Hz, where Wk has fallen
to 0.41 of its plateau, and the weighted energy above that is a few per cent
for seat signals of road vehicles; below it the figures would miss the
a-v transition), and a record shorter than :data:`MIN_DURATION_S` (the MTVV's
1 s window).
"""

import contextlib
import csv
import gc
import logging
import os
import sys
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..process import interrupts
from ..process.extras import require
from ..process.units import ACCELERATION_UNITS, TIME_UNITS, split_unit, unit_scale
from ..runtime.errors import BodyvibError
from ..runtime.inputfile import check_input_file

__all__ = [
    "MIN_RATE_HZ",
    "MIN_DURATION_S",
    "UNIFORM_TOLERANCE",
    "MAX_ACCELERATION",
    "SeatSignal",
    "check_signal",
    "read_csv_signal",
    "read_mdf_signal",
    "read_signal",
]

#: Lowest sampling rate accepted, Hz.
MIN_RATE_HZ = 80.0
#: Shortest record accepted, s (the MTVV's running-r.m.s. window).
MIN_DURATION_S = 1.0
#: Largest relative deviation of a time step from the mean step.
UNIFORM_TOLERANCE = 1e-3
#: Largest seat acceleration accepted, m/s2 (chosen: about 100,000 g, a thousand times a
#: crash pulse; a larger value is a unit or file error, and at 1e76 m/s2 the fourth powers of
#: the VDV would overflow).
MAX_ACCELERATION = 1e6
#: File extensions read as ASAM MDF.
MDF_EXTENSIONS = (".mf4", ".mdf")


@dataclass(frozen=True)
class SeatSignal:
    """A uniformly sampled seat acceleration.

    Attributes
    ----------
    time : ndarray
        s, starting wherever the record starts.
    acceleration : ndarray
        m/s2.
    fs : float
        Sampling rate, Hz (from the mean step).
    name : str
        Where it came from (file and channel).
    """

    time: np.ndarray
    acceleration: np.ndarray
    fs: float
    name: str = "seat acceleration"

    @property
    def duration(self) -> float:
        """Record length ``(n - 1) / fs``, s."""
        return (self.acceleration.size - 1) / self.fs


def check_signal(time, acceleration, name: str = "seat acceleration") -> SeatSignal:
    """Check a record and return it as a :class:`SeatSignal`.

    Parameters
    ----------
    time : (n,) array_like
        Sample times in s, increasing and uniform within 0.1 %.
    acceleration : (n,) array_like
        Seat vertical acceleration in m/s2, one sample per time, all finite.
    name : str
        Label, used in the messages.

    Returns
    -------
    SeatSignal
        The record as float arrays, its rate ``fs`` from the mean step.

    Raises
    ------
    BodyvibError
        Mismatched lengths, NaN or infinite values, an acceleration beyond
        :data:`MAX_ACCELERATION`, time that does not increase or is not uniform, a
        sampling rate below 80 Hz, a record shorter than 1 s.

    Examples
    --------
    >>> t = np.arange(0, 2, 1e-3)
    >>> check_signal(t, np.sin(t)).fs
    1000.0
    """
    t = np.asarray(time, dtype=float).ravel()
    a = np.asarray(acceleration, dtype=float).ravel()
    if t.size != a.size:
        raise BodyvibError(f"{name}: {t.size} times but {a.size} samples")
    if t.size < 3:
        raise BodyvibError(f"{name}: {t.size} samples; a record needs at least 1 s of them")
    for what, v in (("time", t), ("acceleration", a)):
        bad = ~np.isfinite(v)
        if bad.any():
            k = int(np.argmax(bad))
            at = f"t = {t[k]:g} s" if np.isfinite(t[k]) else f"sample {k}"
            raise BodyvibError(
                f"{name}: {what} is NaN or infinite at {at} (sample {k}); "
                "cut the record or fill the gap"
            )
    big = np.abs(a) > MAX_ACCELERATION
    if big.any():
        k = int(np.argmax(big))
        raise BodyvibError(
            f"{name}: acceleration {a[k]:g} m/s2 at t = {t[k]:g} s (sample {k}) is beyond "
            f"{MAX_ACCELERATION:g} m/s2; the values must be in m/s2: check the units"
        )
    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.argmax(dt <= 0))
        raise BodyvibError(
            f"{name}: time does not increase at sample {k + 1} "
            f"({t[k]:g} s then {t[k + 1]:g} s); sort or cut the record"
        )
    h = (t[-1] - t[0]) / (t.size - 1)
    dev = float(np.max(np.abs(dt - h)))
    if dev > UNIFORM_TOLERANCE * h:
        raise BodyvibError(
            f"{name}: time is not uniformly sampled (steps from {dt.min():.6g} to "
            f"{dt.max():.6g} s, more than {100 * UNIFORM_TOLERANCE:g} % apart); "
            "resample it to a constant rate"
        )
    fs = 1.0 / h
    if fs < MIN_RATE_HZ:
        raise BodyvibError(
            f"{name}: sampled at {fs:.4g} Hz, below the {MIN_RATE_HZ:g} Hz the Wk "
            "weighting needs; record at a higher rate"
        )
    if (t.size - 1) * h < MIN_DURATION_S:
        raise BodyvibError(
            f"{name}: {(t.size - 1) * h:.3g} s long, shorter than the "
            f"{MIN_DURATION_S:g} s the figures need (MTVV window)"
        )
    return SeatSignal(time=t, acceleration=a, fs=float(fs), name=name)


def _is_time(header: str) -> bool:
    h = header.strip().lower()
    return h.startswith("time") or split_unit(h, TIME_UNITS)[0] == "t"


def _column_name(header: str) -> str:
    """A header without its unit: ``"seat_z [m/s2]"`` -> ``"seat_z"``, ``"acc_g"`` -> ``"acc"``."""
    return split_unit(header, ACCELERATION_UNITS)[0]


def _column_scale(path, header: str, units, what: str, default: str) -> float:
    """The factor to SI of the unit a column's header names (``default`` if it names none)."""
    unit = split_unit(header, units)[1]
    try:
        return unit_scale(default if unit is None else unit, units, what)
    except BodyvibError as exc:
        raise BodyvibError(f"{path}: column '{header}': {exc}") from None


def _data_lines(f):
    """The lines of a CSV file but its comments, a safe point for a signal every 16384 lines."""
    for i, line in enumerate(f):
        if not i & 16383:
            interrupts.check()
        if not line.lstrip().startswith("#"):
            yield line


def read_csv_signal(path, channel: Optional[str] = None) -> SeatSignal:
    """A seat acceleration from a CSV file with a time column.

    Parameters
    ----------
    path : str or os.PathLike
        A CSV file: ``#`` comment lines, a header row with a time column (``time``,
        ``t``, ``t [s]``, ``time_ms``: in s unless its header names another unit of
        :data:`~bodyvib.process.units.TIME_UNITS`), then one row of numbers per sample.
        The acceleration is in m/s2 unless its header names another unit of
        :data:`~bodyvib.process.units.ACCELERATION_UNITS` (``acc_g``, ``seat [g]``:
        multiplied by 9.80665, and the record's name says so).
    channel : str, optional
        Name of the acceleration column (with or without its unit); needed when
        the file has more than one column besides the time.

    Returns
    -------
    SeatSignal
        The column against the time column, named ``path:column``.

    Raises
    ------
    BodyvibError
        No header or time column, a missing or ambiguous column, a unit a header
        names that is not one of its quantity, a cell that is not a number, and
        everything :func:`check_signal` refuses.
    """
    path = check_input_file(path, "signal file")
    with open(path, newline="", encoding="utf-8") as f:
        rows = [r for r in csv.reader(_data_lines(f)) if r and any(c.strip() for c in r)]
    if not rows:
        raise BodyvibError(f"{path}: empty file; expected a header row and samples")
    header = [h.strip() for h in rows[0]]
    times = [i for i, h in enumerate(header) if _is_time(h)]
    if not times:
        raise BodyvibError(
            f"{path}: no time column in the header ({', '.join(header)}); name one 'time' (in s)"
        )
    ti = times[0]
    others = [i for i in range(len(header)) if i != ti]
    if channel is not None:
        found = [i for i in others if channel.strip() in (header[i], _column_name(header[i]))]
        if not found:
            raise BodyvibError(
                f"{path}: no column '{channel}'; columns are {', '.join(header[i] for i in others)}"
            )
        ci = found[0]
    elif len(others) == 1:
        ci = others[0]
    else:
        raise BodyvibError(
            f"{path}: {len(others)} signal columns "
            f"({', '.join(header[i] for i in others)}); choose one with channel=NAME",
            parameters=("channel",),
        )
    data = np.empty((len(rows) - 1, 2))
    for k, r in enumerate(rows[1:]):
        if not k & 16383:
            interrupts.check()  # a long record: a safe point every few tens of ms
        try:
            data[k] = float(r[ti]), float(r[ci])
        except (ValueError, IndexError):
            raise BodyvibError(
                f"{path}: line {k + 2} is not two numbers in columns "
                f"'{header[ti]}' and '{header[ci]}' (truncated file?)"
            ) from None
    t_scale = _column_scale(path, header[ti], TIME_UNITS, "time", "s")
    a_scale = _column_scale(path, header[ci], ACCELERATION_UNITS, "acceleration", "m/s2")
    name = f"{path}:{_column_name(header[ci])}"
    if a_scale != 1.0:  # said where the record is named: in the report and the JSON
        unit = split_unit(header[ci], ACCELERATION_UNITS)[1]
        name += f" (in {unit}, x {a_scale:g} to m/s2)"
    return check_signal(data[:, 0] * t_scale, data[:, 1] * a_scale, name)


@contextlib.contextmanager
def _quiet_reader(logger: str):
    """Silence a reader library's logger and the errors of its half-built objects' ``__del__``
    (which Python would print as "Exception ignored in ...") inside the block."""
    log = logging.getLogger(logger)
    level, hook = log.level, sys.unraisablehook
    log.setLevel(logging.CRITICAL + 1)
    sys.unraisablehook = lambda unraisable: None
    try:
        yield
    finally:
        gc.collect()  # a reader left in reference cycles is finalized here, still silent
        sys.unraisablehook = hook
        log.setLevel(level)


def _open_mdf(MDF, path: str):
    """``asammdf.MDF(path)``, or one BodyvibError: a truncated or corrupt file makes asammdf
    log an error and leave a half-built reader whose ``__del__`` fails, both silenced here."""
    with _quiet_reader("asammdf"):
        try:
            return MDF(path)
        except Exception as exc:  # asammdf raises many kinds on a bad file
            reason = str(exc)
    # raised outside the except block: the failed reader, held by the traceback, is gone
    raise BodyvibError(f"{path}: not a readable MDF file ({reason})")


def read_mdf_signal(path, channel: Optional[str]) -> SeatSignal:
    """A seat acceleration from an ASAM MDF file (``asammdf``), one channel with its time stamps.

    Parameters
    ----------
    path : str or os.PathLike
        An ASAM MDF file (``.mf4``, ``.mdf``).
    channel : str
        Channel name: the acceleration in the channel's unit, one of
        :data:`~bodyvib.process.units.ACCELERATION_UNITS` (converted to m/s2, the
        record's name saying so) or none (m/s2).

    Returns
    -------
    SeatSignal
        The channel at its time stamps, named ``path:channel``.

    Raises
    ------
    BodyvibError
        No channel given or none of that name (the file's channels are listed),
        a file asammdf cannot read, and everything :func:`check_signal` refuses.
    """
    require("reading an MDF4 file", "mdf")
    from asammdf import MDF

    path = check_input_file(path, "signal file")
    mdf = _open_mdf(MDF, path)
    try:
        names = sorted(n for n in mdf.channels_db if not n.lower().startswith("time") and n != "t")
        if channel is None:
            raise BodyvibError(
                f"{path}: choose a channel with channel=NAME; channels are {', '.join(names)}",
                parameters=("channel",),
            )
        if channel not in mdf.channels_db:
            raise BodyvibError(f"{path}: no channel '{channel}'; channels are {', '.join(names)}")
        try:
            sig = mdf.get(channel)
        except Exception as exc:
            raise BodyvibError(
                f"{path}: channel '{channel}' cannot be read ({exc}); if "
                "the name occurs in several groups, rename it"
            ) from None
        t = np.asarray(sig.timestamps, dtype=float)
        a = np.asarray(sig.samples, dtype=float)
        unit = str(getattr(sig, "unit", "") or "").strip()
    finally:
        mdf.close()
    name = f"{path}:{channel}"
    scale = 1.0
    if unit:  # the channel's own unit, read as a CSV header's (none: m/s2)
        try:
            scale = unit_scale(unit, ACCELERATION_UNITS, "acceleration")
        except BodyvibError as exc:
            raise BodyvibError(f"{name}: {exc}") from None
    if scale != 1.0:
        name += f" (in {unit}, x {scale:g} to m/s2)"
    return check_signal(t, a * scale, name)


def read_signal(path, channel: Optional[str] = None) -> SeatSignal:
    """A seat acceleration from a CSV or an MDF file (by extension).

    Parameters
    ----------
    path : str or os.PathLike
        ``.mf4`` or ``.mdf`` is read as MDF, anything else as CSV.
    channel : str, optional
        Column (CSV) or channel (MDF) name.

    Returns
    -------
    SeatSignal
        As :func:`read_csv_signal` or :func:`read_mdf_signal` returns it.

    Raises
    ------
    BodyvibError
        See :func:`read_csv_signal` and :func:`read_mdf_signal`.
    OSError
        An unreadable file.
    """
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext in MDF_EXTENSIONS:
        return read_mdf_signal(path, channel)
    return read_csv_signal(path, channel)
