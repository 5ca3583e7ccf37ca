"""Measured roads from files: OpenCRG (``.crg``), CSV longitudinal profiles and ERD files.

:func:`load_profile` reads any of them into a :class:`~bodyvib.vehicle.road.profile.ProfileRoad`
(heights in m at a uniform spacing in m from the first sample):

* **OpenCRG** ``.crg`` (ASAM OpenCRG, through ``pycrg``): the height of the road
  surface (reference line elevation and slope, banking and the elevation grid, as
  OpenCRG evaluates it with the file's modifiers) along the reference line at the
  lateral offset ``track_m`` (positive to the left), at the file's own increment
  (without a modifiers section, OpenCRG's default modifiers put the reference line's
  start at z = 0; the grid is single precision).
* **CSV**: two columns, distance and elevation, with their units in the header
  (``distance_m,elevation_mm``; also ``distance [m]`` or ``distance (m)``) or given
  as ``units="m,mm"``. Lines starting with ``#`` are comments.
* **ERD** (UMTRI's text format for profiles, as RoadRuf and ProVAL write it): a
  header that starts with ``ERDFILEV2.00`` and ends with a line ``END``, then the
  samples, ``NCHAN`` numbers per row, ``NSAMP`` rows. The header gives the layout on
  its second line (comma-separated: ``NCHAN, NSAMP``, three more fields, then the
  spacing ``DELTA``) or as keyword lines (``NCHAN``, ``NSAMP``, ``DELTA``, ``START``),
  and the units as keyword lines: distance ``XUNITS`` (or ``GENUNITS``), elevation
  ``YUNITS``, ``UNITSNAM`` or ``UNITS`` (one per channel). Keyword lines are
  ``KEY, v1, v2`` or the fixed-column form, an 8-character key then the values
  (``XUNITS  m``, ``UNITSNAMmm      mm``). The first channel is read (``channel``
  chooses another).

A file that cannot be driven is refused with one line naming the problem and the
fix: repeated or decreasing distances, a height that is not a number, a gap, a
spacing that is not uniform, missing or unknown units, heights implausible for their
units, a truncated file.
"""

import math
import os
import re
from typing import List, Optional, Tuple

import numpy as np

from bodyvib.runtime.errors import BodyvibError

from .profile import ProfileRoad

__all__ = ["load_profile", "PROFILE_EXTENSIONS", "LENGTH_UNITS", "MAX_SLOPE"]

#: File extensions read as road profiles.
PROFILE_EXTENSIONS = (".crg", ".csv", ".erd")

#: Length units of CSV and ERD files, in m.
LENGTH_UNITS = {
    "m": 1.0,
    "km": 1e3,
    "cm": 1e-2,
    "mm": 1e-3,
    "um": 1e-6,
    "µm": 1e-6,
    "micron": 1e-6,
    "microns": 1e-6,
    "ft": 0.3048,
    "feet": 0.3048,
    "in": 0.0254,
    "inch": 0.0254,
    "inches": 0.0254,
    "mi": 1609.344,
    "mile": 1609.344,
}

#: Steepest slope of a driven profile with its grade removed: steeper than 1 (45 degrees)
#: means a unit is wrong (heights in mm read as m make a 5 mm bump a 5 m wall).
MAX_SLOPE = 1.0

#: Deviation of a sample's distance from the uniform grid still taken as uniform, in
#: spacings (a printed distance rounded to a few digits).
UNIFORM_TOLERANCE = 0.01


def load_profile(
    path,
    *,
    track_m: float = 0.0,
    units: Optional[str] = None,
    envelope: bool = False,
    channel: int = 1,
) -> ProfileRoad:
    """Read a measured road profile (OpenCRG, CSV or ERD) as a :class:`ProfileRoad`.

    Parameters
    ----------
    path : str or path
        ``.crg``, ``.csv`` or ``.erd`` file.
    track_m : float
        OpenCRG: lateral offset from the reference line, m (positive to the left).
    units : str, optional
        CSV and ERD: ``"DIST,ELEV"`` units, e.g. ``"m,mm"``, when the file does not
        name them (a file that names other units is refused).
    envelope : bool
        Apply the 250 mm tire-enveloping moving average.
    channel : int
        ERD: the channel (profile) to read, from 1.

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
    if ext == ".crg":
        if units is not None:
            raise BodyvibError(f"road '{base}': an OpenCRG file is in metres; drop --road-units")
        x, z, info = _read_crg(path, float(track_m))
    elif ext in (".csv", ".erd"):
        if track_m:
            raise BodyvibError(
                f"road '{base}': a {ext} file holds one profile; --road-track "
                "applies to OpenCRG files only"
            )
        x, z, info = (_read_csv if ext == ".csv" else _read_erd)(path, units, channel)
    else:
        raise BodyvibError(
            f"road '{path}': unknown kind of file '{ext}'; give an OpenCRG "
            ".crg, a .csv profile or an .erd file (or an ISO 8608 class A-H, "
            "'bump' or 'sweep')"
        )
    spacing = _uniform(x, z, base)
    name = base + (f" at {track_m:g} m" if ext == ".crg" else "")
    road = ProfileRoad(
        z,
        spacing,
        name=name,
        enveloped=envelope,
        info=dict(info, file=os.path.abspath(path), start_m=float(x[0])),
    )
    steep = float(np.max(np.abs(np.diff(road.table.value[:, 0])))) / spacing
    if steep > MAX_SLOPE:
        raise BodyvibError(
            f"road '{base}': the height changes by {steep:.3g} m per m of distance "
            "(steeper than 45 degrees): the units look wrong; name them in the "
            "header (distance_m,elevation_mm) or give --road-units"
        )
    return road


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
    dev = np.max(np.abs(x - (x[0] + spacing * np.arange(x.size))))
    if dev > UNIFORM_TOLERANCE * spacing:
        raise BodyvibError(
            f"road '{base}': the distances are not uniformly spaced (spacing "
            f"from {d.min():g} to {d.max():g}); resample the profile to a uniform "
            "spacing"
        )
    return spacing


def _unit(text, what, base) -> float:
    u = str(text).strip().strip("[]()").strip()
    if u not in LENGTH_UNITS:
        raise BodyvibError(
            f"road '{base}': unknown {what} unit '{u}'; use one of "
            + ", ".join(k for k in LENGTH_UNITS if k.isascii())
        )
    return LENGTH_UNITS[u]


def _given_units(units, base) -> Optional[Tuple[float, float]]:
    if units is None:
        return None
    parts = [p.strip() for p in str(units).split(",")]
    if len(parts) != 2:
        raise BodyvibError(
            f"--road-units '{units}' must name two units, distance and elevation, e.g. m,mm"
        )
    return _unit(parts[0], "distance", base), _unit(parts[1], "elevation", base)


def _scales(base, units, given, header, header_text, no_units) -> Tuple[float, float]:
    """The factors from a file's distance and elevation units to metres.

    Parameters
    ----------
    base : str
        The file's name, for the messages.
    units : str or None
        ``--road-units`` as given (``"DIST,ELEV"``), for the messages.
    given : (float, float) or None
        ``units`` read by :func:`_given_units`.
    header : (str, str) or None
        The distance and elevation units the file's header names, None if it names none.
    header_text : str
        The header as a message quotes it.
    no_units : str
        What a message says when neither the header nor ``--road-units`` names the
        units (the fix ``or give --road-units m,mm`` is appended).

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
                f"road '{base}': --road-units {units} disagrees with the header "
                f"{header_text}; drop one of them"
            )
        return scales
    if given is None:
        raise BodyvibError(f"road '{base}': {no_units} or give --road-units m,mm")
    return given


# -- CSV ------------------------------------------------------------------------------

_HEADER_UNIT = re.compile(r"^\s*([A-Za-z][A-Za-z0-9 ]*?)\s*(?:_|\[|\()\s*([A-Za-zµ]+)\s*[\])]?\s*$")


def _read_csv(path, units, channel):
    base = os.path.basename(path)
    lines = _text_lines(path)
    rows = [
        (i + 1, ln) for i, ln in enumerate(lines) if ln.strip() and not ln.lstrip().startswith("#")
    ]
    if not rows:
        raise BodyvibError(
            f"road '{base}' is empty; a CSV profile needs a header and rows of distance,elevation"
        )
    head = [h.strip() for h in rows[0][1].split(",")]
    given = _given_units(units, base)
    if _is_number(head[0]):
        raise BodyvibError(
            f"road '{base}' has no header; start it with the columns and their "
            "units, e.g. distance_m,elevation_mm"
        )
    if len(head) < 2:
        raise BodyvibError(
            f"road '{base}': the header '{rows[0][1].strip()}' needs two columns, "
            "distance and elevation"
        )
    named = [_HEADER_UNIT.match(h) for h in head[:2]]
    scales = _scales(
        base,
        units,
        given,
        (named[0].group(2), named[1].group(2)) if all(named) else None,
        f"'{','.join(head[:2])}'",
        f"the header '{','.join(head[:2])}' names no units; name them (distance_m,elevation_mm)",
    )
    x, z = [], []
    for k, (lineno, ln) in enumerate(rows[1:]):
        f = ln.split(",")
        if len(f) < 2:
            last = k == len(rows) - 2
            raise BodyvibError(
                f"road '{base}': line {lineno} has {len(f)} field(s), not 2"
                + ("; the file looks truncated: write it again" if last else "; fix the line")
            )
        try:
            x.append(float(f[0]) if f[0].strip() else math.nan)
            z.append(float(f[1]) if f[1].strip() else math.nan)
        except ValueError:
            raise BodyvibError(
                f"road '{base}': line {lineno} '{ln.strip()}' is not two numbers; fix the line"
            ) from None
    return (
        np.array(x) * scales[0],
        np.array(z) * scales[1],
        {"format": "csv", "units": f"{head[0]},{head[1]}" if all(named) else units},
    )


def _is_number(text) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


def _text_lines(path) -> List[str]:
    try:
        with open(path, encoding="utf-8", errors="strict") as f:
            return f.read().splitlines()
    except UnicodeDecodeError:
        raise BodyvibError(
            f"road '{os.path.basename(path)}' is not a text file; give a CSV or ERD text file"
        ) from None


# -- ERD ------------------------------------------------------------------------------


def _read_erd(path, units, channel):
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
    if not 1 <= channel <= nchan:
        raise BodyvibError(
            f"road '{base}' has {nchan} channel(s); channel {channel} does not exist"
        )
    xu = keys.get("XUNITS") or keys.get("GENUNITS")
    yu = keys.get("YUNITS") or keys.get("UNITSNAM") or keys.get("UNITS")
    given = _given_units(units, base)
    yname = (yu[channel - 1] if len(yu) >= channel else yu[0]) if yu else None
    scales = _scales(
        base,
        units,
        given,
        (xu[0], yname) if xu and yu else None,
        f"(XUNITS {xu[0] if xu else ''}, YUNITS {yname})",
        "the ERD header names no units (XUNITS and YUNITS); add them",
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
        },
    )


# -- OpenCRG --------------------------------------------------------------------------


def _read_crg(path, track):
    base = os.path.basename(path)
    try:
        import pycrg
    except ImportError:  # pragma: no cover - a dependency
        raise BodyvibError(
            "reading OpenCRG files needs the pycrg package: pip install pycrg"
        ) from None
    pycrg.set_message_level(pycrg.MSG_LEVEL_NONE)
    try:
        with pycrg.DataSet.open(path) as ds:
            g = ds.grid()
            u, v = np.asarray(g.u, dtype=float), np.asarray(g.v, dtype=float)
            if not (v.min() - 1e-9 <= track <= v.max() + 1e-9):
                raise BodyvibError(
                    f"road '{base}': --road-track {track:g} m is off the road "
                    f"(it spans {v.min():g} to {v.max():g} m from the reference "
                    "line); choose a track on it"
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
