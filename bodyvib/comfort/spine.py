"""ISO 2631-5:2018, vertical axis: spinal response, acceleration dose and injury risk.

ISO 2631-5:2018 (*Method for evaluation of vibration containing multiple shocks*)
judges repeated shocks by the response of the lumbar spine, vertical axis only:

* **Seat-to-spine transfer function** (clause 5.2, Formula 1), in ``s = j w`` (rad/s),

      ``H(s) = (1 + 2 z1 s / w1 + (s / w1)^2) / prod_k (1 + 2 zk s / wk + (s / wk)^2)``

  with the zero ``(w1, z1) = (34, 0.35)`` and six pole pairs ``(wk, zk)`` = (31, 0.21),
  (230, 0.88), (260, 0.80), (320, 0.40), (380, 0.75), (420, 0.65) (:data:`SPINE_ZERO`,
  :data:`SPINE_POLES`); unity at 0 Hz. The spinal response ``Az(t)`` is the seat
  acceleration through ``H`` (Formula 2), here the analog filter applied from rest.
* **Acceleration dose** (clause 5.3, Formula 3): ``Dz = 1.07 (sum_i Az,i^6)^(1/6)`` over
  the positive peaks of ``Az`` (the largest value between consecutive zero crossings);
  the **daily dose** ``Dzd = Dz (td / tm)^(1/6)`` for a daily exposure ``td`` measured
  over ``tm`` (Formula 4).
* **Annex C** (adverse health effects): the daily compressive stress ``Sd = mz Dzd``
  (Formula C.1; ``mz`` = 0.029 MPa per m/s2 for men, 0.025 for women, Formula C.2), the
  static stress ``Sstat = 9.81 mz``, the ultimate strength of the ageing spine
  ``Su(age) = 6.75 - Sage age`` MPa (``Sage`` = 0.052 MPa/year for men, 0.039 for women,
  Formula C.4), the stress variable over ``n`` years of ``N`` days from age ``b``
  ``R = [sum_{i=0}^{n-1} (Sd N^(1/6) / (Su(b + i) - Sstat))^6]^(1/6)`` (Formula C.3) and
  the probability of a lumbar injury ``P = 1 - exp(-(R / alpha)^beta)`` (Formula C.5;
  Weibull ``(alpha, beta)`` = (1.613, 2.799) for men, (0.959, 3.709) for women,
  Table C.1). Table C.2 lists the R of 10, 50 and 90 % risk (men 0.72, 1.42, 2.17).

The standard text was not at hand when this module was written: the coefficients are
those of the open implementation in the ``phonometry`` package (module
``multiple_shock_vibration``, with the clause of each), transcribed, and checked for
consistency where two parts of the standard meet (Table C.2 follows from Table C.1 to
its rounding). Check them against ISO 2631-5:2018 before relying on a risk figure.
"""

import math
from dataclasses import dataclass

import numpy as np

from ..runtime.errors import BodyvibError
from .figures import _check_signal, _filtered

__all__ = [
    "SPINE_ZERO",
    "SPINE_POLES",
    "DOSE_FACTOR",
    "MZ",
    "STRENGTH_AGE_SLOPE",
    "WEIBULL",
    "spine_response",
    "spine_statespace",
    "spinal_response",
    "response_peaks",
    "acceleration_dose",
    "daily_dose",
    "injury_risk",
    "injury_probability",
    "SpinalDose",
    "spinal_dose",
]

#: Zero ``(w1 [rad/s], z1)`` of the seat-to-spine transfer function (clause 5.2, Formula 1).
SPINE_ZERO = (34.0, 0.35)
#: Pole pairs ``(wk [rad/s], zk)`` of the seat-to-spine transfer function (Formula 1).
SPINE_POLES = (
    (31.0, 0.21),
    (230.0, 0.88),
    (260.0, 0.80),
    (320.0, 0.40),
    (380.0, 0.75),
    (420.0, 0.65),
)
#: Factor of the acceleration dose (clause 5.3, Formula 3).
DOSE_FACTOR = 1.07
#: Stress per unit acceleration dose ``mz``, MPa per m/s2 (Annex C, Formula C.2).
MZ = {"male": 0.029, "female": 0.025}
#: Loss of ultimate strength with age ``Sage``, MPa/year (Annex C, Formula C.4).
STRENGTH_AGE_SLOPE = {"male": 0.052, "female": 0.039}
#: Ultimate strength at age 0, MPa (Annex C, Formula C.4).
STRENGTH_AT_ZERO = 6.75
#: Weibull ``(alpha, beta)`` of the injury probability (Annex C, Table C.1).
WEIBULL = {"male": (1.613, 2.799), "female": (0.959, 3.709)}
#: Gravity of the static stress, m/s2 (Annex C).
GRAVITY = 9.81


def spine_response(frequencies_hz) -> np.ndarray:
    """Complex seat-to-spine transfer function ``H`` at frequencies in Hz (Formula 1).

    Examples
    --------
    >>> float(abs(spine_response(0.0)[0]))
    1.0
    """
    s = 2j * np.pi * np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    w, z = SPINE_ZERO
    h = 1 + 2 * z * s / w + (s / w) ** 2
    for w, z in SPINE_POLES:
        h = h / (1 + 2 * z * s / w + (s / w) ** 2)
    return h


def spine_statespace():
    """Formula 1 as a state space ``(A, B, C, D)`` (12 states, unity DC gain)."""
    from scipy.signal import tf2ss

    w, z = SPINE_ZERO
    num = np.array([1 / w**2, 2 * z / w, 1.0])
    den = np.array([1.0])
    for w, z in SPINE_POLES:
        den = np.polymul(den, [1 / w**2, 2 * z / w, 1.0])
    return tf2ss(num / den[0], den / den[0])


def spinal_response(acceleration, fs: float) -> np.ndarray:
    """Spinal response ``Az(t)`` of a seat acceleration record (Formula 2), from rest.

    Parameters
    ----------
    acceleration : (n,) array_like
        Vertical seat acceleration without its mean (gravity removed), m/s2.
    fs : float
        Sampling rate, Hz.

    Returns
    -------
    (n,) ndarray
        m/s2: the analog filter applied from rest (FFT of the record zero-padded by
        its length plus 2 s, in which the response decays).
    """
    return _filtered(_check_signal(acceleration, fs), fs, spine_response, 2.0)


def response_peaks(response) -> np.ndarray:
    """Positive peaks: the largest value of each run of positive samples (clause 5.3).

    Samples within 1e-9 of the largest magnitude of zero count as zero (the rounding of
    a filtered record at rest is not a crossing).

    Examples
    --------
    >>> response_peaks([0.0, 1.0, 3.0, 2.0, -1.0, 0.5, -0.2, 4.0]).tolist()
    [3.0, 0.5, 4.0]
    """
    r = np.asarray(response, dtype=float)
    tiny = 1e-9 * np.abs(r).max(initial=0.0)
    pos = np.concatenate([[False], r > tiny, [False]])
    starts = np.flatnonzero(~pos[:-1] & pos[1:])
    if starts.size == 0:
        return np.empty(0)
    return np.maximum.reduceat(r, starts)


def acceleration_dose(acceleration, fs: float) -> float:
    """Acceleration dose ``Dz = 1.07 (sum Az,i^6)^(1/6)`` of a seat record, m/s2 (Formula 3).

    Examples
    --------
    >>> fs = 1000.0; t = np.arange(0, 3, 1 / fs)
    >>> a = np.where((t > 1) & (t < 1.1), 10 * np.sin(np.pi * (t - 1) / 0.1), 0.0)  # 1 shock
    >>> round(acceleration_dose(a, fs), 2)
    11.7
    """
    peaks = response_peaks(spinal_response(acceleration, fs))
    return float(DOSE_FACTOR * np.sum(peaks**6) ** (1 / 6)) if peaks.size else 0.0


def daily_dose(dose: float, exposure_s: float, measured_s: float) -> float:
    """Daily dose ``Dzd = Dz (td / tm)^(1/6)`` (Formula 4), m/s2."""
    if not (exposure_s > 0 and measured_s > 0):
        raise BodyvibError("exposure and measurement times must be positive")
    return float(dose * (exposure_s / measured_s) ** (1 / 6))


def _sex(sex):
    if sex not in MZ:
        raise BodyvibError(f"sex must be 'male' or 'female', not {sex!r}")
    return sex


def injury_risk(
    daily_dose_value: float, start_age: float, years: int, days_per_year: float, sex="male"
) -> float:
    """Stress variable ``R`` of a working life (Annex C, Formulae C.1, C.3, C.4).

    Parameters
    ----------
    daily_dose_value : float
        ``Dzd``, m/s2.
    start_age : float
        Age at the start of the exposure, years.
    years : int
        Years of exposure.
    days_per_year : float
        Exposure days per year.
    sex : str
        ``"male"`` or ``"female"``.

    Returns
    -------
    float
        ``R``, dimensionless (:func:`injury_probability` turns it into a risk).

    Raises
    ------
    BodyvibError
        No years, or an age at which the spine's strength is used up by the static
        stress (outside the model).
    """
    sex = _sex(sex)
    if int(years) < 1 or not days_per_year > 0:
        raise BodyvibError("give at least one year and a positive number of days per year")
    mz = MZ[sex]
    ages = float(start_age) + np.arange(int(years))
    margin = STRENGTH_AT_ZERO - STRENGTH_AGE_SLOPE[sex] * ages - mz * GRAVITY
    if np.any(margin <= 0):
        raise BodyvibError("the spine's ultimate strength is used up within these ages")
    sd = mz * daily_dose_value
    return float(np.sum((sd * days_per_year ** (1 / 6) / margin) ** 6) ** (1 / 6))


def injury_probability(risk: float, sex="male") -> float:
    """Probability of a lumbar injury ``P = 1 - exp(-(R / alpha)^beta)`` (Formula C.5).

    Examples
    --------
    >>> round(injury_probability(1.42), 2)  # Table C.2: R of 50 % risk for men
    0.5
    """
    alpha, beta = WEIBULL[_sex(sex)]
    return float(1.0 - math.exp(-((max(risk, 0.0) / alpha) ** beta)))


@dataclass(frozen=True)
class SpinalDose:
    """ISO 2631-5 figures of a seat record (:func:`spinal_dose`).

    Attributes
    ----------
    dose : float
        ``Dz`` over the record, m/s2.
    daily_dose : float
        ``Dzd`` for the daily exposure, m/s2.
    compression : float
        Daily compressive stress ``Sd = mz Dzd``, MPa.
    exposure_s : float
        The daily exposure ``Dzd`` is for, s.
    peaks : int
        Positive response peaks counted.
    """

    dose: float
    daily_dose: float
    compression: float
    exposure_s: float
    peaks: int

    def to_dict(self) -> dict:
        """The fields (JSON)."""
        return {
            "spinal_dose_dz": self.dose,
            "spinal_daily_dose_dzd": self.daily_dose,
            "spinal_compression_sd_mpa": self.compression,
            "spinal_exposure_s": self.exposure_s,
            "spinal_peaks": self.peaks,
        }


def spinal_dose(acceleration, fs: float, exposure_s: float = 8 * 3600.0, sex="male") -> SpinalDose:
    """``Dz``, ``Dzd`` and ``Sd`` of a seat record, its daily exposure ``exposure_s``.

    Parameters
    ----------
    acceleration : (n,) array_like
        Vertical seat acceleration (mean removed), m/s2.
    fs : float
        Hz.
    exposure_s : float
        Daily exposure ``td`` the record stands for, s (8 h by default).
    sex : str
        For ``mz``.

    Returns
    -------
    SpinalDose
    """
    a = _check_signal(acceleration, fs)
    peaks = response_peaks(spinal_response(a, fs))
    dz = float(DOSE_FACTOR * np.sum(peaks**6) ** (1 / 6)) if peaks.size else 0.0
    dzd = daily_dose(dz, exposure_s, a.size / fs)
    return SpinalDose(dz, dzd, MZ[_sex(sex)] * dzd, float(exposure_s), int(peaks.size))
