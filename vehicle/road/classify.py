"""ISO 8608 classification of a longitudinal profile: its displacement PSD, fitted and classed.

The displacement PSD ``Gd(n)`` (one-sided, m^3, over the spatial frequency ``n``
in cycle/m) is estimated by Welch's method over distance (Hann windows, half
overlapping, linear trend removed per segment; a single periodogram when the
profile is too short for segments). ISO 8608 describes a road by the straight
line ``Gd(n) = Gd(n0) (n / n0)^-w`` in log-log axes, ``n0 = 0.1 cycle/m``.
The estimate is averaged into one-third-octave bands (geometric centres) over
the classification band -- ISO 8608's 0.011-2.83 cycle/m, narrowed to what
the profile resolves: from four Welch bins (``4 / segment length``) up to
half the Nyquist frequency ``1 / (4 dx)`` -- and the line is fitted to the
band averages by least squares in ``log Gd`` against ``log n``, which gives
``Gd(n0)`` and the waviness ``w``. A profile shorter than 40 m does not reach
``n0``: its class comes from the band it has, with the waviness held at ISO 8608's 2
and ``Gd(n0)`` read off that line (the band is stated with it).

How well the line fits is stated twice: the factor by which the band averages scatter
about it, ``exp(rms(log Gd_band - log line))``, and the *misfit*, that r.m.s. in units
of the averages' own statistical scatter (a mean of ``K`` periodogram values scatters
by about ``1.28 / sqrt(K)`` in log). A random road following the line has a misfit
near 1; a profile the line does not describe (a single sine puts all its power in one
band) has far more, and above :data:`POOR_FIT_MISFIT` the class says little about it.

The class is where the fitted ``Gd(n0)`` falls among the class limits: class
``i`` (A = 0 ... H = 7) has the geometric mean ``16 4^i 1e-6 m^3`` and spans a
factor 2 either side, ``[8, 32) 4^i 1e-6 m^3`` (A from 0, H without an upper
limit).
"""

import math
from dataclasses import dataclass, field
from typing import List, Tuple

import numpy as np

from bodyvib.runtime.errors import BodyvibError

from ..records import Record
from .iri import _check_profile
from .synthetic import ISO8608_CLASSES, N0, N_BAND, class_psd_n0

__all__ = [
    "class_limits",
    "class_of",
    "profile_psd",
    "RoadClass",
    "classify_profile",
    "POOR_FIT_MISFIT",
]

#: Misfit (band averages' distance from the line in units of their own statistical
#: scatter) above which the ISO 8608 line does not describe the profile.
POOR_FIT_MISFIT = 3.0


def class_limits(road_class: str) -> Tuple[float, float]:
    """Lower and upper limit of ``Gd(n0)`` of an ISO 8608 class, m^3.

    Parameters
    ----------
    road_class : str
        ``"A"`` ... ``"H"``.

    Returns
    -------
    (float, float)
        Half and twice the class's geometric mean (A's lower limit 0, H's
        upper infinity).

    Examples
    --------
    >>> class_limits("C")
    (0.000128, 0.000512)
    """
    mean = class_psd_n0(road_class)
    c = road_class.strip().upper()
    return (0.0 if c == "A" else mean / 2, math.inf if c == "H" else mean * 2)


def class_of(gd_n0: float) -> str:
    """The ISO 8608 class whose limits hold ``Gd(n0)``.

    Parameters
    ----------
    gd_n0 : float
        Displacement PSD at 0.1 cycle/m, m^3.

    Returns
    -------
    str
        ``"A"`` ... ``"H"``.

    Examples
    --------
    >>> class_of(256e-6), class_of(511e-6), class_of(513e-6)
    ('C', 'C', 'D')
    """
    v = float(gd_n0)
    if not (math.isfinite(v) and v >= 0):
        raise BodyvibError(f"Gd(n0) must be a non-negative number of m^3, got {gd_n0!r}")
    for c in ISO8608_CLASSES:
        if v < class_limits(c)[1]:
            return c
    return ISO8608_CLASSES[-1]


def profile_psd(
    distance, elevation, segment_m: float = None
) -> Tuple[np.ndarray, np.ndarray, float]:
    """One-sided displacement PSD of a profile over distance (Welch, Hann, 50 % overlap).

    Parameters
    ----------
    distance : (n,) array_like
        Distances, m, uniformly spaced.
    elevation : (n,) array_like
        Heights, m.
    segment_m : float, optional
        Welch segment length, m. By default a quarter of the profile, at least
        100 m (1/0.011 cycle/m would need 91 m per cycle), and the whole
        profile (one periodogram) when it is shorter than that.

    Returns
    -------
    n : ndarray
        Spatial frequencies, cycle/m (without 0).
    gd : ndarray
        ``Gd(n)``, m^3.
    segment : float
        Segment length used, m.

    Raises
    ------
    BodyvibError
        As :func:`bodyvib.vehicle.road.iri.international_roughness_index` for a bad profile.
    """
    from scipy.signal import welch

    x, z, dx = _check_profile(distance, elevation)
    length = x.size * dx
    if segment_m is None:
        segment_m = max(100.0, length / 4)
    nseg = int(min(x.size, max(8, round(segment_m / dx))))
    n, gd = welch(
        z,
        fs=1.0 / dx,
        window="hann",
        nperseg=nseg,
        noverlap=nseg // 2,
        detrend="linear",
        scaling="density",
    )
    return n[1:], gd[1:], nseg * dx


def _third_octaves(lo: float, hi: float):
    """One-third-octave band edges (base 2, centred on 0.1 cycle/m) covering [lo, hi]."""
    step = 2 ** (1 / 3)
    k0 = math.floor(math.log(lo / N0, step))
    k1 = math.ceil(math.log(hi / N0, step))
    centres = N0 * step ** np.arange(k0, k1 + 1)
    return centres, centres / step**0.5, centres * step**0.5


@dataclass(frozen=True)
class RoadClass(Record):
    """ISO 8608 description of a profile (:func:`classify_profile`).

    Attributes
    ----------
    gd_n0_m3 : float
        Fitted ``Gd(n0)`` at n0 = 0.1 cycle/m, m^3.
    waviness : float
        Fitted exponent w (2 for ISO 8608's model roads).
    iso8608_class : str
        ``"A"`` ... ``"H"``.
    class_limits_m3 : (float, float)
        That class's limits of ``Gd(n0)``, m^3.
    band_cycles_per_m : (float, float)
        Band of the fit, cycle/m.
    segment_m : float
        Welch segment length, m.
    band_centres, band_gd : list of float
        The one-third-octave averages the line was fitted to (cycle/m, m^3).
    scatter : float
        Factor by which the band averages scatter about the line (1: on it).
    misfit : float
        The band averages' r.m.s. distance from the line in units of their own
        statistical scatter: about 1 where the line describes the profile.
    waviness_fitted : bool
        False when the band does not reach n0 and ``w`` was held at 2.
    """

    gd_n0_m3: float
    waviness: float
    iso8608_class: str
    class_limits_m3: Tuple[float, float]
    band_cycles_per_m: Tuple[float, float]
    segment_m: float
    band_centres: List[float] = field(default_factory=list)
    band_gd: List[float] = field(default_factory=list)
    scatter: float = 1.0
    misfit: float = 0.0
    waviness_fitted: bool = True

    @property
    def fits(self) -> bool:
        """Whether the ISO 8608 line describes the profile (:data:`POOR_FIT_MISFIT`)."""
        return self.misfit <= POOR_FIT_MISFIT

    def to_dict(self) -> dict:
        """JSON-ready dict (an infinite limit as None)."""
        d = super().to_dict()
        d["class_limits_m3"] = [v if math.isfinite(v) else None for v in self.class_limits_m3]
        return d


def classify_profile(
    distance, elevation, segment_m: float = None, band: Tuple[float, float] = N_BAND
) -> RoadClass:
    """Fit ISO 8608's ``Gd(n0) (n/n0)^-w`` to a profile's PSD and name its class.

    Parameters
    ----------
    distance, elevation : (n,) array_like
        The profile, m, as :func:`profile_psd` takes it (uniformly spaced distances).
    segment_m : float, optional
        Welch segment length, m (see :func:`profile_psd`).
    band : (float, float)
        Widest band of the fit, cycle/m (ISO 8608's classification band).

    Returns
    -------
    RoadClass

    Raises
    ------
    BodyvibError
        A bad profile, or one too short or too coarse to hold two one-third
        octaves of the band (it names what it resolves).

    Examples
    --------
    >>> from bodyvib.vehicle.road.synthetic import random_road
    >>> x = np.arange(0, 1000, 0.05)
    >>> classify_profile(x, random_road("C", 1000.0, seed=3).displacement(x)).iso8608_class
    'C'
    """
    n, gd, segment = profile_psd(distance, elevation, segment_m)
    return _fit_band(n, gd, segment, band, _segments(distance, segment))


def _segments(distance, segment: float) -> int:
    """Welch segments (half overlapping) of ``segment`` metres in a profile."""
    x = np.asarray(distance, dtype=float)
    span = x[-1] - x[0] + (x[1] - x[0])
    return max(1, int(round(2 * span / segment - 1)))


def _fit_band(
    n, gd, segment: float, band: Tuple[float, float] = N_BAND, segments: int = 1
) -> RoadClass:
    """:func:`classify_profile` on a PSD already made: ``n``, ``gd`` and ``segment`` as
    :func:`profile_psd` returns them (cycle/m, m^3, m), ``band`` as there, and the number
    of Welch segments averaged (for the estimate's own scatter)."""
    dx = 1.0 / (2 * n[-1]) if n.size else float("nan")
    lo = max(band[0], 4.0 / segment)
    hi = min(band[1], 1.0 / (4 * dx))
    centres, lower, upper = _third_octaves(lo, hi)
    keep_c, keep_g, keep_k = [], [], []
    for c, a, b in zip(centres, lower, upper):
        sel = (n >= a) & (n < b)
        if c >= lo and c <= hi and np.any(sel):
            keep_c.append(float(c))
            keep_g.append(float(np.mean(gd[sel])))
            keep_k.append(int(np.count_nonzero(sel)) * segments)
    keep_c, keep_g = np.array(keep_c), np.array(keep_g)
    if keep_c.size < 2 or np.any(keep_g <= 0):
        raise BodyvibError(
            f"the profile resolves {lo:.3g}-{hi:.3g} cycle/m (segments of {segment:g} m, spacing "
            f"{dx:g} m), too little of ISO 8608's {band[0]}-{band[1]} cycle/m to fit a class "
            "(two one-third octaves at least); use a longer or finer profile"
        )
    u, g = np.log(keep_c / N0), np.log(keep_g)
    fitted = lo <= N0
    if fitted:
        slope, intercept = np.polyfit(u, g, 1)
    else:  # the band does not reach n0: ISO 8608's waviness, Gd(n0) read off its line
        slope, intercept = -2.0, float(np.mean(g + 2.0 * u))
    residual = g - intercept - slope * u
    scatter = float(np.exp(np.sqrt(np.mean(residual**2))))
    # a band mean of K periodogram values scatters by ~1.28 / sqrt(K) in log (one value:
    # the log of an exponential variate, pi / sqrt(6)); the misfit is the residual in those
    # units: ~1 where the line holds, far more where it does not
    noise = 1.28 / np.sqrt(np.array(keep_k, dtype=float))
    misfit = float(np.sqrt(np.mean((residual / noise) ** 2)))
    gd_n0 = float(math.exp(intercept))
    cls = class_of(gd_n0)
    return RoadClass(
        gd_n0_m3=gd_n0,
        waviness=float(-slope),
        iso8608_class=cls,
        class_limits_m3=class_limits(cls),
        band_cycles_per_m=(float(lo), float(hi)),
        segment_m=float(segment),
        band_centres=keep_c.tolist(),
        band_gd=keep_g.tolist(),
        scatter=scatter,
        misfit=misfit,
        waviness_fitted=bool(fitted),
    )
