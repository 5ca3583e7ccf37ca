"""ISO 2631-1 in every axis: the six weightings, the multiplying factors, the totals.

A seated person is measured at three points (ISO 2631-1:1997, 5.3 and Figure 1): the
seat surface (translations x, y, z and rotations rx, ry, rz), the backrest (x, y, z)
and the feet (x, y, z). Each axis is frequency-weighted (Annex A, Table A.1:
Wk, Wd, Wc, We, Wj, Wf, all of the one form of the Wk weighting)
and gives its own weighted r.m.s. ``a_w``, VDV and MTVV. Axes are combined with
multiplying factors ``k`` (7.2.3 for health, 8.2.2 and 8.2.3 for comfort):

* the **point vibration total value** of one point,
  ``a_v = sqrt(sum_j k_j^2 a_wj^2)`` over its axes (eq. (10));
* the **overall vibration total value** for comfort, the root sum of squares of the
  point values of the seat, the backrest and the feet (8.2.3);
* for **health** (7.2.3, Annex B) the seat surface alone, with ``k`` = 1.4, 1.4, 1
  for x, y, z: the axis with the largest ``k a_w`` is assessed against the health
  guidance caution zone of Annex B, Figure B.1 (:func:`health_guidance`).

Rotations are in rad/s2 and their factors in m/rad, so that ``k a_w`` is in m/s2.
Table :data:`SEATED_AXES` names every axis with its weighting and factors.
"""

from dataclasses import asdict, dataclass, field
from typing import Dict, Mapping, Optional, Tuple

import numpy as np

from ..runtime.errors import BodyvibError
from .figures import (
    WK_PARAMETERS,
    _check_signal,
    _filtered,
    _mtvv,
    _peak,
    _rms,
    _vdv,
    comfort_category,
    weighting_response,
)
from .measures import WF_PARAMETERS
from .validity import governing_method

__all__ = [
    "WEIGHTINGS",
    "SEATED_AXES",
    "POINTS",
    "weighting",
    "weighted_axis",
    "AxisFigures",
    "axis_figures",
    "VibrationTotals",
    "vibration_totals",
    "HEALTH_CAUTION_ZONE",
    "HealthGuidance",
    "health_guidance",
]

_INF = float("inf")
_BAND = {"f1": 0.4, "f2": 100.0, "Q1": 2**-0.5}
_NO_STEP = {"f5": _INF, "Q5": 1.0, "f6": _INF, "Q6": 1.0}

#: The frequency weightings of ISO 2631-1:1997 Annex A, Table A.1 (Hz and Q): band
#: limits f1, f2 (Q1 = 1/sqrt(2)), the a-v transition f3, f4, Q4, the upward step
#: f5, Q5, f6, Q6; ``inf`` where the table leaves a term out.
WEIGHTINGS: Dict[str, Dict[str, float]] = {
    "Wk": dict(WK_PARAMETERS),
    "Wd": {**_BAND, "f3": 2.0, "f4": 2.0, "Q4": 0.63, **_NO_STEP},
    "Wf": dict(WF_PARAMETERS),
    "Wc": {**_BAND, "f3": 8.0, "f4": 8.0, "Q4": 0.63, **_NO_STEP},
    "We": {**_BAND, "f3": 1.0, "f4": 1.0, "Q4": 0.63, **_NO_STEP},
    "Wj": {
        **_BAND,
        "f3": _INF,
        "f4": _INF,
        "Q4": 1.0,
        "f5": 3.75,
        "Q5": 0.91,
        "f6": 5.32,
        "Q6": 0.91,
    },
}

#: Every axis of a seated person: name -> (weighting, k for comfort, k for health or
#: None, unit of the signal). Comfort factors: ISO 2631-1 8.2.2 and 8.2.3 (rotations
#: in m/rad); health factors: 7.2.3 (seat surface translations only).
SEATED_AXES: Dict[str, Tuple[str, float, Optional[float], str]] = {
    "seat_x": ("Wd", 1.0, 1.4, "m/s2"),
    "seat_y": ("Wd", 1.0, 1.4, "m/s2"),
    "seat_z": ("Wk", 1.0, 1.0, "m/s2"),
    "seat_rx": ("We", 0.63, None, "rad/s2"),
    "seat_ry": ("We", 0.40, None, "rad/s2"),
    "seat_rz": ("We", 0.20, None, "rad/s2"),
    "backrest_x": ("Wc", 0.80, None, "m/s2"),
    "backrest_y": ("Wd", 0.50, None, "m/s2"),
    "backrest_z": ("Wd", 0.40, None, "m/s2"),
    "feet_x": ("Wk", 0.25, None, "m/s2"),
    "feet_y": ("Wk", 0.25, None, "m/s2"),
    "feet_z": ("Wk", 0.40, None, "m/s2"),
}

#: The measuring points of a seated person and their axes (the seat's translations
#: and rotations are two points of one surface, as the standard combines them).
POINTS: Dict[str, Tuple[str, ...]] = {
    "seat": ("seat_x", "seat_y", "seat_z"),
    "seat_rotation": ("seat_rx", "seat_ry", "seat_rz"),
    "backrest": ("backrest_x", "backrest_y", "backrest_z"),
    "feet": ("feet_x", "feet_y", "feet_z"),
}


def _parameters(name: str) -> Dict[str, float]:
    try:
        return WEIGHTINGS[name]
    except KeyError:
        raise BodyvibError(
            f"unknown frequency weighting {name!r}; ISO 2631-1 defines {', '.join(WEIGHTINGS)}"
        ) from None


def weighting(name: str, frequencies_hz) -> np.ndarray:
    """Complex ISO 2631-1 frequency weighting ``name`` at the given frequencies.

    Parameters
    ----------
    name : {"Wk", "Wd", "Wf", "Wc", "We", "Wj"}
        The weighting (Annex A, Table A.1).
    frequencies_hz : array_like
        Frequencies in Hz.

    Returns
    -------
    ndarray of complex
        The weighting factor; its modulus is the factor of Tables 3 and 4.

    Raises
    ------
    BodyvibError
        An unknown weighting name.

    Examples
    --------
    >>> round(float(abs(weighting("Wd", 1.0)[0])), 3)  # ISO 2631-1 Table 3: 1.011
    1.011
    >>> round(float(abs(weighting("Wc", 4.0)[0])), 3)  # Table 4: 1.024
    1.024
    """
    return weighting_response(_parameters(name), frequencies_hz)


def weighted_axis(acceleration, fs: float, name: str = "Wk") -> np.ndarray:
    """A record weighted with the ISO 2631-1 weighting ``name`` (analog filter from rest).

    The same method as :func:`~bodyvib.comfort.weighted_acceleration` (the analog
    response on the FFT bins of the zero-padded record), for any of the six
    weightings.

    Parameters
    ----------
    acceleration : (n,) array_like
        Unweighted acceleration (m/s2, or rad/s2 for a rotation), uniformly sampled.
    fs : float
        Sampling rate in Hz.
    name : str
        The weighting, a key of :data:`WEIGHTINGS`.

    Returns
    -------
    (n,) ndarray
        The weighted record, in the unit of the input.

    Raises
    ------
    BodyvibError
        Bad samples or rate, or an unknown weighting.

    Examples
    --------
    >>> from bodyvib.comfort import weighted_acceleration
    >>> a = np.sin(2 * np.pi * 4.0 * np.arange(2000) / 1000.0)
    >>> bool(np.allclose(weighted_axis(a, 1000.0, "Wk"), weighted_acceleration(a, 1000.0)))
    True
    """
    parameters = _parameters(name)
    a = _check_signal(acceleration, fs)
    return _filtered(a, fs, lambda f: weighting_response(parameters, f), 8.0)


@dataclass(frozen=True)
class AxisFigures:
    """The ISO 2631-1 figures of one axis (:func:`axis_figures`).

    Attributes
    ----------
    axis : str
        The axis, a key of :data:`SEATED_AXES` (``"seat_x"``, ...).
    weighting : str
        Its frequency weighting.
    unit : str
        Unit of the weighted r.m.s., MTVV and peak (m/s2 or rad/s2).
    weighted_rms, vdv, mtvv, peak, crest_factor : float
        Weighted r.m.s. ``a_w``, vibration dose value (unit times s^0.25), maximum
        transient vibration value, peak and ``peak / a_w``.
    k_comfort : float
        Multiplying factor for comfort (m/rad for a rotation).
    k_health : float or None
        Multiplying factor for health (seat translations only).
    comfort_method : str
        Which ISO 2631-1 method governs the axis (clause 6.3,
        :func:`~bodyvib.comfort.validity.governing_method`): ``"basic"`` (the r.m.s.
        suffices), ``"vdv"`` or ``"mtvv"``.
    """

    axis: str
    weighting: str
    unit: str
    weighted_rms: float
    vdv: float
    mtvv: float
    peak: float
    crest_factor: float
    k_comfort: float
    k_health: Optional[float]
    comfort_method: str = "basic"


def axis_figures(acceleration, fs: float, axis: str) -> AxisFigures:
    """Weight one axis of a seated person and compute its figures.

    Parameters
    ----------
    acceleration : (n,) array_like
        The axis's unweighted record (m/s2; rad/s2 for ``seat_rx/ry/rz``).
    fs : float
        Sampling rate in Hz.
    axis : str
        A key of :data:`SEATED_AXES`: it chooses the weighting and the factors.

    Returns
    -------
    AxisFigures

    Raises
    ------
    BodyvibError
        An unknown axis, bad samples or a bad rate.

    Examples
    --------
    >>> t = np.arange(20000) / 1000.0
    >>> f = axis_figures(np.sin(2 * np.pi * 1.0 * t), 1000.0, "seat_x")
    >>> f.weighting, round(float(f.weighted_rms), 2)  # Wd is 1.011 at 1 Hz: 1.011 / sqrt(2)
    ('Wd', 0.71)
    """
    try:
        name, k_comfort, k_health, unit = SEATED_AXES[axis]
    except KeyError:
        raise BodyvibError(
            f"unknown axis {axis!r}; the axes are {', '.join(SEATED_AXES)}"
        ) from None
    aw = weighted_axis(acceleration, fs, name)
    rms, pk, vdv, mtvv = _rms(aw), _peak(aw), _vdv(aw, fs), _mtvv(aw, fs)
    crest = pk / rms if rms > 0 else float("nan")
    return AxisFigures(
        axis=axis,
        weighting=name,
        unit=unit,
        weighted_rms=rms,
        vdv=vdv,
        mtvv=mtvv,
        peak=pk,
        crest_factor=crest,
        k_comfort=k_comfort,
        k_health=k_health,
        comfort_method=governing_method(rms, crest, mtvv, vdv, aw.size / fs),
    )


def _total(values) -> float:
    return float(np.sqrt(sum(v * v for v in values)))


#: The health guidance caution zone of ISO 2631-1 Annex B, Figure B.1, for the
#: r.m.s. time dependence of eq. (B.1) (``a_w T^1/2`` constant): its lower and upper
#: bounds at 8 h of daily exposure, m/s2 (through about 3 and 6 m/s2 at 10 min); and
#: for the fourth-power dependence of eq. (B.2) its bounds in VDV, m/s^1.75.
HEALTH_CAUTION_ZONE = {"rms_8h": (0.43, 0.87), "vdv": (8.5, 17.0)}


@dataclass(frozen=True)
class HealthGuidance:
    """Where a daily exposure lies against ISO 2631-1 Annex B (:func:`health_guidance`).

    Attributes
    ----------
    value : float
        The assessed weighted r.m.s. ``k a_w``, m/s2.
    exposure_s : float
        Daily exposure time, s.
    lower, upper : float
        The zone's bounds at that exposure by eq. (B.1), m/s2.
    zone : str
        ``"below"`` (health effects not clearly documented), ``"caution"`` (potential
        health risks) or ``"above"`` (health risks likely).
    """

    value: float
    exposure_s: float
    lower: float
    upper: float
    zone: str


def health_guidance(value: float, exposure_s: float = 8 * 3600.0) -> HealthGuidance:
    """A weighted r.m.s. against the health guidance caution zone (eq. (B.1)).

    Parameters
    ----------
    value : float
        The weighted r.m.s. of the dominant seat axis with its health factor
        (``max(1.4 a_wx, 1.4 a_wy, a_wz)``), m/s2.
    exposure_s : float
        Daily exposure, s (default 8 h). The standard's guidance rests mainly on
        4 h to 8 h; the zone is scaled as ``T^-1/2`` from its 8 h bounds.

    Returns
    -------
    HealthGuidance

    Raises
    ------
    BodyvibError
        A negative or non-finite value, or a non-positive exposure.

    Examples
    --------
    >>> health_guidance(0.5).zone
    'caution'
    >>> round(health_guidance(1.0, 3600.0).upper, 2)  # 0.87 sqrt(8)
    2.46
    """
    v, t = float(value), float(exposure_s)
    if not (np.isfinite(v) and v >= 0):
        raise BodyvibError(f"a weighted r.m.s. must be a non-negative number, got {value!r}")
    if not (np.isfinite(t) and t > 0):
        raise BodyvibError(f"the daily exposure must be a positive number of s, got {exposure_s!r}")
    scale = np.sqrt(8 * 3600.0 / t)
    lower, upper = (b * scale for b in HEALTH_CAUTION_ZONE["rms_8h"])
    zone = "below" if v < lower else ("caution" if v <= upper else "above")
    return HealthGuidance(value=v, exposure_s=t, lower=float(lower), upper=float(upper), zone=zone)


@dataclass(frozen=True)
class VibrationTotals:
    """The ISO 2631-1 figures of a seated person in every measured axis.

    Attributes
    ----------
    axes : dict
        Axis name -> :class:`AxisFigures`, for each axis given.
    points : dict
        Point name (``"seat"``, ``"seat_rotation"``, ``"backrest"``, ``"feet"``) ->
        its point vibration total value for comfort ``sqrt(sum k^2 a_w^2)``, m/s2,
        for each point with at least one axis given.
    overall : float
        Overall vibration total value for comfort, the root sum of squares of the
        point values, m/s2.
    comfort : str
        ISO 2631-1 Annex C words for ``overall``.
    health_value : float
        ``max(k a_w)`` over the seat's translations with the health factors (NaN
        when none is given), m/s2.
    health : HealthGuidance or None
        ``health_value`` against the caution zone at the exposure given.
    """

    axes: Dict[str, AxisFigures]
    points: Dict[str, float]
    overall: float
    comfort: str
    health_value: float
    health: Optional[HealthGuidance] = field(default=None)

    def to_dict(self) -> Dict[str, object]:
        """The totals as a JSON-ready dict."""
        return asdict(self)


def vibration_totals(
    signals: Mapping[str, object], fs: float, exposure_s: float = 8 * 3600.0
) -> VibrationTotals:
    """Every axis's figures, the point and overall totals, and the health guidance.

    Parameters
    ----------
    signals : mapping
        Axis name (keys of :data:`SEATED_AXES`) -> unweighted record; any subset of
        the axes, all of one length.
    fs : float
        Sampling rate in Hz.
    exposure_s : float
        Daily exposure for the health guidance, s (default 8 h).

    Returns
    -------
    VibrationTotals

    Raises
    ------
    BodyvibError
        No signal, an unknown axis, records of different lengths, bad samples.

    Examples
    --------
    >>> t = np.arange(20000) / 1000.0
    >>> s = {"seat_x": 0.3 * np.sin(2 * np.pi * t), "seat_z": np.sin(2 * np.pi * 5 * t)}
    >>> tot = vibration_totals(s, 1000.0)
    >>> a = [tot.axes[k].weighted_rms for k in ("seat_x", "seat_z")]
    >>> bool(abs(tot.points["seat"] - np.hypot(*a)) < 1e-12)
    True
    """
    if not signals:
        raise BodyvibError(f"no signal given; name axes among {', '.join(SEATED_AXES)}")
    lengths = {np.size(v) for v in signals.values()}
    if len(lengths) > 1:
        raise BodyvibError(f"the axes' records differ in length ({sorted(lengths)} samples)")
    axes = {name: axis_figures(a, fs, name) for name, a in signals.items()}
    points = {
        point: _total(axes[a].k_comfort * axes[a].weighted_rms for a in names if a in axes)
        for point, names in POINTS.items()
        if any(a in axes for a in names)
    }
    overall = _total(points.values())
    health = [f.k_health * f.weighted_rms for f in axes.values() if f.k_health is not None]
    health_value = max(health) if health else float("nan")
    return VibrationTotals(
        axes=axes,
        points=points,
        overall=overall,
        comfort=comfort_category(overall),
        health_value=health_value,
        health=health_guidance(health_value, exposure_s) if health else None,
    )
