"""ISO 2631-1 whole-body vibration figures: Wk weighting, weighted r.m.s., VDV, peak.

The vertical (z, seated) frequency weighting Wk of ISO 2631-1:1997, Annex A,
is the product of four analog filters in ``p = j 2 pi f``:

============================ ==============================================
band limiting, high pass     ``p^2 / (p^2 + w1 p / Q1 + w1^2)``, f1 = 0.4 Hz
band limiting, low pass      ``w2^2 / (p^2 + w2 p / Q1 + w2^2)``, f2 = 100 Hz
a-v transition               ``(1 + p/w3) / (1 + p/(Q4 w4) + (p/w4)^2)``,
                             f3 = f4 = 12.5 Hz, Q4 = 0.63
upward step                  ``(1 + p/(Q5 w5) + (p/w5)^2) / (1 + p/(Q6 w6)
                             + (p/w6)^2) (w5/w6)^2``, f5 = 2.37 Hz,
                             f6 = 3.35 Hz, Q5 = Q6 = 0.91
============================ ==============================================

with Q1 = 1/sqrt(2) (Butterworth) and ``w = 2 pi f``. A time history is
weighted by multiplying its spectrum by this analog response on the FFT bins of
the zero-padded record: that is the causal analog filter started from rest,
without the frequency warping of a bilinear (digital) version, which would
shift the 100 Hz band limit at the 1 kHz sampling of a 1 ms co-simulation.

Figures (ISO 2631-1 clause 6):

* weighted r.m.s. ``a_w = sqrt(mean(a_w(t)^2))`` [m/s2];
* vibration dose value ``VDV = (int a_w(t)^4 dt)^(1/4)`` [m/s^1.75];
* peak ``max |a_w(t)|`` [m/s2] and crest factor ``peak / a_w`` [-];
* maximum transient vibration value ``MTVV = max_t0 a_w(t0)`` [m/s2], the
  largest running r.m.s. of ISO 2631-1 eq. (4) with *linear* integration
  (eq. (4) as written, not the exponential variant of its note) over
  ``tau = 1 s``: ``a_w(t0) = sqrt(1/tau int_{t0-tau}^{t0} a_w(t)^2 dt)``.
  Discretely, the mean of ``a_w^2`` over the last ``N = round(fs tau)``
  samples, with the weighted signal zero before the record (the Wk filter
  starts from rest), so every sample ends a window and a record shorter than
  1 s still has one (its energy over 1 s).

The standard's basic method (the weighted r.m.s.) is not enough when the
crest factor exceeds 9, ``MTVV / a_w`` exceeds 1.5 or ``VDV / (a_w T^1/4)``
exceeds 1.75 (clause 6.3, eqs. (7) and (8)); :func:`basic_method_checks`
reports these ratios.

The comfort scale of ISO 2631-1 Annex C (public transport) names the
weighted r.m.s.; see :func:`comfort_category`.
"""

from dataclasses import asdict, dataclass
from typing import Dict

import numpy as np

from ..process import interrupts
from ..runtime.errors import BodyvibError
from ..runtime.renames import renamed_parameters

__all__ = [
    "WK_PARAMETERS",
    "COMFORT_SCALE",
    "wk_response",
    "weighting_response",
    "weighted_acceleration",
    "weighted_rms",
    "vdv",
    "peak",
    "comfort_category",
    "ComfortFigures",
    "comfort_figures",
    "MTVV_WINDOW_S",
    "running_rms",
    "mtvv",
    "basic_method_checks",
    "BASIC_METHOD_LIMITS",
    "check_rate",
]

#: Integration time of the running r.m.s. of the MTVV (ISO 2631-1 eq. (4)), s.
MTVV_WINDOW_S = 1.0

#: Wk parameters of ISO 2631-1:1997 Annex A, Table A.1 (Hz and dimensionless Q).
WK_PARAMETERS: Dict[str, float] = {
    "f1": 0.4,
    "f2": 100.0,
    "Q1": 2**-0.5,
    "f3": 12.5,
    "f4": 12.5,
    "Q4": 0.63,
    "f5": 2.37,
    "Q5": 0.91,
    "f6": 3.35,
    "Q6": 0.91,
}

#: ISO 2631-1:1997 Annex C: likely reactions to overall weighted r.m.s. values
#: in public transport, as (lower bound, upper bound, words) in m/s2. The
#: standard's bands overlap; a value is given every band that contains it.
COMFORT_SCALE = (
    (0.0, 0.315, "not uncomfortable"),
    (0.315, 0.63, "a little uncomfortable"),
    (0.5, 1.0, "fairly uncomfortable"),
    (0.8, 1.6, "uncomfortable"),
    (1.25, 2.5, "very uncomfortable"),
    (2.0, float("inf"), "extremely uncomfortable"),
)


def wk_response(frequencies_hz) -> np.ndarray:
    """Complex Wk frequency weighting (ISO 2631-1 Annex A) at the given frequencies.

    Parameters
    ----------
    frequencies_hz : array_like
        Frequencies in Hz (0 allowed).

    Returns
    -------
    ndarray of complex
        Weighting factor (dimensionless); its modulus is the factor tabulated in
        ISO 2631-1 Table 3 (e.g. 0.482 at 1 Hz, 1.054 at 6.3 Hz).

    Examples
    --------
    >>> round(float(abs(wk_response(1.0)[0])), 3)
    0.482
    """
    return weighting_response(WK_PARAMETERS, frequencies_hz)


def weighting_response(parameters, frequencies_hz) -> np.ndarray:
    """Complex response of an ISO 2631-1 Annex A weighting (band limits, transition, step).

    Parameters
    ----------
    parameters : dict
        ``f1 ... f6`` (Hz), ``Q1, Q4, Q5, Q6`` as in :data:`WK_PARAMETERS`; ``f3``
        may be ``inf`` (no numerator term in the a-v transition, as in Wf), ``f3``
        and ``f4`` both ``inf`` (no transition, as in Wj), ``f5`` and ``f6`` both
        ``inf`` (no upward step, as in Wd, Wc and We).
    frequencies_hz : array_like
        Frequencies in Hz (0 allowed).

    Returns
    -------
    ndarray of complex
    """
    P = parameters
    p = 2j * np.pi * np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    w1, w2, w3, w4, w5, w6 = (2 * np.pi * P[k] for k in ("f1", "f2", "f3", "f4", "f5", "f6"))
    q1 = P["Q1"]
    high = p**2 / (p**2 + w1 * p / q1 + w1**2)
    low = w2**2 / (p**2 + w2 * p / q1 + w2**2)
    # a corner at infinity removes its term (the standard's Table A.1 leaves it blank)
    transition = (1 + p / w3) / (1 + p / (P["Q4"] * w4) + (p / w4) ** 2)
    if np.isinf(w5):
        return high * low * transition
    step = (
        (1 + p / (P["Q5"] * w5) + (p / w5) ** 2)
        / (1 + p / (P["Q6"] * w6) + (p / w6) ** 2)
        * (w5 / w6) ** 2
    )
    return high * low * transition * step


# What every function of one unweighted record takes and refuses, written once and put
# into their docstrings by :func:`_record_doc` (``%(record)s``, ``%(record_raises)s``).
_RECORD_DOC = {
    "record": """Parameters
    ----------
    acceleration : (n,) array_like
        Unweighted vertical (z) acceleration in m/s2, uniformly sampled, at
        least two finite samples.
    fs : float
        Sampling rate in Hz, positive and finite.""",
    "record_raises": """Raises
    ------
    BodyvibError
        Non-finite samples, fewer than two samples, or a bad sampling rate.""",
}


def _record_doc(function):
    """Fill the shared parameter and error sections into ``function``'s docstring."""
    if function.__doc__:  # None under python -OO
        function.__doc__ = function.__doc__ % _RECORD_DOC
    return function


def _check_signal(a, fs):
    a = np.asarray(a, dtype=float)
    if a.ndim != 1 or a.size < 2:
        raise BodyvibError("acceleration must be a 1-D array of at least 2 samples")
    if not np.all(np.isfinite(a)):
        raise BodyvibError("acceleration contains NaN or infinite values; clean the signal")
    check_rate(fs)
    return a


def check_rate(fs) -> float:
    """A sampling rate, checked: a positive finite number of Hz.

    Parameters
    ----------
    fs : float
        Sampling rate in Hz.

    Returns
    -------
    float
        ``fs`` as a float.

    Raises
    ------
    BodyvibError
        ``fs`` is not a number, not finite or not positive.

    Examples
    --------
    >>> check_rate(1000)
    1000.0
    """
    try:
        ok = bool(np.isfinite(fs) and fs > 0)
    except TypeError:
        ok = False
    if not ok:
        raise BodyvibError(f"sampling rate must be a positive number of Hz, got {fs!r}")
    return float(fs)


@_record_doc
def weighted_acceleration(acceleration, fs: float) -> np.ndarray:
    """Wk-weighted acceleration time history (ISO 2631-1).

    %(record)s

    Returns
    -------
    (n,) ndarray
        Weighted acceleration in m/s2: the analog Wk filter applied from rest
        (the record is zero-padded to twice its length plus 8 s, so that the
        circular FFT convolution equals the linear one for the filter's
        impulse response, which decays within a few seconds).

    %(record_raises)s
    """
    return _filtered(_check_signal(acceleration, fs), fs, wk_response, 8.0)


def _filtered(a, fs, response, settle_s):
    """A record filtered by an analog response from rest (FFT of the zero-padded record).

    The record is padded to a power of two of at least twice its length plus ``settle_s``
    seconds, in which the response's impulse response decays, so the circular
    convolution equals the linear one. The response is evaluated a piece of the
    spectrum at a time, a safe point for a signal after each
    (:func:`bodyvib.process.interrupts.check`): at once it took 4 s for a record of
    3e6 samples; the FFTs take well under a second.
    """
    n = a.size
    nfft = 1 << int(np.ceil(np.log2(2 * n + int(settle_s * fs))))
    spec = np.fft.rfft(a, nfft)
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    for s in range(0, f.size, 1 << 18):
        interrupts.check()
        spec[s : s + (1 << 18)] *= response(f[s : s + (1 << 18)])
    interrupts.check()
    return np.fft.irfft(spec, nfft)[:n]


# The figures of a weighted record, defined once (ISO 2631-1 clause 6).
def _rms(aw) -> float:
    return float(np.sqrt(np.mean(aw**2)))


def _vdv(aw, fs: float) -> float:
    return float((np.sum(aw**4) / fs) ** 0.25)


def _peak(aw) -> float:
    return float(np.max(np.abs(aw)))


def _window_samples(fs: float) -> int:
    """Samples in the 1 s MTVV window: ``round(fs tau)``, at least one."""
    return max(1, int(round(MTVV_WINDOW_S * float(fs))))


class _RunningWindow:
    """Sums of the last ``N`` squares ending at each new sample (the MTVV's running sums).

    The squares before the first are zeros. Kept as a ring of the last ``N``
    squares per signal and the current sum, which each new sample moves by
    ``new - leaving`` (a cumulative sum over the block: O(1) per sample); the sum
    is recomputed from the ring at least every ``N`` samples, so rounding cannot
    accumulate over a long record. Shared by the whole-record and the streamed
    MTVV so that both are one definition.
    """

    def __init__(self, window: int, cases: int):
        self.window = int(window)
        self.ring = np.zeros((cases, self.window))
        self.at = 0  # ring position of the oldest square
        self.total = np.zeros(cases)  # sum of the ring
        self.since = 0  # samples since the sum was recomputed

    def update(self, squares) -> np.ndarray:
        """Window sums ``(cases, m)`` ending at each of the new ``(cases, m)`` squares."""
        out = np.empty_like(squares)
        n = self.window
        k = 0
        while k < squares.shape[1]:
            m = min(n - self.at, squares.shape[1] - k)  # up to the ring's end
            new = squares[:, k : k + m]
            leaving = self.ring[:, self.at : self.at + m]
            sums = self.total[:, None] + np.cumsum(new - leaving, axis=1)
            out[:, k : k + m] = sums
            leaving[...] = new
            self.at = (self.at + m) % n
            self.since += m
            if self.since >= n:
                self.total = self.ring.sum(axis=1)
                self.since = 0
            else:
                self.total = sums[:, -1]
            k += m
        return np.maximum(out, 0.0)


def _running_ms(aw, fs: float) -> np.ndarray:
    n = _window_samples(fs)
    return _RunningWindow(n, 1).update(np.asarray(aw, dtype=float)[None] ** 2)[0] / n


def _mtvv(aw, fs: float) -> float:
    return float(np.sqrt(np.max(_running_ms(aw, fs))))


@_record_doc
def running_rms(weighted, fs: float) -> np.ndarray:
    """Running r.m.s. of an already weighted signal (ISO 2631-1 eq. (4), linear, 1 s).

    Parameters
    ----------
    weighted : (n,) array_like
        Weighted acceleration a_w(t), m/s2.
    fs : float
        Sampling rate in Hz.

    Returns
    -------
    (n,) ndarray
        ``sqrt(mean(a_w^2))`` over the ``round(fs)`` samples ending at each
        sample, the signal taken as zero before the record; m/s2.

    %(record_raises)s

    Examples
    --------
    >>> t = np.arange(0, 3, 1e-3)
    >>> round(float(running_rms(np.sin(2 * np.pi * 5 * t), 1000.0)[-1] * np.sqrt(2)), 6)
    1.0
    """
    return np.sqrt(_running_ms(_check_signal(weighted, fs), fs))


@_record_doc
def weighted_rms(acceleration, fs: float) -> float:
    """ISO 2631-1 frequency-weighted r.m.s. acceleration (Wk) in m/s2.

    %(record)s

    Returns
    -------
    float
        ``sqrt(mean(a_w^2))`` over the whole record.

    %(record_raises)s

    Examples
    --------
    >>> t = np.arange(0, 60, 1e-3)
    >>> round(float(weighted_rms(np.sin(2 * np.pi * 5 * t), 1000.0) * np.sqrt(2)), 2)
    1.04
    """
    return _rms(weighted_acceleration(acceleration, fs))


@_record_doc
def vdv(acceleration, fs: float) -> float:
    """ISO 2631-1 vibration dose value (Wk weighted) in m/s^1.75.

    The fourth power vibration dose method (clause 6.3.2): more sensitive to shocks
    than the r.m.s.

    %(record)s

    Returns
    -------
    float
        ``(sum(a_w^4) / fs)^(1/4)``, the fourth-power dose over the record.

    %(record_raises)s
    """
    return _vdv(weighted_acceleration(acceleration, fs), fs)


@_record_doc
def peak(acceleration, fs: float) -> float:
    """Peak of the Wk-weighted acceleration, ``max |a_w|`` in m/s2.

    %(record)s

    Returns
    -------
    float
        The largest magnitude of the weighted record, either sign.

    %(record_raises)s
    """
    return _peak(weighted_acceleration(acceleration, fs))


@_record_doc
def mtvv(acceleration, fs: float) -> float:
    """ISO 2631-1 maximum transient vibration value (Wk weighted) in m/s2.

    %(record)s

    Returns
    -------
    float
        The largest 1 s running r.m.s. (linear integration) of the weighted
        record; see the module docstring.

    %(record_raises)s
    """
    return _mtvv(weighted_acceleration(acceleration, fs), fs)


def comfort_category(weighted_rms_value: float) -> str:
    """Words of ISO 2631-1 Annex C for an overall weighted r.m.s. acceleration.

    Parameters
    ----------
    weighted_rms_value : float
        Weighted r.m.s. in m/s2.

    Returns
    -------
    str
        e.g. ``"a little uncomfortable"``; where the standard's bands overlap,
        both names joined by ``" / "``.

    Examples
    --------
    >>> comfort_category(0.55)
    'a little uncomfortable / fairly uncomfortable'
    """
    v = float(weighted_rms_value)
    if not (np.isfinite(v) and v >= 0):
        raise BodyvibError(f"weighted r.m.s. must be a non-negative number, got {v!r}")
    names = [w for lo, hi, w in COMFORT_SCALE if lo <= v < hi]
    return " / ".join(names)


@dataclass(frozen=True)
class ComfortFigures:
    """ISO 2631-1 figures of one weighted record (:func:`comfort_figures`).

    Attributes
    ----------
    weighted_rms : float
        Wk-weighted r.m.s., m/s2.
    vdv : float
        Vibration dose value, m/s^1.75.
    peak : float
        Peak of the weighted record, m/s2.
    crest_factor : float
        ``peak / weighted_rms`` (NaN for a zero record), dimensionless.
    comfort : str
        ISO 2631-1 Annex C words for the weighted r.m.s.
    mtvv : float
        Maximum transient vibration value (largest 1 s running r.m.s., linear
        integration), m/s2.
    """

    weighted_rms: float
    vdv: float
    peak: float
    crest_factor: float
    comfort: str
    mtvv: float

    def to_dict(self) -> Dict[str, object]:
        """The figures as a JSON-ready dict, keys in the order of the attributes."""
        return asdict(self)


@_record_doc
def comfort_figures(acceleration, fs: float) -> ComfortFigures:
    """Weighted r.m.s., VDV, peak and crest factor of one record (one filtering pass).

    %(record)s

    Returns
    -------
    ComfortFigures
        ``weighted_rms`` [m/s2], ``vdv`` [m/s^1.75], ``peak`` [m/s2],
        ``crest_factor`` [-], ``comfort`` (ISO 2631-1 Annex C words),
        ``mtvv`` [m/s2].

    %(record_raises)s
    """
    aw = weighted_acceleration(acceleration, fs)
    rms, pk = _rms(aw), _peak(aw)
    return ComfortFigures(
        weighted_rms=rms,
        vdv=_vdv(aw, fs),
        peak=pk,
        crest_factor=pk / rms if rms > 0 else float("nan"),
        comfort=comfort_category(rms),
        mtvv=_mtvv(aw, fs),
    )


#: ISO 2631-1 clause 6.3: above these ratios the basic method (the weighted
#: r.m.s.) may underestimate the effect of the vibration: (name, limit, words).
BASIC_METHOD_LIMITS = (
    ("crest_factor", 9.0, "crest factor peak / a_w"),
    ("mtvv_ratio", 1.5, "MTVV / a_w"),
    ("vdv_ratio", 1.75, "VDV / (a_w T^1/4)"),
)


@renamed_parameters(duration_s="duration")
def basic_method_checks(figures: ComfortFigures, duration: float) -> Dict[str, dict]:
    """The standard's tests of whether the weighted r.m.s. alone describes a record.

    Parameters
    ----------
    figures : ComfortFigures
        Figures of the record.
    duration : float
        Its duration T in s (for ``VDV / (a_w T^1/4)``).

    Returns
    -------
    dict
        ``{"crest_factor" | "mtvv_ratio" | "vdv_ratio": {"value", "limit",
        "what", "exceeded"}}``; ``exceeded`` True means ISO 2631-1 asks for the
        additional methods (running r.m.s. / MTVV, or VDV) besides ``a_w``.

    Examples
    --------
    >>> f = ComfortFigures(1.0, 1.0, 10.0, 10.0, "", 1.2)
    >>> basic_method_checks(f, 1.0)["crest_factor"]["exceeded"]
    True
    """
    rms = figures.weighted_rms
    with np.errstate(divide="ignore", invalid="ignore"):
        values = {
            "crest_factor": figures.crest_factor,
            "mtvv_ratio": figures.mtvv / rms if rms > 0 else float("nan"),
            "vdv_ratio": (
                figures.vdv / (rms * float(duration) ** 0.25)
                if rms > 0 and duration > 0
                else float("nan")
            ),
        }
    return {
        k: {
            "value": float(values[k]),
            "limit": lim,
            "what": what,
            "exceeded": bool(values[k] > lim),
        }
        for k, lim, what in BASIC_METHOD_LIMITS
    }
