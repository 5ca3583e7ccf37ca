"""Measured seat vibration: reading (CSV, ASAM MDF4) and the checks it must pass.

A :class:`SeatSignal` is a uniformly sampled seat-pan vertical acceleration record in
m/s2, with any other measured axes of the seated person beside it (:data:`AXES`). It
comes from

* a CSV file: a header row of column names, one of them the time (``time``,
  ``t``, or a name starting with ``time``, optionally with a unit such as
  ``time [s]``), the acceleration in another (``channel``, ``seat_z``, or the only
  other column); ``#`` lines are comments;
* an ASAM MDF4 file (``.mf4``/``.mdf``), read through ``asammdf``: the channels
  with their own time stamps, which must be the same for every axis.

The axes are found by one naming rule (:func:`assign_channels`): a column or
channel named as an axis of ISO 2631-1 (``seat_x``, ``seat_y``, ``seat_z``,
``seat_rx``, ``seat_ry``, ``seat_rz``, ``backrest_x`` ... ``feet_z``) holds that
axis; a mapping (``channels={"seat_z": "AccZ", "seat_x": "AccX"}``, on the command
line ``--channels seat_z=AccZ,seat_x=AccX``) names the others.

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
from dataclasses import dataclass, field, replace
from typing import Dict, Mapping, Optional, Sequence

import numpy as np

from ..comfort.axes import SEATED_AXES
from ..process import interrupts
from ..process.extras import require
from ..process.units import (
    ACCELERATION_UNITS,
    ANGULAR_ACCELERATION_UNITS,
    TIME_UNITS,
    split_unit,
    unit_scale,
)
from ..runtime.errors import BodyvibError
from ..runtime.inputfile import check_input_file

__all__ = [
    "MIN_RATE_HZ",
    "MIN_DURATION_S",
    "UNIFORM_TOLERANCE",
    "MAX_ACCELERATION",
    "AXES",
    "SeatSignal",
    "parse_channels",
    "assign_channels",
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
#: The standard names of a record's channels: the axes of a seated person as
#: :data:`bodyvib.comfort.SEATED_AXES` names them, the point, an underscore and the axis
#: (``seat_x``, ``seat_y``, ``seat_z``, the seat's rotations ``seat_rx``, ``seat_ry``,
#: ``seat_rz``, ``backrest_x`` ... ``feet_z``).
AXES = tuple(SEATED_AXES)
#: The axis that drives the occupant: the seat surface's vertical acceleration.
Z_AXIS = "seat_z"
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
    axes : dict of str to ndarray
        The record's other axes (keys of :data:`AXES` but ``seat_z``), at the same
        sample times, in m/s2 (rotations in rad/s2); empty for a vertical record.
    channels : dict of str to str
        Axis -> where it came from (file and channel), ``seat_z`` included; empty for a
        record not read from a file.
    """

    time: np.ndarray
    acceleration: np.ndarray
    fs: float
    name: str = "seat acceleration"
    axes: Dict[str, np.ndarray] = field(default_factory=dict)
    channels: Dict[str, str] = field(default_factory=dict)

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


def _units(axis: str):
    """The units, quantity and SI unit of an axis's channel (a rotation's are angular)."""
    if SEATED_AXES[axis][3] == "rad/s2":
        return ANGULAR_ACCELERATION_UNITS, "angular acceleration", "rad/s2"
    return ACCELERATION_UNITS, "acceleration", "m/s2"


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


def _check_channels(channels: Optional[Mapping[str, str]]) -> Dict[str, str]:
    """A mapping of axes to channels, its axes checked against :data:`AXES`."""
    out = {}
    for axis, name in (channels or {}).items():
        if axis not in SEATED_AXES:
            raise BodyvibError(
                f"unknown axis '{axis}' in channels=AXIS=NAME; the axes are {', '.join(AXES)}",
                parameters=("channels",),
            )
        out[axis] = str(name).strip()
    return out


def parse_channels(text: str) -> Dict[str, str]:
    """A mapping of axes to channels from ``"seat_z=AccZ,seat_x=AccX"``.

    Parameters
    ----------
    text : str
        Comma-separated ``AXIS=CHANNEL`` pairs, each axis one of :data:`AXES`.

    Returns
    -------
    dict of str to str
        Axis -> channel (column) name.

    Raises
    ------
    BodyvibError
        A pair without ``=``, an unknown or repeated axis.

    Examples
    --------
    >>> parse_channels("seat_z=AccZ, seat_x=AccX")
    {'seat_z': 'AccZ', 'seat_x': 'AccX'}
    """
    out: Dict[str, str] = {}
    for item in str(text).split(","):
        axis, eq, name = (p.strip() for p in item.partition("="))
        if not eq or not axis or not name:
            raise BodyvibError(
                f"channels=AXIS=NAME,...: '{item.strip()}' is not AXIS=NAME "
                f"(e.g. seat_z=AccZ,seat_x=AccX)",
                parameters=("channels",),
            )
        if axis in out:
            raise BodyvibError(f"axis '{axis}' mapped twice in channels", parameters=("channels",))
        out[axis] = name
    return _check_channels(out)


def assign_channels(
    path, names: Sequence[str], channel=None, channels=None, kind: str = "column"
) -> Dict[str, str]:
    """Which of a file's channels holds which axis: mapped, by standard name, or the only one.

    The naming rule: a channel (or a column, its unit aside) named as an axis of
    :data:`AXES` (``seat_x``, ``backrest_z``, ``feet_y``, ``seat_rx``) holds that axis.
    ``channels`` maps axes to other names and ``channel`` names the ``seat_z`` channel;
    a file with a single channel and no mapping holds ``seat_z``. The seat's ``seat_z``
    must be found: it drives the occupant.

    Parameters
    ----------
    path : str or os.PathLike
        The file, for the messages.
    names : sequence of str
        Its signal channels (columns: without their units), time excluded.
    channel : str, optional
        The ``seat_z`` channel.
    channels : mapping of str to str, optional
        Axis -> channel.
    kind : str
        ``"column"`` or ``"channel"``, for the messages.

    Returns
    -------
    dict of str to str
        Axis -> channel, ``seat_z`` first.

    Raises
    ------
    BodyvibError
        A mapped channel the file does not have (its channels are listed), an unknown
        axis, ``channel`` and ``channels`` naming two ``seat_z``, no ``seat_z`` found.

    Examples
    --------
    >>> assign_channels("f.csv", ["AccZ", "seat_x", "speed"], channel="AccZ")
    {'seat_z': 'AccZ', 'seat_x': 'seat_x'}
    """
    mapping = _check_channels(channels)
    if channel is not None:
        if mapping.get(Z_AXIS, channel.strip()) != channel.strip():
            raise BodyvibError(
                f"channel={channel} and channels={Z_AXIS}={mapping[Z_AXIS]} name two "
                f"{Z_AXIS} channels; give one",
                parameters=("channel", "channels"),
            )
        mapping[Z_AXIS] = channel.strip()
    listed = ", ".join(names)
    for axis, name in mapping.items():
        if name not in names:
            raise BodyvibError(f"{path}: no {kind} '{name}' (for {axis}); {kind}s are {listed}")
    used = set(mapping.values())
    for name in names:  # the naming rule: a channel named as an axis holds it
        if name in SEATED_AXES and name not in mapping and name not in used:
            mapping[name] = name
    if Z_AXIS not in mapping:
        if len(names) == 1 and not mapping:
            mapping[Z_AXIS] = names[0]
        else:
            raise BodyvibError(
                f"{path}: {len(names)} signal {kind}s ({listed}), none of them {Z_AXIS}; "
                f"choose one with channel=NAME, or name the axes with "
                f"channels={Z_AXIS}=NAME,seat_x=NAME",
                parameters=("channel", "channels"),
            )
    return {Z_AXIS: mapping.pop(Z_AXIS), **mapping}


def _axis_signal(time, samples: Mapping[str, np.ndarray], names: Mapping[str, str]) -> SeatSignal:
    """A checked record of several axes: ``seat_z`` the signal, the others beside it."""
    z = check_signal(time, samples[Z_AXIS], names[Z_AXIS])
    others = {}
    for axis, a in samples.items():
        if axis != Z_AXIS:
            others[axis] = check_signal(time, a, names[axis]).acceleration
    return replace(z, axes=others, channels=dict(names))


def read_csv_signal(path, channel: Optional[str] = None, channels=None) -> SeatSignal:
    """A seat acceleration, and any other axes, from a CSV file with a time column.

    Parameters
    ----------
    path : str or os.PathLike
        A CSV file: ``#`` comment lines, a header row with a time column (``time``,
        ``t``, ``t [s]``, ``time_ms``: in s unless its header names another unit of
        :data:`~bodyvib.process.units.TIME_UNITS`), then one row of numbers per sample.
        An acceleration is in m/s2 unless its header names another unit of
        :data:`~bodyvib.process.units.ACCELERATION_UNITS` (``acc_g``, ``seat [g]``:
        multiplied by 9.80665, and the record's name says so); a rotation (``seat_rx``)
        in rad/s2 unless it names one of
        :data:`~bodyvib.process.units.ANGULAR_ACCELERATION_UNITS`.
    channel : str, optional
        Name of the seat's vertical acceleration column (with or without its unit);
        needed when the file has more than one column besides the time and none is
        named ``seat_z``.
    channels : mapping of str to str, optional
        Axis (:data:`AXES`) -> column, for columns not named by the naming rule
        (:func:`assign_channels`).

    Returns
    -------
    SeatSignal
        The ``seat_z`` column against the time column, named ``path:column``, and the
        other axes found in ``axes``.

    Raises
    ------
    BodyvibError
        No header or time column, a missing or ambiguous column, a unit a header
        names that is not one of its quantity, a cell that is not a number (a column
        shorter than the others), and everything :func:`check_signal` refuses.
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
    names = [_column_name(header[i]) for i in others]  # a column is named without its unit
    index = dict(zip(reversed(names), reversed(others)))  # the first of a repeated name
    if channels:
        channels = {a: _column_name(str(n)) for a, n in channels.items()}
    assigned = assign_channels(
        path, names, None if channel is None else _column_name(channel), channels
    )
    cols = [ti] + [index[n] for n in assigned.values()]
    data = np.empty((len(rows) - 1, len(cols)))
    for k, r in enumerate(rows[1:]):
        if not k & 16383:
            interrupts.check()  # a long record: a safe point every few tens of ms
        try:
            data[k] = [float(r[c]) for c in cols]
        except (ValueError, IndexError):
            raise BodyvibError(
                f"{path}: line {k + 2} is not {len(cols)} numbers in columns "
                + ", ".join(f"'{header[c]}'" for c in cols)
                + " (a column shorter than the others, or a truncated file?)"
            ) from None
    t = data[:, 0] * _column_scale(path, header[ti], TIME_UNITS, "time", "s")
    samples, labels = {}, {}
    for j, (axis, name) in enumerate(assigned.items(), start=1):
        units, what, si = _units(axis)
        column = header[index[name]]
        scale = _column_scale(path, column, units, what, si)
        samples[axis] = data[:, j] * scale
        labels[axis] = f"{path}:{name}"
        if scale != 1.0:  # said where the record is named: in the report and the JSON
            labels[axis] += f" (in {split_unit(column, units)[1]}, x {scale:g} to {si})"
    return _axis_signal(t, samples, labels)


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


def _mdf_channel(mdf, path, name: str):
    """One channel's time stamps, samples and unit."""
    try:
        sig = mdf.get(name)
    except Exception as exc:
        raise BodyvibError(
            f"{path}: channel '{name}' cannot be read ({exc}); if "
            "the name occurs in several groups, rename it"
        ) from None
    t = np.asarray(sig.timestamps, dtype=float)
    return t, np.asarray(sig.samples, dtype=float), str(getattr(sig, "unit", "") or "").strip()


def _same_times(path, first, t0, name, t) -> None:
    """Refuse an axis sampled at other times than the first (``seat_z``)."""
    if t.size == t0.size:
        h = (t0[-1] - t0[0]) / max(t0.size - 1, 1)
        if np.max(np.abs(t - t0)) <= UNIFORM_TOLERANCE * h:
            return

    def rate(x):
        return f"{x.size} samples at {(x.size - 1) / (x[-1] - x[0]):.6g} Hz" if x.size > 1 else ""

    raise BodyvibError(
        f"{path}: channel '{name}' ({rate(t)}) is not sampled at the times of '{first}' "
        f"({rate(t0)}); resample the axes to one time base"
    )


def read_mdf_signal(path, channel: Optional[str] = None, channels=None) -> SeatSignal:
    """A seat acceleration, and any other axes, from an ASAM MDF file (``asammdf``).

    Parameters
    ----------
    path : str or os.PathLike
        An ASAM MDF file (``.mf4``, ``.mdf``).
    channel : str, optional
        The seat's vertical acceleration channel; needed unless a channel is named
        ``seat_z`` or the file has one channel. A channel is in its own unit, one of
        :data:`~bodyvib.process.units.ACCELERATION_UNITS` (converted to m/s2, the
        record's name saying so) or none (m/s2); a rotation's one of
        :data:`~bodyvib.process.units.ANGULAR_ACCELERATION_UNITS` or none (rad/s2).
    channels : mapping of str to str, optional
        Axis (:data:`AXES`) -> channel, for channels not named by the naming rule
        (:func:`assign_channels`). Every axis must have the time stamps of ``seat_z``.

    Returns
    -------
    SeatSignal
        The ``seat_z`` channel at its time stamps, named ``path:channel``; the other
        axes the file has are in ``axes``, on the same time stamps.

    Raises
    ------
    BodyvibError
        No channel given or none of a name (the file's channels are listed), axes
        sampled at different times, a file asammdf cannot read, and everything
        :func:`check_signal` refuses.
    """
    require("reading an MDF4 file", "mdf")
    from asammdf import MDF

    path = check_input_file(path, "signal file")
    mdf = _open_mdf(MDF, path)
    try:
        names = sorted(n for n in mdf.channels_db if not n.lower().startswith("time") and n != "t")
        assigned = assign_channels(path, names, channel, channels, kind="channel")
        read = {axis: _mdf_channel(mdf, path, name) for axis, name in assigned.items()}
    finally:
        mdf.close()
    t0 = read[Z_AXIS][0]
    samples, labels = {}, {}
    for axis, (t, a, unit) in read.items():
        _same_times(path, assigned[Z_AXIS], t0, assigned[axis], t)
        units, what, si = _units(axis)
        labels[axis] = f"{path}:{assigned[axis]}"
        scale = 1.0
        if unit:  # the channel's own unit, read as a CSV header's (none: SI)
            try:
                scale = unit_scale(unit, units, what)
            except BodyvibError as exc:
                raise BodyvibError(f"{labels[axis]}: {exc}") from None
        if scale != 1.0:
            labels[axis] += f" (in {unit}, x {scale:g} to {si})"
        samples[axis] = a * scale
    return _axis_signal(t0, samples, labels)


def read_signal(path, channel: Optional[str] = None, channels=None) -> SeatSignal:
    """A seat acceleration, and any other axes, from a CSV or an MDF file (by extension).

    Parameters
    ----------
    path : str or os.PathLike
        ``.mf4`` or ``.mdf`` is read as MDF, anything else as CSV.
    channel : str, optional
        Column (CSV) or channel (MDF) of the seat's vertical acceleration.
    channels : mapping of str to str, optional
        Axis -> column or channel (:func:`assign_channels`); the other columns or
        channels named as axes (:data:`AXES`) are read as those.

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
        return read_mdf_signal(path, channel, channels)
    return read_csv_signal(path, channel, channels)
