"""ISO 2631-1 whole-body vibration figures of the head and the seat.

:mod:`~bodyvib.comfort.figures` weights a whole record at once (Wk weighting,
weighted r.m.s., VDV, MTVV, peak, the comfort scale); :mod:`~bodyvib.comfort.stream`
computes the same figures sample by sample for a batch of signals, with a
recursive Wk filter, so a run of any length needs no history. One record's figures
are a :class:`~bodyvib.comfort.figures.ComfortFigures`, a batch's a
:class:`~bodyvib.comfort.stream.BatchComfortFigures` (arrays, one entry per case). :mod:`~bodyvib.comfort.measures` adds absorbed power
(physical and Lee & Pradko's estimate), the motion sickness dose value (Wf) and the
ISO 10326-1 SEAT value; :mod:`~bodyvib.comfort.spine` the ISO 2631-5:2018 spinal
response, acceleration dose and injury risk of repeated shocks.
:mod:`~bodyvib.comfort.axes` covers every axis of a seated person: the six
weightings (Wk, Wd, Wf, Wc, We, Wj), the multiplying factors for comfort and health,
the point and overall vibration total values and the health guidance caution zone.
:mod:`~bodyvib.comfort.forces` gives the figures of the body's internal forces (neck,
lumbar): r.m.s., peak and the peak's time. :mod:`~bodyvib.comfort.validity` says where a
figure is valid: the largest time step the figures allow, and which of ISO 2631-1's
methods governs a record (clause 6.3).

Import from the package (``from bodyvib.comfort import comfort_figures``): the names in ``__all__``
are its public interface, and the modules that hold them are internal and may move.
"""

from bodyvib._lazy import lazy_exports

_MODULES = {
    "axes": (
        "HEALTH_CAUTION_ZONE",
        "POINTS",
        "SEATED_AXES",
        "WEIGHTINGS",
        "AxisFigures",
        "HealthGuidance",
        "VibrationTotals",
        "axis_figures",
        "health_guidance",
        "vibration_totals",
        "weighted_axis",
        "weighting",
    ),
    "figures": (
        "BASIC_METHOD_LIMITS",
        "COMFORT_SCALE",
        "MTVV_WINDOW_S",
        "WK_PARAMETERS",
        "ComfortFigures",
        "basic_method_checks",
        "check_rate",
        "comfort_category",
        "comfort_figures",
        "mtvv",
        "peak",
        "running_rms",
        "vdv",
        "weighted_acceleration",
        "weighted_rms",
        "wk_response",
    ),
    "forces": ("ForceFigures", "ForceStream", "force_figures"),
    "measures": (
        "WF_PARAMETERS",
        "SeatMeasureStream",
        "SeatMeasures",
        "absorbed_power",
        "lee_pradko_power",
        "msdv",
        "seat_value",
        "wf_response",
    ),
    "spine": (
        "SpinalDose",
        "acceleration_dose",
        "injury_probability",
        "injury_risk",
        "spinal_dose",
    ),
    "validity": (
        "COUPLING_NRMSE_LIMIT",
        "FIGURE_TOLERANCE",
        "MODE_LIMIT_HZ",
        "SAMPLES_PER_PERIOD",
        "WK_BAND_HZ",
        "StepLimit",
        "check_step",
        "comfort_verdict",
        "comfort_words",
        "coupling_warning",
        "governing_method",
        "highest_mode_hz",
        "largest_valid_step",
    ),
    "stream": (
        "BatchComfortFigures",
        "ComfortStream",
        "WkFilter",
        "stream_batch_figures",
        "stream_comfort_figures",
        "weighting_statespace",
        "wk_statespace",
    ),
}

__all__, __getattr__, __dir__ = lazy_exports(__name__, _MODULES)
