"""Where a figure is valid: the time step the figures need, and ISO 2631-1's basic method.

**The time step.** A run's head figures are computed from its samples at the
communication (or integration) step ``h``. :func:`largest_valid_step` gives the
largest step that can give them, with its reason; :func:`check_step` refuses a longer
one. Two criteria, the stricter governs:

* *the Wk band*: ISO 2631-1 weights the vertical vibration up to its band's upper
  limit of 80 Hz (:data:`WK_BAND_HZ`; Wk falls off above it, band-limited at
  100 Hz). The Nyquist step ``1 / 160`` s holds the band but not the figure: measured
  on the quarter car with the reduced body and with the ISO 7962 body (class C road,
  10 and 20 m/s, the exact monolithic step), the head's Wk r.m.s. is off by +1.6 to
  +1.7 % at 1/160 s, +1.0 to +1.1 % at 5 ms, +0.66 to +0.70 % at 4 ms and +0.04 % at
  1 ms against a 0.125 ms run (the error is second order in ``h``: the road's content
  above the Nyquist frequency folds into the band). :data:`SAMPLES_PER_PERIOD` = 3
  samples a period of 80 Hz (``h <= 1/240`` s = 4.17 ms) keeps it within
  :data:`FIGURE_TOLERANCE` = 1 %.
* *the model's highest mode*: every mode of the model inside the weighting's band
  (natural frequency ``|lambda| / 2 pi`` of a complex eigenvalue pair of its state
  matrix, up to the 100 Hz band limit :data:`MODE_LIMIT_HZ`) gets the same
  3 samples a period (a 92 Hz seat-cushion mode: 3.6 ms). A mode above the band
  (the ISO 7962 body's 1.4 kHz) is weighted out and stepped exactly inside its FMU:
  the ISO body's figure keeps the same error as the reduced body's at 4 ms.

The coupling of a co-simulation adds its own error, second order in the step with the
extrapolating master (head NRMSE against the monolithic reference, quarter car and
reduced body on class C, 10 s: 0.029 % at 1 ms, 0.45 % at 4 ms, 1.0 % at 1/160 s,
102 % at 50 ms). A run measures it; :func:`coupling_warning` words one beyond
:data:`COUPLING_NRMSE_LIMIT` (1 %, the figures' tolerance).

**ISO 2631-1 clause 6.3.** The basic method (the weighted r.m.s. and the comfort words
of Annex C, which name it) is not sufficient when the crest factor exceeds 9,
``MTVV / a_w`` exceeds 1.5 or ``VDV / (a_w T^1/4)`` exceeds 1.75
(:data:`bodyvib.comfort.figures.BASIC_METHOD_LIMITS`). :func:`governing_method` says
which method governs a record: ``"basic"``, ``"mtvv"`` (the running r.m.s. method) or
``"vdv"`` (the fourth power vibration dose method); :func:`comfort_words` the words a
report prints for it.
"""

import math
from dataclasses import dataclass
from typing import Any, Dict, Iterable, Optional

import numpy as np

from ..runtime.errors import BodyvibError
from .figures import BASIC_METHOD_LIMITS, WK_PARAMETERS

__all__ = [
    "WK_BAND_HZ",
    "MODE_LIMIT_HZ",
    "SAMPLES_PER_PERIOD",
    "FIGURE_TOLERANCE",
    "COUPLING_NRMSE_LIMIT",
    "StepLimit",
    "highest_mode_hz",
    "largest_valid_step",
    "check_step",
    "coupling_warning",
    "governing_method",
    "comfort_words",
    "comfort_verdict",
]

#: Upper limit of the frequency band ISO 2631-1 weights for comfort and health, Hz.
WK_BAND_HZ = 80.0
#: Highest natural frequency of a model counted as inside the weighting's band: Wk's
#: band limit f2 (ISO 2631-1 Table A.1), Hz.
MODE_LIMIT_HZ = WK_PARAMETERS["f2"]
#: Samples per period of the band's upper limit and of the model's highest mode in it
#: (chosen from the measurement in the module docstring: the head's Wk r.m.s. within
#: :data:`FIGURE_TOLERANCE`).
SAMPLES_PER_PERIOD = 3.0
#: Tolerance the step's criteria keep the head's Wk r.m.s. within (a fraction).
FIGURE_TOLERANCE = 0.01
#: Coupling error (head-acceleration NRMSE against the monolithic reference, a fraction)
#: above which a co-simulation's figures are flagged: the figures' tolerance.
COUPLING_NRMSE_LIMIT = FIGURE_TOLERANCE


@dataclass(frozen=True)
class StepLimit:
    """The largest step a run's figures allow (:func:`largest_valid_step`).

    Attributes
    ----------
    step : float
        The largest valid step, s: the smaller of the two criteria's.
    reason : str
        The criterion that sets it, in words.
    highest_mode_hz : float or None
        The model's highest natural frequency inside the band, Hz (None: no model given,
        or none in the band).
    """

    step: float
    reason: str
    highest_mode_hz: Optional[float] = None


def highest_mode_hz(model, limit_hz: float = MODE_LIMIT_HZ) -> Optional[float]:
    """The highest natural frequency of a model up to ``limit_hz``, from its state matrix.

    Parameters
    ----------
    model : Network, LinearModel or (n, n) array_like
        A network (a nonlinear one is linearized about static equilibrium), its state
        space, or a state matrix ``A``.
    limit_hz : float
        Modes above it are not counted, Hz.

    Returns
    -------
    float or None
        ``max |lambda| / 2 pi`` over the complex eigenvalues of ``A`` (oscillating modes)
        not above ``limit_hz``, Hz; None if there is none.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> round(highest_mode_hz(load_model("reduced-paper")), 2)
    18.68
    """
    ev = np.linalg.eigvals(_state_matrix(model))
    mag = np.abs(ev)
    f = mag[np.abs(ev.imag) > 1e-9 * mag] / (2 * np.pi)
    f = f[f <= limit_hz]
    return float(f.max()) if f.size else None


def _state_matrix(model) -> np.ndarray:
    """``A`` of a network (linearized), a linear model or a matrix."""
    from ..runtime.network import Network, linear_model, linearized

    if isinstance(model, Network):
        return linear_model(linearized(model)).A
    return np.asarray(getattr(model, "A", model), dtype=float)


def largest_valid_step(models: Iterable[Any] = (), band_hz: float = WK_BAND_HZ) -> StepLimit:
    """The largest step at which a run gives the ISO 2631-1 figures, and why.

    The criteria and the measurement behind them are in the module docstring:
    :data:`SAMPLES_PER_PERIOD` samples a period of the band's upper limit and of the
    highest mode (inside the band) of any of the models.

    Parameters
    ----------
    models : iterable of Network, LinearModel or array_like
        The models of the run (a seated car, a body: see :func:`highest_mode_hz`).
    band_hz : float
        Upper limit of the weighted band, Hz.

    Returns
    -------
    StepLimit

    Examples
    --------
    >>> round(largest_valid_step().step, 6)
    0.004167
    """
    band = StepLimit(
        1.0 / (SAMPLES_PER_PERIOD * band_hz),
        f"the Wk band up to {band_hz:g} Hz needs {SAMPLES_PER_PERIOD:g} samples a period "
        f"for the figures within {100 * FIGURE_TOLERANCE:g} %",
    )
    modes = [f for f in (highest_mode_hz(m) for m in models) if f is not None]
    if not modes:
        return band
    top = max(modes)
    mode = StepLimit(
        1.0 / (SAMPLES_PER_PERIOD * top),
        f"the model's highest mode, {top:.3g} Hz, needs {SAMPLES_PER_PERIOD:g} samples a period",
        top,
    )
    return mode if mode.step < band.step else StepLimit(band.step, band.reason, top)


def check_step(
    step: float, models: Iterable[Any] = (), band_hz: float = WK_BAND_HZ, name: str = "step"
) -> StepLimit:
    """Refuse a step that cannot give the figures, naming the largest step that can.

    Parameters
    ----------
    step : float
        The run's step, s.
    models, band_hz
        As :func:`largest_valid_step`.
    name : str
        What the message calls the step: a parameter name (the command line shows its
        flag) or words (``"sampling step"``).

    Returns
    -------
    StepLimit
        The limit the step passed.

    Raises
    ------
    BodyvibError
        A ``ValueError``: the step longer than :func:`largest_valid_step`.

    Examples
    --------
    >>> check_step(0.05)
    Traceback (most recent call last):
    ...
    bodyvib.runtime.errors.BodyvibError: step 0.05 s is too long for the figures: the Wk band up to 80 Hz needs 3 samples a period for the figures within 1 %; use a step of at most 0.0041 s
    """
    limit = largest_valid_step(models, band_hz)
    if step > limit.step * (1 + 1e-12):
        raise BodyvibError(
            f"{name} {step:g} s is too long for the figures: {limit.reason}; use a "
            f"{name} of at most {_round_down(limit.step):g} s",
            parameters=(name,) if name.isidentifier() else (),
        )
    return limit


def _round_down(step: float) -> float:
    """A step at most ``step`` with two significant digits (what a message proposes)."""
    scale = 10.0 ** (math.floor(math.log10(step)) - 1)
    return math.floor(step / scale + 1e-9) * scale if step > 0 else step


def coupling_warning(nrmse: Optional[float], step: float) -> Optional[str]:
    """One line when a co-simulation's coupling error is beyond :data:`COUPLING_NRMSE_LIMIT`.

    Parameters
    ----------
    nrmse : float or None
        Head-acceleration NRMSE of the run against its monolithic reference (None: no
        reference).
    step : float
        The run's communication step, s.

    Returns
    -------
    str or None

    Examples
    --------
    >>> coupling_warning(1.04, 0.05)
    'coupling error 104 % of the head acceleration at step 0.05 s, beyond the 1 % the figures allow: shorten the step (the error is second order in it)'
    """
    if nrmse is None or not nrmse > COUPLING_NRMSE_LIMIT:
        return None
    return (
        f"coupling error {100 * nrmse:.3g} % of the head acceleration at step {step:g} s, "
        f"beyond the {100 * COUPLING_NRMSE_LIMIT:g} % the figures allow: shorten the step "
        "(the error is second order in it)"
    )


def _ratios(weighted_rms, crest_factor, mtvv, vdv, duration) -> Dict[str, float]:
    """The three ratios of clause 6.3 (NaN where they cannot be formed)."""
    rms = float(weighted_rms)
    ok = math.isfinite(rms) and rms > 0
    return {
        "crest_factor": float(crest_factor),
        "mtvv_ratio": float(mtvv) / rms if ok else math.nan,
        "vdv_ratio": float(vdv) / (rms * float(duration) ** 0.25)
        if ok and duration > 0
        else math.nan,
    }


def governing_method(
    weighted_rms: float, crest_factor: float, mtvv: float, vdv: float, duration: float
) -> str:
    """Which ISO 2631-1 method governs a record's evaluation (clause 6.3).

    The rule: ``"basic"`` while the crest factor is at most 9, ``MTVV / a_w`` at most 1.5
    and ``VDV / (a_w T^1/4)`` at most 1.75 (a limit itself is still basic; a figure that
    is NaN, a spectral estimate with no record, counts as within). Otherwise the
    additional method whose ratio is further beyond its limit (ratio over limit):
    ``"mtvv"`` (running r.m.s.) or ``"vdv"``, ``"vdv"`` on a tie; when only the crest
    factor exceeds its limit, ``"vdv"``: the fourth power dose is the measure more
    sensitive to peaks (clause 6.3.2).

    Parameters
    ----------
    weighted_rms : float
        ``a_w``, m/s2.
    crest_factor : float
        Peak over ``a_w``.
    mtvv : float
        Maximum transient vibration value, m/s2.
    vdv : float
        Vibration dose value, m/s^1.75.
    duration : float
        The record's duration ``T``, s.

    Returns
    -------
    str
        ``"basic"``, ``"mtvv"`` or ``"vdv"``.

    Examples
    --------
    >>> governing_method(1.0, 4.0, 1.2, 1.5, 1.0)
    'basic'
    >>> governing_method(1.0, 12.0, 1.2, 1.5, 1.0)
    'vdv'
    >>> governing_method(1.0, 12.0, 2.0, 1.5, 1.0)
    'mtvv'
    """
    ratios = _ratios(weighted_rms, crest_factor, mtvv, vdv, duration)
    over = {k: ratios[k] / lim for k, lim, _ in BASIC_METHOD_LIMITS if ratios[k] > lim}
    if not over:
        return "basic"
    m, v = over.get("mtvv_ratio", 0.0), over.get("vdv_ratio", 0.0)
    return "mtvv" if m > v else "vdv"


def comfort_words(
    comfort: str,
    weighted_rms: float,
    crest_factor: float,
    mtvv: float,
    vdv: float,
    duration: float,
) -> str:
    """The comfort cell of a report: the Annex C words, led by the additional measure where
    the basic method is not sufficient (:func:`governing_method`).

    Parameters
    ----------
    comfort : str
        ISO 2631-1 Annex C words of the weighted r.m.s.
    weighted_rms, crest_factor, mtvv, vdv, duration
        As :func:`governing_method`.

    Returns
    -------
    str
        ``comfort`` as it is where the basic method governs; else e.g. ``"VDV 2.31
        m/s^1.75 governs (basic: not uncomfortable)"``.

    Examples
    --------
    >>> comfort_words("not uncomfortable", 0.2, 11.0, 0.3, 0.5, 6.0)
    'VDV 0.500 m/s^1.75 governs (basic: not uncomfortable)'
    """
    method = governing_method(weighted_rms, crest_factor, mtvv, vdv, duration)
    if method == "basic":
        return comfort
    lead = f"VDV {vdv:.3f} m/s^1.75" if method == "vdv" else f"MTVV {mtvv:.3f} m/s2"
    return f"{lead} governs (basic: {comfort})"


def comfort_verdict(figures, duration: float) -> Dict[str, str]:
    """:func:`governing_method` and :func:`comfort_words` of one record's figures.

    Parameters
    ----------
    figures : ComfortFigures
        A record's figures (``weighted_rms``, ``crest_factor``, ``mtvv``, ``vdv``,
        ``comfort``).
    duration : float
        The record's duration, s.

    Returns
    -------
    dict
        ``comfort_method`` and ``comfort_words``, as reports and their JSON name them.

    Examples
    --------
    >>> from bodyvib.comfort import ComfortFigures
    >>> comfort_verdict(ComfortFigures(0.2, 0.5, 2.2, 11.0, "not uncomfortable", 0.3), 6.0)
    {'comfort_method': 'vdv', 'comfort_words': 'VDV 0.500 m/s^1.75 governs (basic: not uncomfortable)'}
    """
    f = figures
    args = (f.weighted_rms, f.crest_factor, f.mtvv, f.vdv, duration)
    return {
        "comfort_method": governing_method(*args),
        "comfort_words": comfort_words(f.comfort, *args),
    }
