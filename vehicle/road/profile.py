"""Measured longitudinal profiles as roads: samples, one interpolant, and their checks for a run.

A :class:`ProfileRoad` is a profile sampled at a uniform spacing ``dx`` along the
distance (what a profilometer, an OpenCRG file along a track, a CSV or an ERD file
gives, :mod:`bodyvib.vehicle.road.measured`). Between the samples the height is the cubic
Hermite interpolant of :class:`bodyvib.runtime.tabulated.HermiteTable` (the one
``Road.fmu`` evaluates) with the slopes at the samples from second-order central
differences (one-sided at the ends), so the road velocity ``V dz/dx`` a car sees is
the exact derivative of the displacement, continuous across the samples.

The car drives the profile from its first sample, with the profile's *grade* (the
straight line from the first to the last sample, which a car at constant speed
follows without vibrating) removed: the driven height starts and ends at 0, so the
fade-in and fade-out of :class:`bodyvib.vehicle.road.synthetic.TaperedRoad` join level road,
and a repeated profile (``--road-repeat``) joins itself without a step.

A profile driven with a tire contact (:mod:`bodyvib.vehicle.road.contact`) is
replaced by the tandem-cam effective road at its samples before it is interpolated.
The 250 mm moving average of the IRI standard (ASTM E1926; each height the mean of
the ``round(0.25 m / dx)`` samples centred on it, the profile losing the half windows
at its ends) is a profile filter for the IRI, kept as an option.

A *periodic* profile (a short road driven again and again) joins its end to its
start: its driven height is 0 at both, and its slope there is the central difference
across the join, so the repeated road has no step in height or slope.
"""

import math
import warnings
from typing import Optional

import numpy as np

from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.tabulated import HermiteTable

from .base import Road, RoadWarning
from .contact import TandemCam, effective_road

__all__ = [
    "ProfileRoad",
    "ENVELOPE_M",
    "COMFORT_TOP_HZ",
    "MAX_ELEVATION_M",
    "STEEP_SLOPE",
    "envelope",
]

#: Base length of the tire-enveloping moving average (IRI standard, ASTM E1926), m.
ENVELOPE_M = 0.25

#: Slope of a driven profile beyond which a point contact reports it (a step a tire
#: rolls onto over its footprint, not one it follows): 1, 45 degrees.
STEEP_SLOPE = 1.0

#: Highest frequency the comfort figures weight, Hz: the 80 Hz one-third-octave band,
#: the top of ISO 2631-1's range for health and comfort.
COMFORT_TOP_HZ = 80.0


def envelope(elevation, spacing: float, base: float = ENVELOPE_M) -> np.ndarray:
    """The moving average over ``base`` metres (tire enveloping), centred, whole windows only.

    Parameters
    ----------
    elevation : (n,) array_like
        Heights at a uniform spacing, m.
    spacing : float
        m.
    base : float
        Averaging length, m (250 mm in the IRI standard).

    Returns
    -------
    (n - k + 1,) ndarray
        ``k = max(1, round(base / spacing))`` samples averaged; ``k = 1`` returns a copy.

    Examples
    --------
    >>> envelope([0.0, 0.0, 3.0, 0.0, 0.0], 0.0833)
    array([1., 1., 1.])
    """
    z = np.asarray(elevation, dtype=float)
    k = max(1, int(round(base / spacing)))
    if k == 1:
        return z.copy()
    c = np.concatenate([[0.0], np.cumsum(z)])
    return (c[k:] - c[:-k]) / k


#: Largest absolute height a profile may hold, m. Chosen: 10 km is above every road on Earth
#: (the highest reach about 5.8 km) and any datum a profiler writes, while a number beyond
#: it is a unit or file error whose squares overflow in the statistics (1e300 m did).
MAX_ELEVATION_M = 1.0e4


class ProfileRoad(Road):
    """A measured longitudinal profile, uniformly sampled, as a :class:`~bodyvib.vehicle.road.base.Road`.

    Parameters
    ----------
    elevation : (n,) array_like
        Heights at ``distance = 0, dx, 2 dx, ...``, m (n >= 4).
    spacing : float
        dx, m.
    name : str
        Label for reports (usually the file name and track).
    info : dict, optional
        Provenance for :meth:`describe` (format, file, track, units).
    enveloped : bool
        Apply the IRI standard's 250 mm moving average (:func:`envelope`).
    contact : TandemCam, optional
        Drive the tandem-cam effective road of this tire (None: point contact).
    periodic : bool
        The profile repeats with its length (the wheel at ``x`` sees ``x mod length``).

    Attributes
    ----------
    distance : ndarray
        Distance of each sample from the profile's first, m.
    elevation : ndarray
        Heights as read (the moving average and the effective road applied if asked), m.
    spacing : float
        m.
    length : float
        ``distance[-1]``, m.
    grade : float
        Slope of the straight line from the first to the last sample (removed when driven).

    Raises
    ------
    BodyvibError
        Fewer than 4 samples, a spacing that is not positive, non-finite heights.

    Examples
    --------
    >>> p = ProfileRoad([0.0, 0.01, 0.0, -0.01, 0.0], 0.5, name="wave")
    >>> p.length, p.spacing
    (2.0, 0.5)
    >>> float(p.displacement(0.5))
    0.01
    """

    def __init__(
        self,
        elevation,
        spacing: float,
        name: str = "measured profile",
        info: Optional[dict] = None,
        enveloped: bool = False,
        contact: Optional[TandemCam] = None,
        periodic: bool = False,
    ):
        z = np.asarray(elevation, dtype=float).ravel()
        if not (isinstance(spacing, (int, float)) and math.isfinite(spacing) and spacing > 0):
            raise BodyvibError(f"profile spacing must be a positive number of m, got {spacing!r}")
        if not np.all(np.isfinite(z)):
            raise BodyvibError(
                f"profile '{name}' holds a height that is not a number; fill or cut the gap"
            )
        far = np.flatnonzero(np.abs(z) > MAX_ELEVATION_M)
        if far.size:
            i = int(far[0])
            raise BodyvibError(
                f"profile '{name}': sample {i + 1} (at {i * spacing:g} m) has the height "
                f"{z[i]:.3g} m, beyond the {MAX_ELEVATION_M:g} m a road surface can have; "
                "check the file's units or its data"
            )
        if enveloped:
            z = envelope(z, spacing)
        if z.size < 4:
            raise BodyvibError(f"profile '{name}' has {z.size} samples; a road needs at least 4")
        if contact is not None:  # the cams ride the profile without its grade
            line = z[0] + (z[-1] - z[0]) * np.linspace(0.0, 1.0, z.size)
            z = effective_road(z - line, spacing, contact, periodic) + line
        self.contact = contact
        self.periodic = bool(periodic)
        self.name = name
        self.spacing = float(spacing)
        self.elevation = z
        self.distance = np.arange(z.size) * self.spacing
        self.length = float(self.distance[-1])
        self.enveloped = bool(enveloped)
        self.info = dict(info or {})
        self.grade = float((z[-1] - z[0]) / self.length)
        h = z - z[0] - self.grade * self.distance
        h[-1] = 0.0
        dh = np.gradient(h, self.spacing, edge_order=2)
        if self.periodic:  # the join's slope from its neighbours on either side
            dh[0] = dh[-1] = (h[1] - h[-2]) / (2 * self.spacing)
        self._table = HermiteTable(self.distance, h, dh)

    @property
    def table(self) -> HermiteTable:
        """The interpolant of the driven height (grade removed): heights and slopes at the samples."""
        return self._table

    def _at(self, x):
        x = np.asarray(x, dtype=float)
        return np.mod(x, self.length) if self.periodic else x

    def displacement(self, x) -> np.ndarray:
        """Driven height at distances ``x`` (m) from the first sample, m (the end held beyond,
        or the profile repeated when periodic)."""
        return self._table.evaluate(self._at(x))[0][..., 0]

    def slope(self, x) -> np.ndarray:
        """Exact slope ``dz/dx`` of the same interpolant (0 beyond the ends unless periodic)."""
        return self._table.evaluate(self._at(x))[1][..., 0]

    def steepest(self):
        """The steepest chord between neighbouring samples of the driven height, and where.

        Returns
        -------
        (float, float)
            ``|z_{i+1} - z_i| / dx`` and the distance of the chord's first sample, m.
        """
        s = np.abs(np.diff(self._table.value[:, 0])) / self.spacing
        i = int(np.argmax(s))
        return float(s[i]), float(self.distance[i])

    def describe(self) -> dict:
        return {
            **super().describe(),
            "length_m": self.length,
            "spacing_m": self.spacing,
            "samples": int(self.elevation.size),
            "grade_removed": self.grade,
            "moving_average_m": ENVELOPE_M if self.enveloped else None,
            "contact": (
                dict(model="tandem-cam", **self.contact.to_dict())
                if self.contact is not None
                else {"model": "point"}
            ),
            "repeats": self.periodic,
            **self.info,
        }

    def check_run(
        self, speed: float, duration: float, step: Optional[float] = None, repeat: bool = False
    ) -> None:
        """Refuse a run this profile cannot drive; warn of a band it does not carry.

        The profile resolves wavelengths down to ``2 dx``; at the speed ``V`` they pass
        at ``V / (2 dx)`` Hz. Below the highest frequency the comfort figures weight
        (:data:`COMFORT_TOP_HZ`) or the step resolves (``1 / (2 h)``), whichever is lower,
        the figures miss the road's content above it: a :class:`~bodyvib.vehicle.road.base.RoadWarning` names that
        frequency (a profiler's 0.25 m spacing carries 40 Hz at 20 m/s). A run longer
        than the profile is refused unless it repeats.

        Parameters
        ----------
        speed : float
            m/s.
        duration : float
            s.
        step : float, optional
            Communication step, s.
        repeat : bool
            The profile repeats (the run may be longer than it).

        Raises
        ------
        BodyvibError
            A run longer than the profile that does not repeat.

        Warns
        -----
        bodyvib.vehicle.road.base.RoadWarning
            The profile carries nothing above a frequency the figures weight.
        """
        need = COMFORT_TOP_HZ if not step else min(COMFORT_TOP_HZ, 0.5 / step)
        top = speed / (2 * self.spacing)
        if top < need * (1 - 1e-9):
            warnings.warn(
                f"road '{self.name}': at {speed:g} m/s its {self.spacing:g} m spacing carries "
                f"nothing above {top:.3g} Hz (wavelengths below {2 * self.spacing:g} m); the "
                f"figures, which weight up to {need:.3g} Hz, miss the road's content above "
                f"{top:.3g} Hz (a profile every {speed / (2 * need):.3g} m would carry it)",
                RoadWarning,
                stacklevel=2,
            )
        run = speed * duration
        if run > self.length * (1 + 1e-12) and not repeat:
            raise BodyvibError(
                f"road '{self.name}' is {self.length:.6g} m long; a {duration:g} s run at "
                f"{speed:g} m/s needs {run:.6g} m: shorten the run to {self.length / speed:.4g} s "
                "or less, or repeat the road (repeat=True)",
                parameters=("repeat",),
            )
