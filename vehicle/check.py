"""The check: the reduced body's head acceleration against the ISO 7962 body's.

:func:`compare` takes a study of both bodies on the same road and car
(:func:`bodyvib.vehicle.study.run_study`) and judges the reduced body criterion by
criterion against :data:`TOLERANCES` (docs/getting_started.md, "The check" explains each), giving one
PASS/FAIL line per criterion and a verdict, as a :class:`Comparison` of
:class:`Criterion`.
"""

from dataclasses import dataclass, field
from typing import Dict, List

from .records import Record

__all__ = ["TOLERANCES", "Criterion", "Comparison", "compare"]

#: Check tolerances: relative difference of the reduced body's figure from the
#: ISO body's (a fraction), except the peak frequency (Hz). See docs/getting_started.md, "The check".
TOLERANCES = {
    "weighted_rms": 0.10,
    "vdv": 0.10,
    "peak": 0.20,
    "time_history_nrmse": 0.20,
    "transmissibility_peak": 0.10,
    "transmissibility_peak_frequency_hz": 0.5,
}


@dataclass(frozen=True)
class Criterion(Record):
    """One criterion of the check.

    Attributes
    ----------
    name : str
        A key of :data:`TOLERANCES`.
    reduced, iso : float
        The figure of the reduced and of the ISO body (for the time-history
        NRMSE: the NRMSE and 0).
    difference : float
        Relative difference (a fraction), except the peak frequency (Hz).
    tolerance : float
        The criterion's tolerance, same unit as ``difference``.
    unit : str
        ``"relative"`` or ``"Hz"``.
    passed : bool
        ``difference <= tolerance``.
    """

    name: str
    reduced: float
    iso: float
    difference: float
    tolerance: float
    unit: str
    passed: bool


@dataclass(frozen=True)
class Comparison:
    """The check's outcome (:func:`compare`).

    Attributes
    ----------
    reduced, iso : str
        Labels of the two bodies in the study.
    criteria : list of Criterion
    verdict : str
        ``"PASS"`` if every criterion passes, else ``"FAIL"``.
    tolerances : dict of str to float
        The tolerances judged against (:data:`TOLERANCES`).
    """

    reduced: str
    iso: str
    criteria: List[Criterion]
    verdict: str
    tolerances: Dict[str, float] = field(default_factory=lambda: dict(TOLERANCES))

    def to_dict(self) -> dict:
        """The check section of the JSON document: ``criteria``, ``verdict``, ``tolerances``."""
        return {
            "criteria": [c.to_dict() for c in self.criteria],
            "verdict": self.verdict,
            "tolerances": dict(self.tolerances),
        }


def _rel(a, b):
    return abs(a - b) / abs(b) if b else float("inf")


def compare(study, reduced: str, iso: str) -> Comparison:
    """The check: reduced body against the ISO body, criterion by criterion.

    Parameters
    ----------
    study : bodyvib.vehicle.study.Study
        From :func:`bodyvib.vehicle.study.run_study` with both labels.
    reduced, iso : str
        Labels of the reduced body and of the ISO 7962 body.

    Returns
    -------
    Comparison
        One :class:`Criterion` per key of :data:`TOLERANCES` (difference
        relative, a fraction, except the peak frequency in Hz; for the
        time-history NRMSE ``reduced`` holds the NRMSE) and the verdict.
    """
    R, I = study.bodies[reduced], study.bodies[iso]
    crit = []

    def add(name, r, i, diff, unit="relative"):
        tol = TOLERANCES[name]
        crit.append(
            Criterion(
                name=name,
                reduced=r,
                iso=i,
                difference=diff,
                tolerance=tol,
                unit=unit,
                passed=bool(diff <= tol),
            )
        )

    for key in ("weighted_rms", "vdv", "peak"):
        r, i = getattr(R.figures, key), getattr(I.figures, key)
        add(key, r, i, _rel(r, i))
    e = study.history_nrmse(reduced, iso)  # running sums: no history kept
    add("time_history_nrmse", e, 0.0, e)
    pr, pi = R.transmissibility.peak, I.transmissibility.peak
    add("transmissibility_peak", pr.modulus, pi.modulus, _rel(pr.modulus, pi.modulus))
    add(
        "transmissibility_peak_frequency_hz",
        pr.frequency_hz,
        pi.frequency_hz,
        abs(pr.frequency_hz - pi.frequency_hz),
        unit="Hz",
    )
    return Comparison(
        reduced=reduced,
        iso=iso,
        criteria=crit,
        verdict="PASS" if all(c.passed for c in crit) else "FAIL",
    )
