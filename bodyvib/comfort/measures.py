"""Measures beside ISO 2631-1's basic figures: absorbed power, motion sickness dose, SEAT.

* **Absorbed power** (W), physical: the mean mechanical power the seat delivers to
  the occupant, ``P = mean(F_s v_s)`` with ``F_s`` the seat force (the occupant
  pushing the seat down, positive in compression, equal to the seat pushing the
  occupant up) and ``v_s`` the seat velocity (up). For a passive body on a
  stationary input it is what the body dissipates. Only a body model gives it
  (:func:`absorbed_power`).
* **Absorbed power** (W), frequency-weighted estimate from the seat acceleration
  alone, after Lee and Pradko (R. A. Lee and F. Pradko, "Analytical analysis of human
  vibration", SAE Technical Paper 680091, 1968): ``P = mean(y^2)`` with ``y`` the
  vertical acceleration in ft/s2 filtered by

      ``H(s) = 14.5 s (s + 44) / ((s + 63) (s^2 + 24 s + 750))``   (s in rad/s),

  the analog vertical filter that Project Chrono's ride logger implements in
  bilinear form (``chrono::utils::ChAbsorbed_Power_Vertical``, ``ChFilters.cpp``;
  the analog form is read off its coefficients). The estimate is what tools
  without a body model report (:func:`lee_pradko_power`).
* **MSDV** (m/s^1.5), ISO 2631-1:1997 clause 9 and Annex D: the motion sickness
  dose value ``MSDV_z = (int a_wf(t)^2 dt)^(1/2)`` of the vertical acceleration
  weighted by **Wf** (Annex A, Table A.1: band limits 0.08 and 0.63 Hz, a-v
  transition f4 = 0.25 Hz, Q4 = 0.86, no f3; upward step f5 = 0.0625 Hz,
  f6 = 0.1 Hz, Q5 = Q6 = 0.80), :func:`msdv`.
* **SEAT** (%), ISO 10326-1: ``100 a_w(seat pan) / a_w(floor)``, both Wk-weighted
  r.m.s. (:func:`seat_value`): below 100 the seat isolates.

:class:`SeatMeasureStream` accumulates the first three block by block (the
co-simulation's study records them per body without keeping histories).
"""

import math
from dataclasses import dataclass

import numpy as np

from ..runtime.errors import BodyvibError
from .figures import _check_signal, _filtered, check_rate, weighted_rms, weighting_response
from .stream import WkFilter, weighting_statespace

__all__ = [
    "WF_PARAMETERS",
    "FEET_PER_METRE",
    "LEE_PRADKO_FILTER",
    "wf_response",
    "wf_statespace",
    "lee_pradko_response",
    "lee_pradko_statespace",
    "msdv",
    "absorbed_power",
    "lee_pradko_power",
    "seat_value",
    "SeatMeasures",
    "SeatMeasureStream",
]

#: Wf parameters of ISO 2631-1:1997 Annex A, Table A.1 (Hz and dimensionless Q); no
#: f3 (the a-v transition has no numerator term).
WF_PARAMETERS = {
    "f1": 0.08,
    "f2": 0.63,
    "Q1": 2**-0.5,
    "f3": math.inf,
    "f4": 0.25,
    "Q4": 0.86,
    "f5": 0.0625,
    "Q5": 0.80,
    "f6": 0.1,
    "Q6": 0.80,
}

#: Feet per metre: the Lee & Pradko filter takes the acceleration in ft/s2.
FEET_PER_METRE = 1.0 / 0.3048

#: The Lee & Pradko vertical absorbed-power filter as (numerator, denominator)
#: polynomial coefficients in s (rad/s), highest power first (module docstring).
LEE_PRADKO_FILTER = (
    (14.5, 14.5 * 44.0, 0.0),
    tuple(np.polymul([1.0, 63.0], [1.0, 24.0, 750.0])),
)


def wf_response(frequencies_hz) -> np.ndarray:
    """Complex Wf weighting (ISO 2631-1 Annex A, motion sickness) at frequencies in Hz.

    Examples
    --------
    >>> round(float(abs(wf_response(0.16)[0])), 3)  # ISO 2631-1 Table 3: 1.006
    1.006
    """
    return weighting_response(WF_PARAMETERS, frequencies_hz)


def wf_statespace():
    """Wf as an 8-state analog state space ``(A, B, C, D)``."""
    return weighting_statespace(WF_PARAMETERS)


def lee_pradko_response(frequencies_hz) -> np.ndarray:
    """Complex response of the Lee & Pradko filter (input ft/s2, output sqrt(W)).

    Examples
    --------
    >>> round(float(abs(lee_pradko_response(4.0)[0])), 3)
    0.443
    """
    s = 2j * np.pi * np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    num, den = LEE_PRADKO_FILTER
    return np.polyval(num, s) / np.polyval(den, s)


def lee_pradko_statespace():
    """The Lee & Pradko filter as a state space ``(A, B, C, D)`` (3 states, input ft/s2)."""
    from scipy.signal import tf2ss

    return tf2ss(*LEE_PRADKO_FILTER)


def msdv(acceleration, fs: float) -> float:
    """Motion sickness dose value of a vertical acceleration record (ISO 2631-1 Annex D).

    Parameters
    ----------
    acceleration : (n,) array_like
        Unweighted vertical acceleration, m/s2, uniformly sampled.
    fs : float
        Sampling rate, Hz.

    Returns
    -------
    float
        ``(int a_wf^2 dt)^(1/2)`` in m/s^1.5 (Wf applied from rest).

    Examples
    --------
    >>> fs = 50.0; t = np.arange(0, 600, 1 / fs)
    >>> a = np.sin(2 * np.pi * 0.16 * t)  # 1 m/s2 peak near Wf's maximum, 10 min
    >>> round(msdv(a, fs) / math.sqrt(0.5 * 600), 2)  # over r.m.s. times sqrt(T)
    1.0
    """
    a = _check_signal(acceleration, fs)
    aw = _filtered(a, fs, wf_response, 120.0)  # Wf's impulse response decays within 2 min
    return float(math.sqrt(np.sum(aw**2) / fs))


def absorbed_power(seat_force, seat_velocity) -> float:
    """Mean power the seat delivers to the occupant, W.

    Parameters
    ----------
    seat_force : (n,) array_like
        N, positive in compression (the occupant pushing the seat down).
    seat_velocity : (n,) array_like
        m/s, positive up, at the same instants.

    Returns
    -------
    float
        ``mean(F_s v_s)``.

    Raises
    ------
    BodyvibError
        Different lengths, empty or non-finite records.

    Examples
    --------
    >>> t = np.linspace(0, 1, 1001)[:-1]
    >>> absorbed_power(np.cos(2 * np.pi * 5 * t), 2 * np.cos(2 * np.pi * 5 * t))  # F v / 2
    1.0
    """
    F = np.asarray(seat_force, dtype=float)
    v = np.asarray(seat_velocity, dtype=float)
    if F.shape != v.shape or F.ndim != 1 or F.size == 0:
        raise BodyvibError("seat force and velocity must be 1-D records of equal length")
    if not (np.all(np.isfinite(F)) and np.all(np.isfinite(v))):
        raise BodyvibError("seat force or velocity contains NaN or infinite values")
    return float(np.mean(F * v))


def lee_pradko_power(acceleration, fs: float) -> float:
    """Absorbed power estimated from a seat acceleration record (Lee & Pradko), W.

    Parameters
    ----------
    acceleration : (n,) array_like
        Vertical seat acceleration, m/s2.
    fs : float
        Sampling rate, Hz.

    Returns
    -------
    float
        ``mean(y^2)``, ``y`` the acceleration in ft/s2 through the filter of the
        module docstring, from rest.

    Examples
    --------
    >>> fs = 1000.0; t = np.arange(0, 60, 1 / fs)
    >>> a = math.sqrt(2) * np.sin(2 * np.pi * 4.0 * t)  # 1 m/s2 r.m.s. at 4 Hz
    >>> round(lee_pradko_power(a, fs), 2)  # |H(4 Hz)|^2 (1 / 0.3048)^2
    2.11
    """
    a = _check_signal(acceleration, fs)
    y = _filtered(a * FEET_PER_METRE, fs, lee_pradko_response, 5.0)
    return float(np.mean(y**2))


def seat_value(seat_acceleration, floor_acceleration, fs: float) -> float:
    """ISO 10326-1 SEAT value, %: Wk r.m.s. on the seat pan over that on the floor.

    Parameters
    ----------
    seat_acceleration, floor_acceleration : (n,) array_like
        m/s2, simultaneous records.
    fs : float
        Hz.

    Returns
    -------
    float

    Examples
    --------
    >>> a = np.random.default_rng(0).standard_normal(5000)
    >>> seat_value(a, a, 500.0)  # a rigid seat
    100.0
    """
    return 100.0 * weighted_rms(seat_acceleration, fs) / weighted_rms(floor_acceleration, fs)


@dataclass(frozen=True)
class SeatMeasures:
    """Absorbed power and motion sickness dose of one run.

    Attributes
    ----------
    absorbed_power_w : float
        ``mean(F_s v_s)``, W (:func:`absorbed_power`).
    lee_pradko_power_w : float
        Frequency-weighted estimate from the seat acceleration, W (:func:`lee_pradko_power`).
    msdv : float
        Seat MSDV, m/s^1.5 (:func:`msdv`).
    spinal_dose : float
        ISO 2631-5:2018 acceleration dose ``Dz`` of the seat acceleration, m/s2
        (:func:`bodyvib.comfort.spine.acceleration_dose`).
    """

    absorbed_power_w: float
    lee_pradko_power_w: float
    msdv: float
    spinal_dose: float = float("nan")

    def to_dict(self) -> dict:
        """The fields as a dict (JSON)."""
        return {
            "absorbed_power_w": self.absorbed_power_w,
            "lee_pradko_power_w": self.lee_pradko_power_w,
            "seat_msdv": self.msdv,
            "seat_spinal_dose_dz": self.spinal_dose,
        }


class SeatMeasureStream:
    """:class:`SeatMeasures` accumulated block by block (no history kept).

    The filters are the analog ones discretized exactly with the input linear between
    samples (:class:`bodyvib.comfort.stream.WkFilter`), started from rest; the figures
    differ from the whole-record ones (FFT) by the interpolation alone.

    Parameters
    ----------
    fs : float
        Sampling rate, Hz.

    Examples
    --------
    >>> s = SeatMeasureStream(1000.0)
    >>> s.update(np.ones(4), np.full(4, 2.0), np.full(4, 0.5))
    >>> s.figures().absorbed_power_w
    1.0
    """

    def __init__(self, fs: float):
        from .spine import spine_statespace

        self.fs = check_rate(fs)
        self._wf = WkFilter(self.fs, 1, statespace=wf_statespace())
        self._lp = WkFilter(self.fs, 1, statespace=lee_pradko_statespace())
        self._spine = WkFilter(self.fs, 1, statespace=spine_statespace())
        self._n = 0
        self._power = self._wf2 = self._lp2 = 0.0
        self._peaks6 = 0.0  # sum of the closed positive runs' maxima^6
        self._run = 0.0  # the open run's maximum (0: none open)

    def update(self, seat_acceleration, seat_force, seat_velocity) -> None:
        """Add the next samples of the seat acceleration (m/s2), force (N) and velocity (m/s)."""
        a = np.asarray(seat_acceleration, dtype=float)
        F = np.asarray(seat_force, dtype=float)
        v = np.asarray(seat_velocity, dtype=float)
        self._power += float(np.dot(F, v))
        self._n += a.size
        self._wf2 += float(np.sum(self._wf.update(a[None, :]) ** 2))
        self._lp2 += float(np.sum(self._lp.update(a[None, :] * FEET_PER_METRE) ** 2))
        self._add_peaks(self._spine.update(a[None, :])[0])

    def _add_peaks(self, r) -> None:
        """Positive runs of the spinal response, continued across blocks."""
        for x in r:
            if x > 0.0:
                self._run = max(self._run, x)
            elif self._run:
                self._peaks6 += self._run**6
                self._run = 0.0

    def figures(self) -> SeatMeasures:
        """The measures so far (NaN before any sample)."""
        if self._n == 0:
            nan = float("nan")
            return SeatMeasures(nan, nan, nan, nan)
        from .spine import DOSE_FACTOR

        return SeatMeasures(
            absorbed_power_w=self._power / self._n,
            lee_pradko_power_w=self._lp2 / self._n,
            msdv=math.sqrt(self._wf2 / self.fs),
            spinal_dose=DOSE_FACTOR * (self._peaks6 + self._run**6) ** (1 / 6),
        )
