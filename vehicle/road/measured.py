"""Measured roads from files: OpenCRG (``.crg``), CSV longitudinal profiles and ERD files.

:func:`load_profile` reads any of them into a :class:`~bodyvib.vehicle.road.profile.ProfileRoad`
(heights in m at a uniform spacing in m from the first sample):

* **OpenCRG** ``.crg`` (ASAM OpenCRG, through ``pycrg``): the height of the road
  surface (reference line elevation and slope, banking and the elevation grid, as
  OpenCRG evaluates it with the file's modifiers) along the reference line at the
  lateral offset ``track_m`` (positive to the left), at the file's own increment
  (without a modifiers section, OpenCRG's default modifiers put the reference line's
  start at z = 0; the grid is single precision).
* **CSV** (``.csv``) and **text columns** (``.txt``, the plainest profilometer export):
  two columns, distance and elevation, separated by commas, semicolons (then a decimal
  comma is read as a point) or white space, with their units in the header
  (``distance_m,elevation_mm``; also ``distance [m]`` or ``Distance (M)``, any case) or
  given as ``units="m,mm"``. A file without a header starts with its numbers and is
  read in metres (distance and elevation) unless ``units`` says otherwise. A header with
  the columns ``elevation_left`` and ``elevation_right`` (in one unit,
  ``distance_m,elevation_left_mm,elevation_right_mm``) makes a two-track profile: each
  track of a car with left and right wheels its own column (``side``), both columns
  checked alike (as long as each other, numbers throughout).
  Lines starting with ``#`` or ``%`` are comments; a UTF-8 byte-order mark and CRLF
  line ends are read as a text editor reads them.
* **ERD** (UMTRI's text format for profiles, as RoadRuf and ProVAL write it): a
  header that starts with ``ERDFILEV2.00`` and ends with a line ``END``, then the
  samples, ``NCHAN`` numbers per row, ``NSAMP`` rows. The header gives the layout on
  its second line (comma-separated: ``NCHAN, NSAMP``, three more fields, then the
  spacing ``DELTA``) or as keyword lines (``NCHAN``, ``NSAMP``, ``DELTA``, ``START``),
  and the units (any case) as keyword lines: distance ``XUNITS`` (or ``GENUNITS``), elevation
  ``YUNITS``, ``UNITSNAM`` or ``UNITS`` (one per channel). Keyword lines are
  ``KEY, v1, v2`` or the fixed-column form, an 8-character key then the values
  (``XUNITS  m``, ``UNITSNAMmm      mm``). The first channel is read (``channel``
  chooses another); a file of exactly two channels is a two-track profile, left then
  right as ProVAL and RoadRuf write a profiler's two lines, and ``side`` chooses the
  track as for a CSV file.

Before pycrg reads an OpenCRG file, its structure is checked against what it
declares: the ``$ROAD_CRG`` block (the road's extent and increment), the
``$KD_DEFINITION`` block and the end of the header present, and the data as long as
the declared samples and channels need (a shorter payload is *truncated*, a height of
more than 10 km (higher than any road on Earth, even in absolute elevations) *corrupt*,
both with the byte offset).

The units are judged by a robust statistic, not by the steepest sample: the median
slope over 1 m steps with the mean grade removed (:data:`MAX_MEDIAN_SLOPE`). Every
road, a cobbled street with 2 cm joints or a mountain road alike, stays far below it;
heights in mm read as m (a thousand times steeper) exceed it even on a very good road.
A single steep sample (a joint, an expansion gap, a pothole's edge) is a fact the
run reports (:func:`bodyvib.vehicle.road.driven.driven_road`), not a reason to refuse
the file.

A file that cannot be driven is refused with one line naming the problem and the
fix: repeated or decreasing distances, a height that is not a number, a gap, a
spacing that is not uniform, missing or unknown units, heights implausible for their
units, a truncated or corrupt file.
"""

import math
import os
import re
from typing import List, Optional, Tuple

import numpy as np

from bodyvib.process.extras import require
from bodyvib.process.units import LENGTH_UNITS, split_unit, unit_scale
from bodyvib.runtime.errors import BodyvibError

from .profile import ProfileRoad

__all__ = [
    "load_profile",
    "TRACK_COLUMNS",
    "PROFILE_EXTENSIONS",
    "LENGTH_UNITS",
    "MAX_MEDIAN_SLOPE",
    "UNIT_BASE_M",
    "median_slope",
]

#: File extensions read as road profiles.
PROFILE_EXTENSIONS = (".crg", ".csv", ".txt", ".erd")

#: Largest median slope over :data:`UNIT_BASE_M` steps, grade removed, of a road whose
#: units are right. The steepest public roads climb 0.35 m per m, and the median change of
#: grade over a metre is far smaller (a few mm on a cobbled street, 0.05 on a hill road);
#: an ISO 8608 class A road (the smoothest, Gd(n0) = 16e-6 m^3) has differences of 1.8 mm
#: r.m.s. over 1 m, so its heights in mm read as m give a median slope of 1.2.
MAX_MEDIAN_SLOPE = 0.5

#: Step of the units' slope statistic, m: long enough that a joint or an edge is one
#: sample among many, short enough that a hill's change of grade stays small.
UNIT_BASE_M = 1.0

#: Deviation of a sample's distance from the uniform grid still taken as uniform, in
#: spacings (a printed distance rounded to a few digits).
UNIFORM_TOLERANCE = 0.01


def load_profile(
    path,
    *,
    track_m: float = 0.0,
    side: int = 0,
    units: Optional[str] = None,
    envelope: bool = False,
    channel: Optional[int] = None,
    contact: str = "point",
    periodic: bool = False,
    option: str = "units",
) -> ProfileRoad:
    """Read a measured road profile (OpenCRG, CSV, text or ERD) as a
    :class:`~bodyvib.vehicle.road.profile.ProfileRoad`.

    Parameters
    ----------
    path : str or path
        ``.crg``, ``.csv``, ``.txt`` or ``.erd`` file.
    track_m : float
        OpenCRG: lateral offset from the reference line, m (positive to the left).
    side : int
        CSV and text: the track of a two-track profile (columns ``elevation_left`` and
        ``elevation_right`` beside ``distance``): 1 or 0 the left, -1 the right; a
        one-track profile's elevation whatever the side. ERD of two channels: the first
        (1 or 0) or the second (-1). Both tracks are checked.
        OpenCRG: ``track_m`` is the track; a side names it in the messages (the left or
        right wheels of a car, at ``track_m`` plus or minus half its track width).
    units : str, optional
        CSV, text and ERD: ``"DIST,ELEV"`` units, e.g. ``"m,mm"``, when the file does not
        name them (a file that names other units is refused).
    envelope : bool
        Apply the IRI standard's 250 mm moving average.
    channel : int, optional
        ERD: the channel (profile) to read, from 1, for every side (default: the first,
        or the side's track of a two-channel file).
    contact : {"point", "tandem-cam", "mfswift-205-60R15", "auto"}
        The tire contact (:mod:`bodyvib.vehicle.road.contact`): the profile as it is, the
        effective road of the shipped tire (default shape factors, or the enveloping set
        MF-Swift measured), or the default set's effective road when the spacing is
        finer than the tire's footprint (point contact otherwise).
    periodic : bool
        The profile repeats with its length
        (:class:`~bodyvib.vehicle.road.profile.ProfileRoad`).
    option : str
        What the messages call ``units`` (listed in the error's ``parameters``).

    Returns
    -------
    ProfileRoad

    Raises
    ------
    BodyvibError
        A missing, unreadable or unsuitable file; the message names the problem and
        the fix.

    Examples
    --------
    >>> import os, pathlib, tempfile
    >>> d = tempfile.mkdtemp()
    >>> f = os.path.join(d, "p.csv")
    >>> _ = pathlib.Path(f).write_text("distance_m,elevation_mm\\n0,0\\n0.1,1\\n0.2,2\\n0.3,1\\n0.4,0\\n")
    >>> p = load_profile(f)
    >>> p.spacing, p.length, float(p.elevation[2])
    (0.1, 0.4, 0.002)
    >>> os.remove(f); os.rmdir(d)
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise BodyvibError(f"road file '{path}' does not exist")
    ext = os.path.splitext(path)[1].lower()
    base = os.path.basename(path)
    x, z, info = _read_any(path, ext, track_m, side, units, channel, option)
    spacing = _uniform(x, z, base)
    _check_units(z, spacing, base, ext == ".crg", option)
    name = base + (f" at {track_m:g} m" if ext == ".crg" else "")
    if "track" in info:
        name += f", {info['track']} track"
    return ProfileRoad(
        z,
        spacing,
        name=name,
        enveloped=envelope,
        contact=_tire(contact, spacing),
        periodic=periodic,
        info=dict(info, file=os.path.abspath(path), start_m=float(x[0])),
    )


def _read_any(path, ext, track_m, side, units, channel, option):
    """Distances and heights (m) of a road file of any kind, and what was read."""
    base = os.path.basename(path)
    if ext == ".crg":
        if units is not None:
            raise BodyvibError(
                f"road '{base}': an OpenCRG file is in metres; drop '{option}'",
                parameters=(option,),
            )
        return _read_crg(path, float(track_m), side)
    if ext in (".csv", ".txt", ".erd"):
        if track_m:
            raise BodyvibError(
                f"road '{base}': track_m applies to OpenCRG files only (a lateral offset "
                f"on a scanned surface), not to a {ext} profile",
                parameters=("track_m",),
            )
        if ext == ".erd":
            return _read_erd(path, units, channel, option, side)
        return _read_columns(path, units, option, side)
    raise BodyvibError(
        f"road '{path}': unknown kind of file '{ext}'; give an OpenCRG "
        ".crg, a .csv or .txt profile or an .erd file (or an ISO 8608 class A-H, "
        "'bump' or 'sweep')"
    )


def _tire(contact, spacing):
    """The tandem cam to drive with, or None (point contact)."""
    from .contact import CONTACTS, TIRES, load_tire

    if contact not in CONTACTS:
        raise BodyvibError(f"unknown road contact '{contact}'; use one of {', '.join(CONTACTS)}")
    if contact == "point":
        return None
    tire = load_tire(contact if contact in TIRES else "tandem-cam")
    return tire if contact != "auto" or spacing < tire.footprint_m else None


def median_slope(elevation, spacing: float, base: float = UNIT_BASE_M) -> float:
    """Median of ``|z(x + b) - z(x) - g b| / b`` over the profile: its typical slope, grade removed.

    Parameters
    ----------
    elevation : (n,) array_like
        Heights at a uniform spacing, m.
    spacing : float
        Distance between the samples, m.
    base : float
        The step b, m (rounded to whole samples; the whole profile if it is shorter).

    Returns
    -------
    float
        m per m; ``g`` is the median slope over the steps (the profile's grade, which a
        step or a pothole does not move).

    Examples
    --------
    A 1 % grade with a 20 mm step: the median ignores both.

    >>> x = np.arange(0, 20, 0.01)
    >>> round(median_slope(0.01 * x + 0.02 * (x > 10), 0.01), 6)
    0.0
    """
    z = np.asarray(elevation, dtype=float)
    k = int(min(z.size - 1, max(1, round(base / spacing))))
    d = z[k:] - z[:-k]
    return float(np.median(np.abs(d - np.median(d))) / (k * spacing))


def _check_units(elevation, spacing, base, crg, option):
    """Refuse heights whose typical slope no road has (:data:`MAX_MEDIAN_SLOPE`)."""
    typical = median_slope(elevation, spacing)
    if typical <= MAX_MEDIAN_SLOPE:
        return
    fix = (
        "an OpenCRG file holds metres: the file is corrupt or was written in other units"
        if crg
        else "the units look wrong (mm read as m?); name them in the header "
        f"(distance_m,elevation_mm) or give {option}=DIST,ELEV"
    )
    raise BodyvibError(
        f"road '{base}': the height changes by a median {typical:.3g} m per m over "
        f"{UNIT_BASE_M:g} m steps (grade removed), where roads stay below "
        f"{MAX_MEDIAN_SLOPE:g}: {fix}",
        parameters=(option,),
    )


# -- checks shared by the readers ----------------------------------------------------


def _uniform(x, z, base) -> float:
    """The profile's spacing; refuses NaN, repeated or decreasing distances, gaps, jitter."""
    x = np.asarray(x, dtype=float)
    z = np.asarray(z, dtype=float)
    if x.size < 4:
        raise BodyvibError(f"road '{base}' has {x.size} samples; a road needs at least 4")
    bad = np.flatnonzero(~np.isfinite(x) | ~np.isfinite(z))
    if bad.size:
        i = int(bad[0])
        raise BodyvibError(
            f"road '{base}': sample {i + 1} (distance {x[i]:g}) is not a number; "
            "fill the gap or cut the profile there"
        )
    d = np.diff(x)
    if np.any(d <= 0):
        i = int(np.flatnonzero(d <= 0)[0])
        what = "repeats" if d[i] == 0 else "goes back"
        raise BodyvibError(
            f"road '{base}': the distance {what} at sample {i + 2} ({x[i]:g} then "
            f"{x[i + 1]:g}); distances must increase strictly: sort the profile "
            "and drop repeated rows"
        )
    dx = float(np.median(d))
    if np.max(d) > 1.5 * dx:
        i = int(np.argmax(d))
        raise BodyvibError(
            f"road '{base}': a gap of {d[i]:g} between distances {x[i]:g} and "
            f"{x[i + 1]:g} (spacing {dx:g}); fill the gap or cut the profile there"
        )
    spacing = float((x[-1] - x[0]) / (x.size - 1))
    for digits in range(1, 10):  # as printed: 0.01, not 0.0100000002 from a float32 grid
        if abs(round(spacing, digits) - spacing) <= 1e-6 * spacing:
            spacing = round(spacing, digits)
            break
    dev = np.max(np.abs(x - (x[0] + spacing * np.arange(x.size))))
    if dev > UNIFORM_TOLERANCE * spacing:
        raise BodyvibError(
            f"road '{base}': the distances are not uniformly spaced (spacing "
            f"from {d.min():g} to {d.max():g}); resample the profile to a uniform "
            "spacing"
        )
    return spacing


def _unit(text, what, base) -> float:
    try:
        return unit_scale(text, LENGTH_UNITS, what)
    except BodyvibError as exc:
        raise BodyvibError(f"road '{base}': {exc}") from None


def _given_units(units, base, option) -> Optional[Tuple[float, float]]:
    if units is None:
        return None
    parts = [p.strip() for p in str(units).split(",")]
    if len(parts) != 2:
        raise BodyvibError(
            f"{option}='{units}' must name two units, distance and elevation, e.g. m,mm",
            parameters=(option,),
        )
    return _unit(parts[0], "distance", base), _unit(parts[1], "elevation", base)


def _scales(base, units, given, header, header_text, no_units, option) -> Tuple[float, float]:
    """The factors from a file's distance and elevation units to metres.

    Parameters
    ----------
    base : str
        The file's name, for the messages.
    units : str or None
        ``units`` as given (``"DIST,ELEV"``), for the messages.
    given : (float, float) or None
        ``units`` read by :func:`_given_units`.
    header : (str, str) or None
        The distance and elevation units the file's header names, None if it names none.
    header_text : str
        The header as a message quotes it.
    no_units : str
        What a message says when neither the header nor ``--road-units`` names the
        units (the fix ``or give OPTION m,mm`` is appended).
    option : str
        What the messages call ``units``.

    Returns
    -------
    (float, float)
        Metres per distance unit and per elevation unit: the header's, else ``given``.

    Raises
    ------
    BodyvibError
        An unknown unit in the header, ``--road-units`` disagreeing with the header, or
        units named nowhere.
    """
    if header is not None:
        scales = (_unit(header[0], "distance", base), _unit(header[1], "elevation", base))
        if given is not None and given != scales:
            raise BodyvibError(
                f"road '{base}': {option}={units} disagrees with the header "
                f"{header_text}; drop one of them",
                parameters=(option,),
            )
        return scales
    if given is None:
        raise BodyvibError(f"road '{base}': {no_units} or give {option}=m,mm", parameters=(option,))
    return given


# -- CSV and text columns -------------------------------------------------------------


def _splitter(line):
    """How a file's lines split into fields: by semicolons, commas or white space."""
    if ";" in line:
        return lambda ln: [f.strip().replace(",", ".") for f in ln.split(";")]
    if "," in line:
        return lambda ln: [f.strip() for f in ln.split(",")]
    # white space; a unit in brackets stays with its column's name ("distance [m]")
    return lambda ln: re.sub(r"\s+(?=[\[(])", "", ln).split()


#: Header names of a two-track profile's elevation columns, left then right.
TRACK_COLUMNS = ("elevation_left", "elevation_right")


def _read_columns(path, units, option, side=0):
    """Distance and elevation (m) of a CSV or text profile, and what was read.

    A header naming :data:`TRACK_COLUMNS` makes it a two-track profile: ``side`` 1 (or 0)
    reads ``elevation_left``, -1 ``elevation_right``; both columns are checked either way.
    Any other file's second column is the elevation of both tracks.
    """
    base = os.path.basename(path)
    lines = _text_lines(path)
    rows = [
        (i + 1, ln)
        for i, ln in enumerate(lines)
        if ln.strip() and not ln.lstrip().startswith(("#", "%"))
    ]
    if not rows:
        raise BodyvibError(
            f"road '{base}' is empty; a profile needs a header and rows of distance,elevation"
        )
    split = _splitter(rows[0][1])
    head = split(rows[0][1])
    given = _given_units(units, base, option)
    if _is_number(head[0]):
        # bare columns, as profilers and IRI tools export them: SI metres unless told
        # otherwise; the unit check below still catches millimetres read as metres
        given, units = (1.0, 1.0) if given is None else given, units or "m,m"
        head, data = None, rows
    else:
        data = rows[1:]
        if len(head) < 2:
            raise BodyvibError(
                f"road '{base}': the header '{rows[0][1].strip()}' needs two columns, "
                "distance and elevation"
            )
    cols = _track_columns(head, base) if head else None
    picked = [0, 1] if cols is None else [0, cols[1] if side < 0 else cols[0]]
    named = (
        [split_unit(head[i], None if cols is None else LENGTH_UNITS)[1] for i in picked]
        if head
        else [None, None]
    )
    text = f"'{','.join(head[i] for i in picked)}'" if head else "(none)"
    scales = _scales(
        base,
        units,
        given,
        (named[0], named[1]) if all(named) else None,
        text,
        f"the header {text} names no units; name them (distance_m,elevation_mm)",
        option,
    )
    values = _numbers(base, data, split, [0, 1] if cols is None else [0, *cols])
    if cols is not None:
        _check_tracks(base, head, cols, data, values)
        if len({split_unit(head[i], LENGTH_UNITS)[1] for i in cols}) > 1:
            raise BodyvibError(
                f"road '{base}': {head[cols[0]]} and {head[cols[1]]} name different units; "
                "give both tracks' elevations in one unit"
            )
    x, z = values[:, 0], values[:, 1 if cols is None or side >= 0 else 2]
    kind = "csv" if path.lower().endswith(".csv") else "text"
    info = {"format": kind, "units": text.strip("'") if all(named) else units}
    if cols is not None:
        info["track"] = "right" if side < 0 else "left"
    return x * scales[0], z * scales[1], info


def _track_columns(head, base):
    """Indices of a header's ``elevation_left`` and ``elevation_right``, or None (one track)."""
    names = [split_unit(h, LENGTH_UNITS)[0].strip().lower() for h in head]
    found = [names.index(c) if c in names else None for c in TRACK_COLUMNS]
    if found == [None, None]:
        return None
    if None in found:
        has, lacks = TRACK_COLUMNS if found[0] is not None else TRACK_COLUMNS[::-1]
        raise BodyvibError(
            f"road '{base}': the header names {has} but no {lacks} column; a two-track "
            f"profile needs both {TRACK_COLUMNS[0]} and {TRACK_COLUMNS[1]} (a single "
            "elevation column drives both tracks)"
        )
    return found


def _numbers(base, data, split, columns):
    """The rows' values in ``columns`` as a (rows, columns) array: an empty field is NaN,
    and so is a row's missing third column (a two-track row that ends early)."""
    out = np.full((len(data), len(columns)), math.nan)
    for k, (lineno, ln) in enumerate(data):
        f = split(ln)
        if len(f) < 2:
            last = k == len(data) - 1
            raise BodyvibError(
                f"road '{base}': line {lineno} has {len(f)} field(s), not {max(columns) + 1}"
                + ("; the file looks truncated: write it again" if last else "; fix the line")
            )
        try:
            out[k] = [float(f[c]) if c < len(f) and f[c] else math.nan for c in columns]
        except ValueError:
            count = "two" if len(columns) == 2 else "three"
            raise BodyvibError(
                f"road '{base}': line {lineno} '{ln.strip()}' is not {count} numbers; fix the line"
            ) from None
    return out


def _check_tracks(base, head, cols, data, values):
    """Refuse a two-track profile whose tracks differ in length or hold a NaN."""
    present = [np.flatnonzero(np.isfinite(values[:, j])) for j in (1, 2)]
    ends = [p[-1] + 1 if p.size else 0 for p in present]
    if ends[0] != ends[1]:
        short, long_ = (0, 1) if ends[0] < ends[1] else (1, 0)
        raise BodyvibError(
            f"road '{base}': {head[cols[short]]} has {ends[short]} values and "
            f"{head[cols[long_]]} {ends[long_]}; both tracks need a value at every distance"
        )
    for j in (1, 2):
        bad = np.flatnonzero(~np.isfinite(values[:, j]))
        if bad.size:
            i = int(bad[0])
            raise BodyvibError(
                f"road '{base}': {head[cols[j - 1]]} is not a number at line {data[i][0]} "
                f"(distance {values[i, 0]:g}); fill the gap in both tracks or cut the "
                "profile there"
            )


def _is_number(text) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


def _text_lines(path) -> List[str]:
    try:
        with open(path, encoding="utf-8-sig", errors="strict") as f:  # -sig: drop a BOM
            return f.read().splitlines()
    except UnicodeDecodeError:
        raise BodyvibError(
            f"road '{os.path.basename(path)}' is not a text file; give a CSV, text or ERD file"
        ) from None


# -- ERD ------------------------------------------------------------------------------


def _erd_layout(keys, layout, base):
    """``(NCHAN, NSAMP, DELTA, START)`` of an ERD header, from its layout line or its
    keyword lines (which win)."""
    nchan = nsamp = delta = None
    start = 0.0
    try:
        if layout is not None and len(layout) >= 6:
            nchan, nsamp, delta = int(float(layout[0])), int(float(layout[1])), float(layout[5])
        if "NCHAN" in keys:
            nchan = int(float(keys["NCHAN"][0]))
        if "NSAMP" in keys:
            nsamp = int(float(keys["NSAMP"][0]))
        if "DELTA" in keys:
            delta = float(keys["DELTA"][0])
        for k in ("START", "XSTART", "X0"):
            if k in keys:
                start = float(keys[k][0])
    except (ValueError, IndexError):
        raise BodyvibError(
            f"road '{base}': the ERD header's layout (NCHAN, NSAMP, DELTA) is not "
            "numbers; fix the header"
        ) from None
    if not nchan or not nsamp or not delta or nchan < 1 or nsamp < 1 or not delta > 0:
        raise BodyvibError(
            f"road '{base}': the ERD header must give NCHAN, NSAMP and a positive "
            "DELTA (on its second line or as keyword lines)"
        )
    return nchan, nsamp, delta, start


def _read_erd(path, units, channel, option, side=0):
    base = os.path.basename(path)
    lines = _text_lines(path)
    if not lines or not lines[0].strip().upper().startswith("ERDFILEV"):
        raise BodyvibError(f"road '{base}' is not an ERD file: its first line must be ERDFILEV2.00")
    try:
        end = next(i for i, ln in enumerate(lines) if ln.strip().upper() == "END")
    except StopIteration:
        raise BodyvibError(
            f"road '{base}': the ERD header has no END line; the file is "
            "truncated or not an ERD file"
        ) from None
    keys = {}
    layout = None
    for ln in lines[1:end]:
        if not ln.strip():
            continue
        if "," in ln:
            f = [p.strip() for p in ln.split(",")]
        else:  # the fixed-column form: an 8-character key, then the values
            f = [ln[:8].strip()] + ln[8:].split()
        if _is_number(f[0]) and layout is None:
            layout = [p for p in f if p]
        elif f[0]:
            keys[f[0].upper()] = f[1:]
    nchan, nsamp, delta, start = _erd_layout(keys, layout, base)
    track = None
    if channel is None:  # two channels are a profiler's left and right lines
        track = ("right" if side < 0 else "left") if nchan == 2 else None
        channel = 2 if track == "right" else 1
    if not 1 <= channel <= nchan:
        raise BodyvibError(
            f"road '{base}' has {nchan} channel(s); channel {channel} does not exist"
        )
    xu = keys.get("XUNITS") or keys.get("GENUNITS")
    yu = keys.get("YUNITS") or keys.get("UNITSNAM") or keys.get("UNITS")
    given = _given_units(units, base, option)
    yname = (yu[channel - 1] if len(yu) >= channel else yu[0]) if yu else None
    scales = _scales(
        base,
        units,
        given,
        (xu[0], yname) if xu and yu else None,
        f"(XUNITS {xu[0] if xu else ''}, YUNITS {yname})",
        "the ERD header names no units (XUNITS and YUNITS); add them",
        option,
    )
    text = " ".join(lines[end + 1 :]).replace(",", " ")
    try:
        values = np.array([float(v) for v in text.split()], dtype=float)
    except ValueError as exc:
        raise BodyvibError(
            f"road '{base}': the ERD data holds something that is not a number "
            f"({exc}); fix the file"
        ) from None
    if values.size < nchan * nsamp:
        raise BodyvibError(
            f"road '{base}' is truncated: the header promises {nsamp} samples of "
            f"{nchan} channel(s), the file holds {values.size // nchan}; write it "
            "again"
        )
    if values.size > nchan * nsamp:
        raise BodyvibError(
            f"road '{base}' holds {values.size} numbers, the header promises "
            f"{nchan * nsamp} (NCHAN x NSAMP); fix the header"
        )
    z = values.reshape(nsamp, nchan)[:, channel - 1]
    x = start + delta * np.arange(nsamp)
    return (
        x * scales[0],
        z * scales[1],
        {
            "format": "erd",
            "channel": channel,
            "units": f"{(xu or [units])[0]},{(yu or [''])[0] if yu else units}",
            **({"track": track} if track else {}),
        },
    )


# -- OpenCRG --------------------------------------------------------------------------


#: The line that ends an OpenCRG header: the data follow it.
_CRG_END = b"$$$$"

_NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")

#: Largest height an OpenCRG payload may hold, m: more is damaged data, not a road.
_CRG_MAX_HEIGHT = 1e4


def _crg_value(block, key):
    """A ``key = value`` number of a header block, or None."""
    m = re.search(rb"^\s*" + key.encode() + rb"\s*=\s*([^\s!*]+)", block, re.M | re.I)
    try:
        return float(m.group(1)) if m else None
    except ValueError:
        return None


def _crg_block(header, name):
    """The text of a header block ``$NAME`` (to the next ``$`` line), or None."""
    m = re.search(rb"^\$" + name.encode() + rb"\b[^\n]*\n(.*?)^\$", header, re.M | re.S | re.I)
    return m.group(1) if m else None


def _check_crg_extent(base, u0, u1, du):
    """Refuse a header whose start, end or increment of u is given but not finite."""
    for key, v in (
        ("reference_line_start_u", u0),
        ("reference_line_end_u", u1),
        ("reference_line_increment", du),
    ):
        if v is not None and not math.isfinite(v):
            raise BodyvibError(
                f"road '{base}' is corrupt: its header gives {key.upper()} = {v!r}, not a "
                "finite number of metres; write it again"
            )


def _check_crg_structure(path, base):
    """Refuse an OpenCRG file whose blocks or data do not match what its header declares.

    pycrg reads what it finds; a file missing its ``$ROAD_CRG`` block is read with the
    format's defaults, and a binary payload short by a few bytes is read shifted. The
    checks here: the header ends (a ``$$$$`` line), ``$ROAD_CRG`` gives the road's start,
    end and increment, ``$KD_DEFINITION`` names the format and the channels, and the data
    hold ``samples x channels`` values (4 or 8 bytes each when binary), none of them a
    height above ``_CRG_MAX_HEIGHT`` (10 km).
    """
    with open(path, "rb") as f:
        data = f.read()
    stop = data.find(_CRG_END)
    if stop < 0 and not re.search(rb"^\$(ROAD_CRG|KD_DEFINITION)", data, re.M | re.I):
        raise BodyvibError(
            f"road '{base}' is not a readable OpenCRG file (it has no $ROAD_CRG or "
            "$KD_DEFINITION block and no '$$$$' line before its data); give an OpenCRG file"
        )
    if stop < 0:
        raise BodyvibError(
            f"road '{base}' is truncated in its header (no '$$$$' line ends it, "
            f"{len(data)} bytes); write it again"
        )
    start = data.find(b"\n", stop)
    start = len(data) if start < 0 else start + 1
    header = data[:stop]
    road = _crg_block(header, "ROAD_CRG")
    if road is None:
        raise BodyvibError(
            f"road '{base}' has no $ROAD_CRG block (the road's start, end and increment); "
            "without it the file's extent is a guess: write the file again with it"
        )
    kd = _crg_block(header, "KD_DEFINITION")
    if kd is None:
        raise BodyvibError(
            f"road '{base}' has no $KD_DEFINITION block (the data format and channels); "
            "write the file again"
        )
    fmt = re.search(rb"^#:\s*([A-Z]{4})", kd, re.M)
    channels = len(re.findall(rb"^\s*D:", kd, re.M))
    u_line = re.search(rb"^\s*U:([^\n]*)", kd, re.M)
    u_stored = bool(u_line) and u_line.group(1).count(b",") < 3
    if u_stored:
        channels += 1  # u is stored as a channel of its own (distances, not heights)
    u0 = _crg_value(road, "reference_line_start_u")
    u0 = 0.0 if u0 is None else u0
    u1 = _crg_value(road, "reference_line_end_u")
    du = _crg_value(road, "reference_line_increment")
    if u_line and u_line.group(1).count(b",") >= 3 and du is None:
        try:
            du = float(u_line.group(1).split(b",")[3])
        except ValueError:
            du = None
    _check_crg_extent(base, u0, u1, du)
    if fmt is None or channels == 0 or u1 is None or not du or du <= 0 or u1 <= u0:
        raise BodyvibError(
            f"road '{base}' is corrupt: its header does not declare the data "
            "(format '#:....', 'D:' channels, reference_line_end_u and a positive "
            "reference_line_increment); write it again"
        )
    samples = int(round((u1 - u0) / du)) + 1
    code = fmt.group(1).decode()
    if code[2] == "B":  # binary: 4-byte (R) or 8-byte (D) IEEE numbers, big-endian
        width = 8 if code[1] == "D" else 4
        need = samples * channels * width
        have = len(data) - start
        padded = -(-need // 80) * 80  # writers fill the last 80-byte record
        if have < need or need < have < padded:
            need = padded if have > need else need
            raise BodyvibError(
                f"road '{base}' is truncated: its header declares {samples} samples of "
                f"{channels} channel(s), {need} bytes of data from byte offset {start}; the "
                f"file ends at byte offset {len(data)}, {need - have} bytes short; write it "
                "again"
            )
        values = np.frombuffer(
            data, dtype=">f8" if width == 8 else ">f4", count=need // width, offset=start
        )
        bad = np.flatnonzero(np.abs(values) > _CRG_MAX_HEIGHT) if not u_stored else []
        if len(bad):
            i = int(bad[0])
            raise BodyvibError(
                f"road '{base}' is corrupt: a value of {values[i]:.3g} m at byte offset "
                f"{start + i * width} (sample {i // channels + 1}); write it again"
            )
    else:  # text: count the numbers (fixed-width fields may touch: "-1.2e-03-2.5e-03")
        # (a slope or heading channel, defined between samples, may lack its last value)
        count = len(_NUMBER.findall(data[start:]))
        if count < (samples - 1) * channels + 1:
            raise BodyvibError(
                f"road '{base}' is truncated: its header declares {samples} samples of "
                f"{channels} channel(s), its data from byte offset {start} hold "
                f"{count} numbers of {samples * channels}; write it again"
            )


def _read_crg(path, track, side=0):
    base = os.path.basename(path)
    _check_crg_structure(path, base)
    require("reading an OpenCRG file", "roads")
    import pycrg

    pycrg.set_message_level(pycrg.MSG_LEVEL_NONE)
    try:
        with pycrg.DataSet.open(path) as ds:
            g = ds.grid()
            u, v = np.asarray(g.u, dtype=float), np.asarray(g.v, dtype=float)
            if not (v.min() - 1e-9 <= track <= v.max() + 1e-9):
                where = (
                    f"the car's {'left' if side > 0 else 'right'} wheels run at {track:g} m "
                    f"(track_m {'plus' if side > 0 else 'minus'} half the car's track width)"
                    if side
                    else f"track_m={track:g} m is"
                )
                raise BodyvibError(
                    f"road '{base}': {where} off the road (it spans {v.min():g} to "
                    f"{v.max():g} m from the reference line); choose a track_m that keeps "
                    + ("both of the car's tracks on it" if side else "the track on it"),
                    parameters=("track_m",),
                )
            end = (ds.header.road or {}).get("reference_line_end_u")
            du = float(u[1] - u[0]) if u.size > 1 else 0.0
            if end is not None and u[-1] < float(end) - 0.5 * du:
                raise BodyvibError(
                    f"road '{base}' is truncated: its header ends the road at u = "
                    f"{float(end):g} m, its data at {u[-1]:g} m; write it again"
                )
            cp = ds.create_contact_point()
            z = np.asarray(cp.uv_to_z_many(u, np.full_like(u, track)), dtype=float)
    except BodyvibError:
        raise
    except (OSError, ValueError, pycrg.OpenCRGError) as exc:
        msg = " ".join(str(exc).split())
        raise BodyvibError(
            f"road '{base}' is not a readable OpenCRG file ({msg[:200]}); check "
            "that it is complete (not truncated) and valid"
        ) from None
    return u, z, {"format": "opencrg", "track_m": track}
