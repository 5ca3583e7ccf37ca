"""A study as text and as JSON: per-body figures, coupling error, the check's lines.

The JSON document's keys are listed in docs/getting_started.md, "JSON output".
"""

from typing import List, Optional

from bodyvib.comfort import comfort_verdict

from .check import Comparison
from .events import format_events
from .road.driven import road_handling
from .study import Study

__all__ = ["PEAK_HINT", "format_report", "study_json", "vehicle_line"]

_WORDS = {
    "crest_factor": "crest factor [-]",
    "weighted_rms": "Wk-weighted r.m.s. [m/s2]",
    "vdv": "VDV [m/s^1.75]",
    "peak": "weighted peak [m/s2]",
    "mtvv": "MTVV, 1 s running [m/s2]",
    "time_history_nrmse": "head acceleration NRMSE",
    "transmissibility_peak": "transmissibility peak |T|",
    "transmissibility_peak_frequency_hz": "transmissibility peak frequency [Hz]",
}


def vehicle_line(vehicle: dict) -> str:
    """The report's line naming the car, its seat and its controller.

    Parameters
    ----------
    vehicle : dict
        ``car`` (a name, a parameter file or a car FMU), ``seat`` (None: the occupant on
        the car's seat point) and ``control`` (None, or a dict with ``law`` in words or
        ``fmu``), as :func:`study_json` records them.

    Returns
    -------
    str

    Examples
    --------
    >>> vehicle_line({"car": "quarter-car", "seat": None, "control": None})
    'car quarter-car, no seat (the occupant on the seat point), no controller'
    """
    seat = vehicle.get("seat")
    control = vehicle.get("control")
    if control is None:
        law = "no controller"
    else:
        law = "controller " + (control.get("law") or f"FMU {control.get('fmu')}")
    seat_words = f"seat {seat}" if seat else "no seat (the occupant on the seat point)"
    return f"car {vehicle['car']}, {seat_words}, {law}"


def format_report(
    study: Study, comparison: Optional[Comparison] = None, vehicle: Optional[dict] = None
) -> str:
    """Text report: per-body head and internal-force figures, coupling error, the check's lines.

    Parameters
    ----------
    study : Study
        From :func:`bodyvib.vehicle.study.run_study`: its settings head the report, one column
        per body.
    comparison : Comparison, optional
        From :func:`bodyvib.vehicle.check.compare`: adds one PASS/FAIL line per criterion, the
        hint :data:`PEAK_HINT` if a transmissibility-peak criterion failed, and the verdict.
    vehicle : dict, optional
        The car, seat and controller of the run (:func:`vehicle_line`): a second heading
        line names them.

    Returns
    -------
    str
        The lines ``bodyvib cosim`` and ``bodyvib check`` print, joined by newlines
        (no trailing newline); figures in m/s2, m/s^1.75 (VDV), Hz and percent; the neck
        and lumbar forces' r.m.s. and peak (+ compression) in N, the peak's time in s.
    """
    s = study.settings
    handling = road_handling(study.road)
    lines = [
        f"road {study.road['name']}{', ' + handling if handling else ''}, "
        f"{s.speed:g} m/s, {s.duration:g} s, "
        f"step {s.step:g} s ({study.master})",
        *([vehicle_line(vehicle)] if vehicle is not None else []),
        "",
    ]
    bodies = study.bodies
    labels = list(bodies)
    # every cell fits with two spaces before it: ISO 2631-1's comfort words are the longest
    # ("very uncomfortable / extremely uncomfortable" ran into the next column)
    w = max(24, *(len(label) + 2 for label in labels))
    comfort = {
        label: comfort_verdict(bodies[label].figures, s.duration)["comfort_words"]
        for label in labels
    }
    w = max(w, *(len(c) + 2 for c in comfort.values()))

    def row(title, cell):  # one line: a title, then cell(body) right-aligned per body
        return f"{title:<28}" + "".join(f"{cell(bodies[b]):>{w}}" for b in labels)

    lines.append(f"{'head acceleration':<28}" + "".join(f"{label:>{w}}" for label in labels))
    for key, fmt in (
        ("weighted_rms", "{:.4f}"),
        ("vdv", "{:.4f}"),
        ("peak", "{:.4f}"),
        ("crest_factor", "{:.2f}"),
        ("mtvv", "{:.4f}"),
    ):
        lines.append(
            row(_WORDS[key], lambda b, fmt=fmt, key=key: fmt.format(getattr(b.figures, key)))
        )
    lines.append(f"{'comfort (ISO 2631-1 C)':<28}" + "".join(f"{comfort[b]:>{w}}" for b in labels))
    lines.append(row("|T| peak estimated from run", lambda b: _peak(b.transmissibility.peak)))
    lines.append(
        row(
            "|T| peak of the model (FRF)",
            lambda b: _peak(getattr(b, "model_transmissibility_peak", None)),
        )
    )
    for name in ("neck_force", "lumbar_force"):
        if any(name in b.forces for b in bodies.values()):
            words = name.replace("_", " ")
            lines.append(row(f"{words} r.m.s. [N]", lambda b, n=name: _force(b, n, "rms")))
            lines.append(row(f"{words} peak [N]", lambda b, n=name: _force(b, n, "peak")))
    if any(
        getattr(b, "events", None) is not None and b.events.smallest_tire_load_ratio is not None
        for b in bodies.values()
    ):
        lines += _event_rows(row)
        wheels = {k: None for b in bodies.values() for k in getattr(b, "wheel_events", {})}
        for wheel in wheels:  # a car with several wheels: each wheel's rows too
            lines += _event_rows(row, wheel)
    lines.append(row("coupling NRMSE vs reference", lambda b: _pct(b.coupling_nrmse)))
    lines.append(row("real-time factor", lambda b: f"{b.real_time_factor:.1f}"))
    seat = bodies[labels[0]].seat_figures.weighted_rms
    lines.append(f"seat Wk-weighted r.m.s. ({labels[0]} run): {seat:.4f} m/s2")
    if all(getattr(bodies[b], "seat_measures", None) is not None for b in labels):
        lines.append(row("absorbed power [W]", lambda b: f"{b.seat_measures.absorbed_power_w:.4f}"))
        lines.append(
            row(
                "  Lee & Pradko estimate [W]", lambda b: f"{b.seat_measures.lee_pradko_power_w:.4f}"
            )
        )
        lines.append(row("seat MSDV (Wf) [m/s^1.5]", lambda b: f"{b.seat_measures.msdv:.4f}"))
        lines.append(
            row("seat ISO 2631-5 Dz [m/s2]", lambda b: f"{b.seat_measures.spinal_dose:.4f}")
        )
    lines += [f"warning: {w}" for w in getattr(study, "warnings", [])]
    lines += _seat_axes_lines(row, bodies, labels)
    if comparison:
        lines += _check_lines(comparison)
    return "\n".join(lines)


#: The seat surface's figures a run reports beside the head's: key, words.
_SEAT_AXES = (
    ("seat_aw_x", "seat a_w x (Wd) [m/s2]"),
    ("seat_aw_y", "seat a_w y (Wd) [m/s2]"),
    ("seat_aw_z", "seat a_w z (Wk) [m/s2]"),
    ("seat_av", "seat a_v, comfort [m/s2]"),
    ("seat_aw_rx", "seat a_w roll (We) [rad/s2]"),
    ("seat_aw_ry", "seat a_w pitch (We) [rad/s2]"),
    ("seat_rotation_av", "seat rotations a_v [m/s2]"),
)


def _seat_axes_lines(row, bodies, labels) -> List[str]:
    """The seat surface's ISO 2631-1 axes and rotations (a car that has them)."""
    axes = [getattr(bodies[b], "seat_axes", None) or {} for b in labels]
    return [
        row(words, lambda b, k=key: f"{(b.seat_axes or {}).get(k, float('nan')):.4f}")
        for key, words in _SEAT_AXES
        if any(key in a for a in axes)
    ]


def _check_lines(comparison: Comparison) -> List[str]:
    """The check's lines: one PASS/FAIL line per criterion, the hint, the verdict."""
    lines: List[str] = []
    lines += ["", f"check: {comparison.reduced} against {comparison.iso}"]
    for c in comparison.criteria:
        mark = "PASS" if c.passed else "FAIL"
        if c.unit == "Hz":
            what = (
                f"{c.reduced:.2f} vs {c.iso:.2f} Hz: difference "
                f"{c.difference:.2f} Hz <= {c.tolerance:g} Hz?"
            )
        elif c.name == "time_history_nrmse":
            what = f"{100 * c.difference:.1f} % <= {100 * c.tolerance:g} %?"
        else:
            what = (
                f"{c.reduced:.4g} vs {c.iso:.4g}: difference "
                f"{100 * c.difference:.1f} % <= {100 * c.tolerance:g} %?"
            )
        lines.append(f"  {mark}  {_WORDS[c.name]:<38} {what}")
    if any(
        c.name.startswith("transmissibility_peak") and not c.passed for c in comparison.criteria
    ):
        lines.append(PEAK_HINT)
    lines.append(f"verdict: {comparison.verdict}")
    return lines


#: The line under a failed transmissibility-peak criterion: where the trade-off is drawn.
PEAK_HINT = (
    "  the 3-DOF chain trades Eq. 3's J for the peak: pareto_front draws it "
    "(docs/tutorials/refit.md, 'The trade-off')"
)


def _event_rows(row, wheel=None):
    """The rows of what the tire and the stops did (a car with a tire contact), over the
    car or (``wheel``, a suffix of :data:`bodyvib.vehicle.signals.WHEELS`) of one wheel."""

    def cell(b, what):
        e = b.events if wheel is None else b.wheel_events.get(wheel)
        if e is None or e.smallest_tire_load_ratio is None:
            return "n/a"
        if what == "lift":
            return format_events(e)
        if what == "stop":
            return f"{e.stop_contacts}, largest {e.largest_stop_force_n:.0f} N"
        return f"{e.smallest_tire_load_ratio:.3f}"

    if wheel is not None:  # indented under the car's rows, named by the wheel
        at = f"  {wheel.replace('_', ' ')}"
        titles = (f"{at} lift-offs", f"{at} stop contacts", f"{at} min load ratio")
    else:
        titles = ("lift-offs (air, longest)", "stop contacts", "smallest tire-load ratio")
    return [row(t, lambda b, k=k: cell(b, k)) for t, k in zip(titles, ("lift", "stop", "ratio"))]


def _peak(p):
    """A transmissibility peak's cell: ``1.600 at 4.66 Hz`` (``n/a``: none)."""
    return "n/a" if p is None else "{modulus:.3f} at {frequency_hz:.2f} Hz".format(**p.to_dict())


def _force(body, name, what):
    """A force figure of one body as the report shows it; ``n/a`` if the body has no such force."""
    f = body.forces.get(name)
    if f is None:
        return "n/a"
    if what == "rms":
        return f"{f.rms:.1f}"
    return f"{f.peak:.1f} at {f.peak_time_s:.3f} s"


def _pct(x):
    return "n/a" if x is None else f"{100 * x:.4f} %"


def study_json(
    study: Study, comparison: Optional[Comparison] = None, vehicle: Optional[dict] = None
) -> dict:
    """The JSON document of a study (figures, no time histories); keys in
    docs/getting_started.md, "JSON output".

    Parameters
    ----------
    study : Study
        From :func:`bodyvib.vehicle.study.run_study`; its time histories are left out.
    comparison : Comparison, optional
        From :func:`bodyvib.vehicle.check.compare`; None for ``bodyvib cosim`` (no check keys).
    vehicle : dict, optional
        The car, seat and controller of the run (:func:`vehicle_line`), recorded as
        ``vehicle``.

    Returns
    -------
    dict
        :meth:`bodyvib.vehicle.study.Study.to_dict`, with ``vehicle`` when given, and
        ``check`` (:meth:`bodyvib.vehicle.check.Comparison.to_dict`) and ``verdict`` when a
        comparison is given.
    """
    doc = study.to_dict()
    if vehicle is not None:
        doc["vehicle"] = dict(vehicle)
    if comparison is not None:
        doc["check"] = comparison.to_dict()
        doc["verdict"] = comparison.verdict
    return doc
