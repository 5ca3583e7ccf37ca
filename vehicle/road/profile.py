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

Optional tire enveloping is the 250 mm moving average of the IRI standard (ASTM
E1926): each height becomes the mean of the ``round(0.25 m / dx)`` samples centred
on it (the profile loses the half windows at its ends).
"""

import math
from typing import Optional

import numpy as np

from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.tabulated import HermiteTable

from .base import Road

__all__ = ["ProfileRoad", "ENVELOPE_M", "COMFORT_TOP_HZ", "envelope"]

#: Base length of the tire-enveloping moving average (IRI standard, ASTM E1926), m.
ENVELOPE_M = 0.25

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


class ProfileRoad(Road):
    """A measured longitudinal profile, uniformly sampled, as a :class:`Road`.

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
        Apply the 250 mm tire-enveloping moving average (:func:`envelope`).

    Attributes
    ----------
    distance : ndarray
        Distance of each sample from the profile's first, m.
    elevation : ndarray
        Heights as read (after enveloping if asked), m.
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
    ):
        z = np.asarray(elevation, dtype=float).ravel()
        if not (isinstance(spacing, (int, float)) and math.isfinite(spacing) and spacing > 0):
            raise BodyvibError(f"profile spacing must be a positive number of m, got {spacing!r}")
        if not np.all(np.isfinite(z)):
            raise BodyvibError(
                f"profile '{name}' holds a height that is not a number; fill or cut the gap"
            )
        if enveloped:
            z = envelope(z, spacing)
        if z.size < 4:
            raise BodyvibError(f"profile '{name}' has {z.size} samples; a road needs at least 4")
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
        self._table = HermiteTable(self.distance, h, np.gradient(h, self.spacing, edge_order=2))

    @property
    def table(self) -> HermiteTable:
        """The interpolant of the driven height (grade removed): heights and slopes at the samples."""
        return self._table

    def displacement(self, x) -> np.ndarray:
        """Driven height at distances ``x`` (m) from the first sample, m (the end held beyond)."""
        return self._table.evaluate(x)[0][..., 0]

    def slope(self, x) -> np.ndarray:
        """Exact slope ``dz/dx`` of the same interpolant (0 beyond the ends)."""
        return self._table.evaluate(x)[1][..., 0]

    def describe(self) -> dict:
        return {
            "name": self.name,
            "length_m": self.length,
            "spacing_m": self.spacing,
            "samples": int(self.elevation.size),
            "grade_removed": self.grade,
            "tire_envelope_m": ENVELOPE_M if self.enveloped else None,
            **self.info,
        }

    def check_run(
        self, speed: float, duration: float, step: Optional[float] = None, repeat: bool = False
    ) -> None:
        """Refuse a run this profile cannot drive.

        The profile resolves wavelengths down to ``2 dx``; at the speed ``V`` they pass
        at ``V / (2 dx)`` Hz, which must reach the highest frequency the comfort figures
        weight (:data:`COMFORT_TOP_HZ`) or the step resolves (``1 / (2 h)``), whichever
        is lower. A run longer than the profile is refused unless it repeats.

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
            Spacing too coarse for the speed and step, or a run longer than the profile.
        """
        need = COMFORT_TOP_HZ if not step else min(COMFORT_TOP_HZ, 0.5 / step)
        top = speed / (2 * self.spacing)
        if top < need * (1 - 1e-9):
            raise BodyvibError(
                f"road '{self.name}': its spacing {self.spacing:g} m is too coarse for "
                f"{speed:g} m/s and a {step or 0:g} s step: its shortest wavelength passes at "
                f"{top:.3g} Hz, below the {need:.3g} Hz the figures need; use a profile sampled "
                f"every {speed / (2 * need):.3g} m or finer, drive at "
                f"{2 * self.spacing * need:.3g} m/s or faster, or step at {0.5 / top:.3g} s or "
                "longer (which resolves less)"
            )
        run = speed * duration
        if run > self.length * (1 + 1e-12) and not repeat:
            raise BodyvibError(
                f"road '{self.name}' is {self.length:.6g} m long; a {duration:g} s run at "
                f"{speed:g} m/s needs {run:.6g} m: shorten the run to {self.length / speed:.4g} s "
                "or less, or repeat the road (--road-repeat)"
            )
