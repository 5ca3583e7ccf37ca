"""Units named in the column headers of input files: one parser, one table per quantity.

A header names its column's unit in brackets or parentheses (``time [s]``,
``seat_z (m/s2)``) or after its last underscore (``time_ms``, ``distance_m``,
``acc_g``). Every reader of columns (road profiles, seat signals) splits its headers
with :func:`split_unit` and turns the unit into a factor to SI with :func:`unit_scale`,
so a unit is read the same way, or refused the same way, wherever it appears.

An unknown unit in brackets is refused; after an underscore a word is a unit only where
the reader says any suffix is one (road profiles: ``elevation_furlong`` is an unknown
unit) or where it is one of the quantity's units (a seat signal's ``seat_z`` is a name,
``acc_g`` an acceleration in g).
"""

import math
import re
from typing import Dict, Optional, Tuple

from ..runtime.errors import BodyvibError

__all__ = [
    "LENGTH_UNITS",
    "TIME_UNITS",
    "ACCELERATION_UNITS",
    "ANGULAR_ACCELERATION_UNITS",
    "STANDARD_GRAVITY",
    "split_unit",
    "unit_scale",
]

#: Length units, in m.
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

#: Time units, in s.
TIME_UNITS = {
    "s": 1.0,
    "sec": 1.0,
    "ms": 1e-3,
    "us": 1e-6,
    "µs": 1e-6,
    "ns": 1e-9,
    "min": 60.0,
    "h": 3600.0,
}

#: Standard acceleration of gravity, m/s2 (CGPM 1901; ISO 80000-3): the ``g`` of
#: accelerometers.
STANDARD_GRAVITY = 9.80665

#: Acceleration units, in m/s2.
ACCELERATION_UNITS = {
    "m/s2": 1.0,
    "m/s^2": 1.0,
    "m/s²": 1.0,
    "m/sec2": 1.0,
    "m/sec^2": 1.0,
    "m s-2": 1.0,
    "m s^-2": 1.0,
    "m*s^-2": 1.0,
    "mps2": 1.0,
    "ms2": 1.0,
    "ms-2": 1.0,
    "g": STANDARD_GRAVITY,
    "mg": 1e-3 * STANDARD_GRAVITY,
    "cm/s2": 1e-2,
    "cm/s^2": 1e-2,
    "mm/s2": 1e-3,
    "mm/s^2": 1e-3,
    "ft/s2": 0.3048,
    "ft/s^2": 0.3048,
}

#: Angular acceleration units (a seat's rotations), in rad/s2.
ANGULAR_ACCELERATION_UNITS = {
    "rad/s2": 1.0,
    "rad/s^2": 1.0,
    "rad/s²": 1.0,
    "rad s-2": 1.0,
    "deg/s2": math.pi / 180.0,
    "deg/s^2": math.pi / 180.0,
    "°/s2": math.pi / 180.0,
    "°/s^2": math.pi / 180.0,
}

_BRACKETED = re.compile(r"^\s*(.*?)\s*[\[(]\s*([^\[\]()]+?)\s*[\])]\s*$")
_SUFFIX = re.compile(r"^\s*(.*?[A-Za-z0-9])_([A-Za-zµ][A-Za-zµ0-9/^²*-]*)\s*$")


def _key(unit: str, units: Dict[str, float]) -> Optional[str]:
    """The key of ``units`` a unit names (as written, else lower case; ``G`` is not ``g``
    only where both are keys), or None."""
    u = unit.strip()
    if u in units:
        return u
    return u.lower() if u.lower() in units else None


def split_unit(header: str, units: Optional[Dict[str, float]] = None) -> Tuple[str, Optional[str]]:
    """A column header's name and the unit it names, if any.

    Parameters
    ----------
    header : str
        E.g. ``"time [s]"``, ``"time_ms"``, ``"distance_m"``, ``"acc_g"``, ``"time"``.
    units : dict of str to float, optional
        The quantity's units: a word after the last underscore is its unit only if it is
        one of them. None: any word after the last underscore is the unit.

    Returns
    -------
    (str, str or None)
        The name, and the unit as written (None when the header names none). A unit in
        brackets is returned whatever it is (:func:`unit_scale` refuses an unknown one).

    Examples
    --------
    >>> split_unit("time [s]"), split_unit("time_ms", TIME_UNITS)
    (('time', 's'), ('time', 'ms'))
    >>> split_unit("seat_z", ACCELERATION_UNITS), split_unit("acc_g", ACCELERATION_UNITS)
    (('seat_z', None), ('acc', 'g'))
    >>> split_unit("elevation_furlong")
    ('elevation', 'furlong')
    """
    m = _BRACKETED.match(header)
    if m and m.group(1):
        return m.group(1), m.group(2)
    m = _SUFFIX.match(header)
    if m and (units is None or _key(m.group(2), units) is not None):
        return m.group(1), m.group(2)
    return header.strip(), None


def unit_scale(unit: str, units: Dict[str, float], what: str) -> float:
    """The factor from a unit to SI.

    Parameters
    ----------
    unit : str
        As a header or an option names it; surrounding brackets are ignored.
    units : dict of str to float
        The quantity's units (:data:`LENGTH_UNITS`, :data:`TIME_UNITS`,
        :data:`ACCELERATION_UNITS`).
    what : str
        The quantity, for the message (``"time"``, ``"elevation"``).

    Returns
    -------
    float
        What a value in ``unit`` is multiplied by to give it in SI.

    Raises
    ------
    BodyvibError
        A unit that is not one of ``units``, listing them.

    Examples
    --------
    >>> unit_scale("ms", TIME_UNITS, "time"), unit_scale("[g]", ACCELERATION_UNITS, "acceleration")
    (0.001, 9.80665)
    """
    u = str(unit).strip().strip("[]()").strip()
    key = _key(u, units)
    if key is None:
        raise BodyvibError(
            f"unknown {what} unit '{u}'; use one of "
            + ", ".join(k for k in units if k.isascii() and " " not in k)
        )
    return units[key]
