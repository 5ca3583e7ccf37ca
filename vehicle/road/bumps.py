"""Speed humps, bumps and potholes: road profiles with their geometry as parameters.

A bump road is level but for one profile that begins ``at`` metres down the road
and is ``l`` long. With ``s = x - at`` (``0 <= s <= l``):

========  ===================================================  ====================
shape     height z(s)                                          keys (defaults)
========  ===================================================  ====================
hump      ``sqrt(R^2 - u^2) - (R - h)``, ``u = s - l/2``,      h 0.075, l 3.7
          ``R = (l^2/4 + h^2) / (2 h)`` (round top, an arc)
table     ``h s/r``, ``h``, ``h (l - s)/r`` (flat top, ramps)  h 0.075, l 6, ramp 0.975
sine      ``h (1 - cos(2 pi s/l)) / 2`` (full cosine)          h 0.075, l 3.7
halfsine  ``h sin(pi s/l)`` (half cosine)                      h 0.075, l 3.7
pothole   ``-d s/r``, ``-d``, ``-d (l - s)/r``                 d 0.05, l 0.6, ramp 0.05
========  ===================================================  ====================

Every shape also takes ``at`` (10 m by default). The slope is the exact derivative of
the height, in closed form; where the profile has a corner (the ends of a hump, the
ramps' ends) it jumps, and the value at the corner itself is the one of the closed
interval's formula. The defaults and their sources (TRL reports, UK regulations; a
chosen value says so) are data, in ``vehicle/data/roads/road-bumps.json``.

A road spec names a shape and overrides keys: ``"hump"``, ``"hump:h=0.1"``,
``"table:h=0.075,l=7,ramp=1"``. :func:`parse_bump` reads one; :func:`is_bump_spec`
tells a bump spec from other roads.
"""

import math
import os
from dataclasses import dataclass
from typing import Dict, Tuple

import numpy as np

from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.jsonfile import read_json

__all__ = [
    "BUMP_FILE",
    "SHAPES",
    "ShapedBump",
    "bump_library",
    "check_bump_start",
    "is_bump_spec",
    "parse_bump",
]

#: The bump library: shapes, their default dimensions and where each comes from.
BUMP_FILE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "data",
                         "roads", "road-bumps.json")  # fmt: skip

#: Shape names, in the library's order.
SHAPES = ("hump", "table", "sine", "halfsine", "pothole")

_library = None


def bump_library() -> dict:
    """The bump library (``vehicle/data/roads/road-bumps.json``), read once.

    Returns
    -------
    dict
        ``{"shapes": {name: {"description", "defaults", "sources"}}, "keys": {...}}``.

    Examples
    --------
    >>> bump_library()["shapes"]["hump"]["defaults"]
    {'h': 0.075, 'l': 3.7, 'at': 10.0}
    """
    global _library
    if _library is None:
        _library = read_json(BUMP_FILE, "the bump library")
    return _library


@dataclass
class ShapedBump:
    """One bump (or pothole) of a named shape on a level road.

    A road of the :class:`bodyvib.vehicle.road.base.Road` interface (``length``,
    ``name``, ``displacement``, ``slope``, ``describe``), endless like the cosine bump;
    :func:`bodyvib.vehicle.road.synthetic.make_road` makes it from a spec (it does not
    derive from ``Road``, whose module imports this one).

    Parameters
    ----------
    shape : str
        One of :data:`SHAPES`.
    height : float
        Height of the top, m (negative for the pothole: minus its depth).
    bump_length : float
        Length ``l`` along the road, m.
    ramp : float
        Ramp length ``r`` of ``table`` and ``pothole``, m (unused by the others).
    start : float
        Where the profile begins, m.
    name : str
        The spec it was made from, for reports.
    """

    shape: str = "hump"
    height: float = 0.075
    bump_length: float = 3.7
    ramp: float = 0.0
    start: float = 10.0
    name: str = "hump"

    #: Length over which the road is defined, m: endless (level beyond the bump).
    length = math.inf

    @property
    def end(self) -> float:
        """Where the profile returns to the level road, m."""
        return self.start + self.bump_length

    def _profile(self, x) -> Tuple[np.ndarray, np.ndarray]:
        """Height and slope at distances ``x``."""
        x = np.asarray(x, dtype=float)
        s = x - self.start
        on = (s >= 0) & (s <= self.bump_length)
        s = np.where(on, s, 0.0)
        h, l = self.height, self.bump_length
        if self.shape == "hump":
            R = (0.25 * l * l + h * h) / (2 * h)
            u = s - 0.5 * l
            root = np.sqrt(np.maximum(R * R - u * u, 0.0))
            z, dz = root - (R - h), -u / root
        elif self.shape in ("table", "pothole"):
            r = self.ramp
            up, down = s < r, s > l - r
            z = np.where(up, h * s / r, np.where(down, h * (l - s) / r, h))
            dz = np.where(up, h / r, np.where(down, -h / r, 0.0))
        elif self.shape == "sine":
            w = 2 * math.pi / l
            z, dz = 0.5 * h * (1 - np.cos(w * s)), 0.5 * h * w * np.sin(w * s)
        else:  # halfsine
            w = math.pi / l
            z, dz = h * np.sin(w * s), h * w * np.cos(w * s)
        return np.where(on, z, 0.0), np.where(on, dz, 0.0)

    def displacement(self, x) -> np.ndarray:
        """Profile height at distances ``x`` (m), in m."""
        return self._profile(x)[0]

    def slope(self, x) -> np.ndarray:
        """Exact slope ``dz/dx`` (closed form; see the module docstring)."""
        return self._profile(x)[1]

    def describe(self) -> dict:
        """Shape and dimensions for reports (JSON-serializable)."""
        d = {
            "name": self.name,
            "shape": self.shape,
            "height_m": self.height,
            "length_m": self.bump_length,
            "start_m": self.start,
        }
        if self.shape in ("table", "pothole"):
            d["ramp_m"] = self.ramp
        return d


def is_bump_spec(spec) -> bool:
    """Whether a road spec names a shape of the bump library (``hump``, ``table:h=0.1``...).

    Examples
    --------
    >>> is_bump_spec("hump:h=0.075,l=3.7"), is_bump_spec("bump"), is_bump_spec("C")
    (True, False, False)
    """
    s = str(spec).strip()
    return s.partition(":")[0].strip().lower() in SHAPES


def _keys(shape: str, text: str) -> Dict[str, float]:
    """The shape's dimensions: its defaults, overridden by ``key=value`` items of ``text``."""
    defaults = bump_library()["shapes"][shape]["defaults"]
    values = dict(defaults)
    seen = set()
    for item in filter(None, (p.strip() for p in text.split(","))):
        key, sep, value = (p.strip() for p in item.partition("="))
        if key in defaults and not (sep and value):
            raise BodyvibError(
                f"bump '{shape}': key '{key}' needs a value in m, e.g. {shape}:{key}="
                f"{defaults[key]:g}"
            )
        if key in seen:
            raise BodyvibError(
                f"bump '{shape}' gives {key} twice ({shape}:{text}); give each key once"
            )
        seen.add(key)
        if not sep or key not in defaults:
            raise BodyvibError(
                f"bump '{shape}' has no key '{key if sep else item}'; its keys are "
                f"{', '.join(defaults)} (e.g. {shape}:"
                + ",".join(f"{k}={v:g}" for k, v in defaults.items())
                + ")"
            )
        try:
            v = float(value)
        except ValueError:
            v = math.nan
        if not math.isfinite(v) or v < 0 or (v == 0 and key != "at"):
            raise BodyvibError(
                f"bump '{shape}': {key}={value} must be a positive number of metres"
                + (" (a pothole's depth d is positive)" if shape == "pothole" else "")
            )
        values[key] = v
    return values


def parse_bump(spec) -> ShapedBump:
    """A bump road from its spec, ``SHAPE`` or ``SHAPE:key=value,...``.

    Parameters
    ----------
    spec : str
        A shape of :data:`SHAPES`, optionally with dimensions in m (keys ``h`` or
        ``d``, ``l``, ``ramp``, ``at``; see the module docstring).

    Returns
    -------
    ShapedBump

    Raises
    ------
    BodyvibError
        Unknown shape or key, a size that is not a positive number, ramps longer than
        the bump, a round top higher than half its length (more than a half circle).

    Examples
    --------
    >>> b = parse_bump("hump:h=0.075,l=3.7")
    >>> round(float(b.displacement(10.0 + 3.7 / 2)), 6), round(float(b.slope(10.0)), 4)
    (0.075, 0.0812)
    """
    s = str(spec).strip()
    head, _, text = s.partition(":")
    shape = head.strip().lower()
    if shape not in SHAPES:
        raise BodyvibError(f"unknown bump shape '{head}'; shapes are {', '.join(SHAPES)}")
    v = _keys(shape, text)
    length = v["l"]
    if shape in ("table", "pothole") and 2 * v["ramp"] > length:
        raise BodyvibError(
            f"bump '{shape}': two ramps of {v['ramp']:g} m do not fit in l={length:g} m; "
            "lengthen l or shorten ramp"
        )
    if shape == "hump" and v["h"] > 0.5 * length:
        raise BodyvibError(
            f"bump 'hump': a round top of h={v['h']:g} m on l={length:g} m is more than a "
            "half circle; keep h <= l/2"
        )
    height = -v["d"] if shape == "pothole" else v["h"]
    name = f"{shape}:" + ",".join(f"{k}={x:g}" for k, x in v.items())
    return ShapedBump(
        shape=shape,
        height=height,
        bump_length=length,
        ramp=v.get("ramp", 0.0),
        start=v["at"],
        name=name,
    )


def check_bump_start(road, taper: float) -> None:
    """Refuse a bump that begins inside the fade-in every run's road starts with.

    Parameters
    ----------
    road : Road
        Any road; only a :class:`ShapedBump` is checked.
    taper : float
        The fade-in length, m (``--road-taper``).

    Raises
    ------
    BodyvibError
        The bump begins before ``taper`` (the fade-in would scale its front).

    Examples
    --------
    >>> check_bump_start(parse_bump("hump:at=2"), 5.0)
    Traceback (most recent call last):
    ...
    bodyvib.runtime.errors.BodyvibError: bump 'hump:h=0.075,l=3.7,at=2' begins at 2 m, inside the road's 5 m fade-in; move it (at=) or shorten taper_m
    """
    if isinstance(road, ShapedBump) and road.start < taper:
        raise BodyvibError(
            f"bump '{road.name}' begins at {road.start:g} m, inside the road's "
            f"{taper:g} m fade-in; move it (at=) or shorten taper_m",
            parameters=("taper_m",),
        )
