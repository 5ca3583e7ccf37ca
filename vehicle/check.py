"""The check: the reduced body's head acceleration against the ISO 7962 body's.

:func:`compare` takes a study of both bodies on the same road and car
(:func:`vehicle.study.run_study`) and judges the reduced body criterion by
criterion against :data:`TOLERANCES` (the README explains each), giving one
PASS/FAIL line per criterion and a verdict.
"""

from .reference import nrmse

__all__ = ["TOLERANCES", "compare"]

#: Check tolerances: relative difference of the reduced body's figure from the
#: ISO body's (a fraction), except the peak frequency (Hz). See README, "The check".
TOLERANCES = {
    "weighted_rms": 0.10,
    "vdv": 0.10,
    "peak": 0.20,
    "time_history_nrmse": 0.20,
    "transmissibility_peak": 0.10,
    "transmissibility_peak_frequency_hz": 0.5,
}


def _rel(a, b):
    return abs(a - b) / abs(b) if b else float("inf")


def compare(study: dict, reduced: str, iso: str) -> dict:
    """The check: reduced body against the ISO body, criterion by criterion.

    Parameters
    ----------
    study : dict
        From :func:`run_study` with both labels.
    reduced, iso : str
        Labels of the reduced body and of the ISO 7962 body.

    Returns
    -------
    dict
        ``criteria``: list of ``{"name", "reduced", "iso", "difference",
        "tolerance", "unit", "passed"}`` (difference relative, a fraction,
        except the peak frequency in Hz; for the time-history NRMSE "reduced"
        holds the NRMSE); ``verdict``: ``"PASS"`` if every criterion passes,
        else ``"FAIL"``.
    """
    R, I = study["bodies"][reduced], study["bodies"][iso]
    crit = []

    def add(name, r, i, diff, unit="relative"):
        tol = TOLERANCES[name]
        crit.append({"name": name, "reduced": r, "iso": i, "difference": diff,
                     "tolerance": tol, "unit": unit, "passed": bool(diff <= tol)})

    for key in ("weighted_rms", "vdv", "peak"):
        r, i = R["figures"][key], I["figures"][key]
        add(key, r, i, _rel(r, i))
    e = nrmse(R["run"]["head_acceleration"], I["run"]["head_acceleration"])
    add("time_history_nrmse", e, 0.0, e)
    pr, pi = R["transmissibility"]["peak"], I["transmissibility"]["peak"]
    add("transmissibility_peak", pr["modulus"], pi["modulus"], _rel(pr["modulus"], pi["modulus"]))
    add("transmissibility_peak_frequency_hz", pr["frequency_hz"], pi["frequency_hz"],
        abs(pr["frequency_hz"] - pi["frequency_hz"]), unit="Hz")
    return {"reduced": reduced, "iso": iso, "criteria": crit,
            "verdict": "PASS" if all(c["passed"] for c in crit) else "FAIL"}
