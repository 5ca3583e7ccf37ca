"""A user's measured seat-to-head transmissibility, read from CSV and checked.

The file is plain CSV with a header row naming the columns::

    frequency_hz,modulus,phase_deg
    0.5,1.003,-0.9
    0.63,1.005,-1.2
    ...

``frequency_hz`` (Hz, strictly increasing, positive) and ``modulus``
(``|X_head / X_seat|``, dimensionless, not negative) are required;
``phase_deg`` (degrees, negative when the head lags the seat) is optional.
Further columns are ignored; blank lines and lines starting with ``#`` are
skipped. Every problem (a missing or doubled column, a value that is not a number,
a NaN, a frequency that does not increase or is above :data:`MAX_FREQUENCY_HZ`, a
negative modulus, one above
:data:`MAX_MODULUS`, all moduli zero, too few rows) is a
:class:`~bodyvib.runtime.errors.BodyvibError` naming the line and the fix.

The GA refit (:mod:`bodyvib.fit.objective`) fits the reduced model to such data: to the
complex transmissibility when the phase is given, to the modulus alone when
it is not.
"""

import csv
import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..runtime.errors import BodyvibError
from ..runtime.inputfile import check_input_file

__all__ = [
    "MIN_ROWS",
    "MAX_MODULUS",
    "MAX_FREQUENCY_HZ",
    "MeasuredTransmissibility",
    "read_transmissibility_csv",
    "write_transmissibility_csv",
]

#: Fewest data rows accepted: the reduced model has six free ratios.
MIN_ROWS = 8

#: Largest modulus accepted. A seated body's seat-to-head ``|T|`` stays below about 3; a value
#: above this is not a transmissibility ratio (a percentage, a force, a wrong column).
MAX_MODULUS = 100.0

#: Highest frequency accepted, Hz. Whole-body vibration is measured up to 80 Hz (ISO 2631-1)
#: and the reduced model's fastest pole is at 40 Hz; far beyond, the model's terms
#: ((2 pi f)^2 m) overflow (1e308 Hz made the fit fail inside scipy). A frequency above
#: this is not a seated body's transmissibility (kHz for Hz, a wrong column).
MAX_FREQUENCY_HZ = 1000.0

_REQUIRED = ("frequency_hz", "modulus")
_OPTIONAL = ("phase_deg",)


@dataclass(frozen=True)
class MeasuredTransmissibility:
    """Seat-to-head transmissibility at discrete frequencies.

    Attributes
    ----------
    frequency_hz : ndarray
        Strictly increasing positive frequencies, Hz.
    modulus : ndarray
        ``|T|`` (dimensionless, >= 0).
    phase_deg : ndarray or None
        Phase of ``T`` in degrees, or None when only the modulus was measured.
    source : str
        Where the data came from (file path), for messages and provenance.
    """

    frequency_hz: np.ndarray
    modulus: np.ndarray
    phase_deg: Optional[np.ndarray] = None
    source: str = "<data>"

    @property
    def has_phase(self) -> bool:
        """True when the phase was measured (the fit then uses the complex value)."""
        return self.phase_deg is not None

    def complex(self) -> np.ndarray:
        """The complex transmissibility ``|T| e^{j phase}``.

        Raises
        ------
        BodyvibError
            If the data have no phase.
        """
        if self.phase_deg is None:
            raise BodyvibError(f"{self.source}: no phase_deg column, only the modulus is known")
        return self.modulus * np.exp(1j * np.radians(self.phase_deg))


def _parse_number(text: str, where: str, column: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise BodyvibError(f"{where}: {column} = {text!r} is not a number") from None
    if math.isnan(value) or math.isinf(value):
        raise BodyvibError(
            f"{where}: {column} is {text.strip()}; every value must be a finite number "
            "(remove or repair that row)"
        )
    return value


def read_transmissibility_csv(path) -> MeasuredTransmissibility:
    """Read and validate a measured transmissibility CSV file.

    Parameters
    ----------
    path : str or os.PathLike
        CSV file with a header row: ``frequency_hz,modulus[,phase_deg]``.

    Returns
    -------
    MeasuredTransmissibility

    Raises
    ------
    BodyvibError
        Unreadable file or not a regular one, no header, a missing required column, a column named
        twice, a non-numeric or non-finite value, a non-positive or
        non-increasing frequency, a negative modulus or one above
        :data:`MAX_MODULUS`, every modulus zero, or fewer than
        :data:`MIN_ROWS` rows.

    Examples
    --------
    >>> import os, pathlib, tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = os.path.join(d, "t.csv")
    ...     _ = pathlib.Path(p).write_text("frequency_hz,modulus\\n" + "".join(
    ...         f"{f},{1 + f / 100}\\n" for f in range(1, 11)))
    ...     m = read_transmissibility_csv(p)
    >>> m.frequency_hz[:3], m.has_phase
    (array([1., 2., 3.]), False)
    """
    src = check_input_file(path, "measured data")  # a FIFO would wait for a writer
    lines, rows, header = _read_rows(src)
    data = _columns(src, lines, rows, header)
    return _checked_transmissibility(src, data, [ln for ln, _ in lines[1:]])


def _read_rows(src):
    """The file's numbered non-comment lines, their CSV rows and the header (lower case)."""
    try:
        with open(src, newline="", encoding="utf-8-sig") as f:
            lines = [
                (i, ln)
                for i, ln in enumerate(f, start=1)
                if ln.strip() and not ln.lstrip().startswith("#")
            ]
    except OSError as exc:
        raise BodyvibError(f"cannot read measured data '{src}': {exc.strerror}") from None
    except UnicodeDecodeError:
        raise BodyvibError(f"{src}: not a text (UTF-8) CSV file") from None
    if not lines:
        raise BodyvibError(
            f"{src}: empty file; expected a header row "
            "'frequency_hz,modulus[,phase_deg]' and data rows"
        )
    rows = list(csv.reader([ln for _, ln in lines]))
    header = [h.strip().lower() for h in rows[0]]
    missing = [c for c in _REQUIRED if c not in header]
    if missing:
        raise BodyvibError(
            f"{src}: line {lines[0][0]}: missing column(s) {', '.join(missing)}; the header row "
            f"must name the columns frequency_hz, modulus and optionally phase_deg "
            f"(found: {', '.join(header) or 'nothing'})"
        )
    twice = sorted({h for h in header if h and header.count(h) > 1})
    if twice:
        raise BodyvibError(
            f"{src}: line {lines[0][0]}: column(s) {', '.join(twice)} named more "
            "than once; which one holds the data is ambiguous: rename or remove "
            "the extra column"
        )
    return lines, rows, header


def _columns(src, lines, rows, header):
    """Column name -> the numbers of its data rows."""
    cols = {c: header.index(c) for c in _REQUIRED + _OPTIONAL if c in header}
    data = {c: [] for c in cols}
    for (lineno, _), row in zip(lines[1:], rows[1:]):
        where = f"{src}: line {lineno}"
        if len(row) < len(header):
            raise BodyvibError(
                f"{where}: {len(row)} value(s), the header names {len(header)} columns"
            )
        for c, j in cols.items():
            data[c].append(_parse_number(row[j], where, c))
    return data


def _checked_transmissibility(src, data, data_lines):
    """The measured transmissibility once its rows, frequencies and moduli pass."""
    n = len(data["frequency_hz"])
    if n < MIN_ROWS:
        raise BodyvibError(
            f"{src}: {n} data row(s); at least {MIN_ROWS} are needed to fit the "
            "reduced model's six free ratios"
        )
    f = np.array(data["frequency_hz"])
    mod = np.array(data["modulus"])
    if f[0] <= 0:
        raise BodyvibError(
            f"{src}: line {data_lines[0]}: frequency_hz = {f[0]:g} must be positive (Hz)"
        )
    bad = np.nonzero(np.diff(f) <= 0)[0]
    if bad.size:
        k = int(bad[0]) + 1
        raise BodyvibError(
            f"{src}: line {data_lines[k]}: frequency_hz = {f[k]:g} does not increase "
            f"(previous row {f[k - 1]:g}); sort the rows by frequency and remove duplicates"
        )
    if f[-1] > MAX_FREQUENCY_HZ:
        k = int(np.nonzero(f > MAX_FREQUENCY_HZ)[0][0])
        raise BodyvibError(
            f"{src}: line {data_lines[k]}: frequency_hz = {f[k]:g} is above "
            f"{MAX_FREQUENCY_HZ:g} Hz; a seated body's transmissibility is measured up to "
            "about 80 Hz: give frequencies in Hz and drop rows beyond"
        )
    neg = np.nonzero(mod < 0)[0]
    if neg.size:
        k = int(neg[0])
        raise BodyvibError(
            f"{src}: line {data_lines[k]}: modulus = {mod[k]:g} is negative; the modulus "
            "|X_head/X_seat| is >= 0 (put the sign into phase_deg)"
        )
    big = np.nonzero(mod > MAX_MODULUS)[0]
    if big.size:
        k = int(big[0])
        raise BodyvibError(
            f"{src}: line {data_lines[k]}: modulus = {mod[k]:g} is not a plausible seat-to-head "
            f"transmissibility (at most {MAX_MODULUS:g}; a seated body's stays below about 3): "
            "give |X_head/X_seat| as a ratio, not in percent or dB"
        )
    if not np.any(mod > 0):
        raise BodyvibError(
            f"{src}: every modulus is 0 (the head never moves); a seat-to-head "
            "transmissibility is about 1 at low frequency: check the modulus column"
        )
    phase = np.array(data["phase_deg"]) if "phase_deg" in data else None
    return MeasuredTransmissibility(f, mod, phase, src)


def write_transmissibility_csv(path, frequency_hz, modulus, phase_deg=None) -> None:
    """Write a transmissibility CSV file that :func:`read_transmissibility_csv` reads.

    Parameters
    ----------
    path : str or os.PathLike
        Destination (written atomically).
    frequency_hz, modulus : array_like
        Frequencies in Hz and ``|T|``.
    phase_deg : array_like, optional
        Phase in degrees.
    """
    from ..process.outputs import atomic_write_text

    cols = [np.asarray(frequency_hz, float), np.asarray(modulus, float)]
    header = "frequency_hz,modulus"
    if phase_deg is not None:
        cols.append(np.asarray(phase_deg, float))
        header += ",phase_deg"
    lines = [header] + [",".join(repr(float(v)) for v in row) for row in zip(*cols)]
    atomic_write_text(path, "\n".join(lines) + "\n")
