"""Co-simulation studies: one road and car, one or more body FMUs, figures and references.

:func:`run_study` drives the quarter car over a road with one or more body FMUs
(:func:`bodyvib.vehicle.cosim.cosimulate`), runs the monolithic reference of each
(:func:`bodyvib.vehicle.reference.reference_run`) and reports, per body, the ISO 2631-1
figures of the head acceleration (:mod:`bodyvib.comfort.figures`), the coupling error
and the seat-to-head transmissibility estimated from the run
(:mod:`bodyvib.frequency.estimate`). The result is a :class:`Study` of :class:`BodyRun`;
their ``to_dict()`` is the JSON form (figures, no time histories).
"""

import contextlib
import math
import os
from dataclasses import dataclass, field, fields, replace
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from bodyvib.comfort import check_step, comfort_verdict, coupling_warning
from bodyvib.comfort.figures import ComfortFigures
from bodyvib.comfort.forces import ForceFigures, ForceStream
from bodyvib.comfort.measures import SeatMeasures, SeatMeasureStream
from bodyvib.comfort.stream import ComfortStream
from bodyvib.frequency.estimate import (
    TRANSMISSIBILITY_BAND_HZ,
    TransmissibilityEstimate,
    TransmissibilityStream,
)
from bodyvib.frequency.response import Peak, find_peaks, transmissibility
from bodyvib.process import interrupts
from bodyvib.process.limits import require_memory
from bodyvib.process.progress import Progress, progress_bar, progress_lines
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.renames import NOT, renamed_parameters

from .control import controller_from_fmu, describe
from .cosim import CsvStream, Master, check_fmu, model_from_fmu, open_controller, open_fmu
from .events import (
    CarEventStream,
    LinearRangeStream,
    RunEvents,
    linear_ranges,
    seated_preloads,
)
from .quarter_car import seated_system, track_width, wheel_offsets, wheel_sides
from .reference import ReferenceStream
from .road import roads_input, wheel_roads
from .road.driven import RunSettings, driven_road
from .road.synthetic import Road, road_input
from .seat_motion import seat_figures, seat_height, seat_method_warnings, seat_totals
from .signals import BODY_SIGNALS, OPTIONAL_SIGNALS

__all__ = [
    "BodyRun",
    "Study",
    "StudyCsv",
    "StudyOptions",
    "check_settings",
    "run_study",
    "coupling_error_sweep",
    "check_study_step",
    "model_peak",
]


@dataclass
class BodyRun:
    """One body FMU on the study's road: its histories, reference, figures and estimate.

    Attributes
    ----------
    fmu : str
        Body FMU path.
    model : str or None
        Name of the model baked into the FMU (None for a foreign FMU).
    run : dict of str to ndarray or None
        Histories of the co-simulation (the signals of :func:`bodyvib.vehicle.cosim.cosimulate`),
        kept only with ``run_study(..., histories=True)``.
    reference : dict of str to ndarray or None
        Histories of the monolithic reference, kept only with ``histories=True``.
    head_window : ndarray
        The head acceleration inside :attr:`Study.window_time` (the plot's window), m/s2.
    figures, seat_figures : ComfortFigures
        ISO 2631-1 figures of the head and of the seat acceleration.
    coupling_nrmse : float or None
        Head-acceleration NRMSE of the run against the reference.
    transmissibility : TransmissibilityEstimate
        Seat-to-head transmissibility estimated from the run.
    real_time_factor : float
        Simulated time / wall time of the co-simulation.
    seat_measures : SeatMeasures or None
        Absorbed power (the run's ``mean(seat_force * seat_velocity)`` and the Lee &
        Pradko estimate from the seat acceleration) and the seat's MSDV
        (:mod:`bodyvib.comfort.measures`).
    forces : dict of str to ForceFigures
        Figures of the body's internal forces over the run (``"neck_force"``,
        ``"lumbar_force"``; only those the body FMU outputs), N and s.
    events : RunEvents or None
        Lift-offs, flights, stop contacts and the smallest tire-load ratio of the run, at
        its communication points (:mod:`bodyvib.vehicle.events`); a car with several
        wheels whose tires are contacts: over all its wheels
        (:func:`bodyvib.vehicle.events.combine_events`).
    wheel_events : dict of str to RunEvents
        The same per wheel (``"front"``, ``"rear_left"``, ...: the suffixes of
        :data:`bodyvib.vehicle.signals.WHEELS`) of a car with several wheels whose tires
        are contacts; empty otherwise.
    reference_events : dict
        The same from the monolithic reference, each event located inside its step:
        element name -> figures (:meth:`bodyvib.runtime.regimes.EventLog.summary`);
        empty for a linear car or without a reference.
    model_transmissibility_peak : Peak or None
        The highest peak of the body model's own seat-to-head transmissibility (its
        frequency response, :func:`model_peak`), beside the run's estimate; None for a
        body FMU without its model.
    seat_axes : dict of str to float or None
        A car with the seat's horizontal accelerations (a half or a full car): the
        seat's ISO 2631-1 weighted r.m.s. per axis, ``seat_aw_x``, ``seat_aw_y`` (Wd)
        and ``seat_aw_z`` (Wk), its point vibration total value for comfort ``seat_av``
        (k = 1, 1, 1), m/s2, and its rotations' ``seat_aw_ry`` (pitch), ``seat_aw_rx``
        (roll, a full car) (We, rad/s2) and ``seat_rotation_av`` (m/s2) (:func:`seat_axes`).
        The seat's records are kept for it (24 bytes a step).
    """

    fmu: str
    model: Optional[str]
    run: Optional[Dict[str, np.ndarray]]
    reference: Optional[Dict[str, np.ndarray]]
    figures: ComfortFigures
    seat_figures: ComfortFigures
    coupling_nrmse: Optional[float]
    transmissibility: TransmissibilityEstimate
    real_time_factor: float
    head_window: np.ndarray = field(default_factory=lambda: np.empty(0))
    seat_measures: Optional[SeatMeasures] = None
    forces: Dict[str, ForceFigures] = field(default_factory=dict)
    events: Optional[RunEvents] = None
    reference_events: Dict[str, dict] = field(default_factory=dict)
    seat_axes: Optional[Dict[str, float]] = None
    model_transmissibility_peak: Optional[Peak] = None
    wheel_events: Dict[str, RunEvents] = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The body's entry of the JSON document (figures, no histories; docs/getting_started.md, "JSON output")."""
        return {
            "fmu": self.fmu,
            "model": self.model,
            **self.figures.to_dict(),
            "coupling_nrmse": self.coupling_nrmse,
            "seat_weighted_rms": self.seat_figures.weighted_rms,
            "transmissibility_peak": self.transmissibility.peak.to_dict(),
            "transmissibility_peak_source": "estimated from the run (H1, seat to head)",
            "model_transmissibility_peak": (
                self.model_transmissibility_peak.to_dict()
                if self.model_transmissibility_peak is not None
                else None
            ),
            "real_time_factor": self.real_time_factor,
            **(self.seat_measures.to_dict() if self.seat_measures is not None else {}),
            **{name: f.to_dict() for name, f in self.forces.items()},
            **({"events": self.events.to_dict()} if self.events is not None else {}),
            **(
                {"wheel_events": {w: e.to_dict() for w, e in self.wheel_events.items()}}
                if self.wheel_events
                else {}
            ),
            **({"reference_events": self.reference_events} if self.reference_events else {}),
            **(self.seat_axes or {}),
        }


@dataclass
class Study:
    """One road and car with one or more body FMUs (:func:`run_study`).

    Attributes
    ----------
    settings : bodyvib.vehicle.road.driven.RunSettings
        Road, speed, duration, step, seed and road options, as given.
    master : str
        The co-simulation master in words.
    road : dict
        The road's description (:meth:`bodyvib.vehicle.road.base.Road.describe`).
    time, road_displacement, road_velocity : ndarray or None
        Communication points (s) and the road input under the tire (m, m/s), kept only
        with ``run_study(..., histories=True)``.
    bodies : dict of str to BodyRun
        Label -> the body's run, in the order given.
    window_time : ndarray
        Times of the plot's window (s), mid-run.
    history_sums : dict of (str, str) to (float, float)
        For each ordered pair of labels ``(a, b)``: ``sum((a_head - b_head)^2)`` and
        ``sum(b_head^2)`` over the run, for :meth:`history_nrmse`.
    warnings : list of str
        Where a figure of the run is outside its method's validity, one line each: a
        step the figures do not allow (``step_validity=False``), a coupling error beyond
        :data:`bodyvib.comfort.COUPLING_NRMSE_LIMIT`, a linear car outside its range
        (``linear_of``).
    """

    settings: RunSettings
    master: str
    road: dict
    time: Optional[np.ndarray] = None
    road_displacement: Optional[np.ndarray] = None
    road_velocity: Optional[np.ndarray] = None
    bodies: Dict[str, BodyRun] = field(default_factory=dict)
    window_time: np.ndarray = field(default_factory=lambda: np.empty(0))
    history_sums: Dict[tuple, tuple] = field(default_factory=dict)
    warnings: List[str] = field(default_factory=list)

    def history_nrmse(self, estimate: str, reference: str) -> float:
        """NRMSE of one body's head acceleration against another's over the whole run.

        Parameters
        ----------
        estimate, reference : str
            Body labels.

        Returns
        -------
        float
            ``rms(a_estimate - a_reference) / rms(a_reference)`` (a fraction).

        Raises
        ------
        BodyvibError
            Unknown labels, or a reference that is zero throughout.
        """
        try:
            num, den = self.history_sums[(estimate, reference)]
        except KeyError:
            raise BodyvibError(f"no bodies '{estimate}' and '{reference}' in this study") from None
        if den == 0:
            raise BodyvibError("reference signal is zero throughout; NRMSE undefined")
        return math.sqrt(num / den)

    def comfort(self, label: str) -> Dict[str, str]:
        """Which ISO 2631-1 method governs a body's head figures, and the report's words.

        Parameters
        ----------
        label : str
            A body of the study.

        Returns
        -------
        dict
            ``comfort_method`` (``"basic"``, ``"vdv"`` or ``"mtvv"``) and
            ``comfort_words`` (the Annex C words, led by the additional measure where the
            basic method is not sufficient): :func:`bodyvib.comfort.comfort_verdict`.
        """
        return comfort_verdict(self.bodies[label].figures, self.settings.duration)

    def to_dict(self) -> dict:
        """The study as JSON: ``settings``, ``road``, ``bodies`` (figures, no histories)
        and ``warnings``.

        ``settings`` holds the run's road, speed, duration, step and seed, and the master;
        each body its figures with :meth:`comfort`.
        """
        settings = self.settings.to_dict()
        del settings["road_options"]  # described with the road
        return {
            "settings": {**settings, "master": self.master},
            "road": dict(self.road),
            "bodies": {
                label: {**b.to_dict(), **self.comfort(label)} for label, b in self.bodies.items()
            },
            "warnings": list(self.warnings),
        }


#: Memory per communication step and body of a study that keeps its histories
#: (``run_study(..., histories=True)``), bytes: every signal of the co-simulation and of
#: the reference at full length (measured about 0.6 kB). A streamed study needs none.
BYTES_PER_STEP = 800

#: Most communication points of one run: 1e9 is 11.6 simulated days at 1 ms, about 9 hours
#: of wall time per body at the master's 30 us per macro-step.
MAX_STEPS = 1e9

#: The run :func:`run_study` makes by default: ``bodyvib cosim``'s defaults.
COSIM_DEFAULTS = RunSettings()

#: The run :func:`coupling_error_sweep` repeats at each step by default: 10 s.
SWEEP_DEFAULTS = RunSettings(duration=10.0)


def check_settings(
    settings: RunSettings, bodies: int = 1, histories: bool = False, car=None
) -> Road:
    """Validate run settings before any work is done; returns the road.

    Parameters
    ----------
    settings : bodyvib.vehicle.road.driven.RunSettings
        The road, speed, duration, step, seed and road options of the run.
    bodies : int
        Number of bodies the study will run (for its memory estimate).
    histories : bool
        The study keeps its histories (memory grows with the run).
    car : bodyvib.runtime.network.Network, optional
        The car: a car with left and right wheels has both its tracks made and checked
        too (an OpenCRG track off the surface, a broken two-track profile).

    Returns
    -------
    bodyvib.vehicle.road.synthetic.TaperedRoad
        The road as driven (:func:`bodyvib.vehicle.road.driven.driven_road`).

    Raises
    ------
    BodyvibError
        A speed, duration or step that is not a positive number, a step longer
        than half the duration, an unknown road or a road file that cannot be
        driven, a negative seed, or a run (or a road) too long for the memory at hand.
    """
    speed, duration, step = settings.speed, settings.duration, settings.step
    for value, what, unit in (
        (speed, "speed", "m/s"),
        (duration, "duration", "s"),
        (step, "step", "s"),
    ):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise BodyvibError(f"{what} must be a positive number of {unit}, got {value!r}")
    if step > duration / 2:
        raise BodyvibError(
            f"step {step:g} s is too long for a {duration:g} s run; use a step "
            "of at most half the duration"
        )
    steps = duration / step + 1
    if steps > MAX_STEPS:
        raise BodyvibError(
            f"a {duration:g} s run at a {step:g} s step has {steps:.3g} "
            f"communication points; the limit is {MAX_STEPS:.3g} (about 9 hours "
            "of wall time per body): shorten 'duration' or lengthen 'step'",
            parameters=("duration", "step"),
        )
    if histories:
        require_memory(
            steps * BYTES_PER_STEP * max(1, bodies),
            f"a {duration:g} s run at a {step:g} s step ({steps:.3g} steps, "
            f"{max(1, bodies)} body/bodies) with its histories",
            "shorten the run or do not keep the histories",
        )
    road = driven_road(settings)
    if car is not None:
        wheel_roads(settings, road, wheel_sides(car), track_width(car))
    return road


@dataclass(frozen=True)
class StudyOptions:
    """How :func:`run_study` runs: the master, the reference, what it keeps and says.

    Attributes
    ----------
    extrapolate : bool
        Seat-force extrapolation in the master (see :mod:`bodyvib.vehicle.cosim`).
    reference : bool
        Also run the monolithic reference and report the coupling error.
    progress : bool or callable
        True: a progress bar and the stage messages on stderr; a callable receives the
        messages (:mod:`bodyvib.process.progress`).
    histories : bool
        Keep every signal of every run at full length (``BodyRun.run``,
        ``BodyRun.reference``, ``Study.time``): memory grows with the run. By default
        only the figures, running sums and the plot window are kept.
    csv : StudyCsv, optional
        Receives the time histories block by block (streamed to disk).
    block : int
        Communication points per block.
    window_s : float
        Length of the plot window kept mid-run, s.
    controller : bodyvib.vehicle.control.SkyhookController or str, optional
        Drive the car FMU's actuators (:class:`bodyvib.vehicle.cosim.Master`) by this law
        or by a controller FMU (its path, :func:`bodyvib.vehicle.cosim.open_controller`);
        the reference is then the closed loop of the law (of a controller FMU: of the
        gains it declares, :func:`bodyvib.vehicle.control.controller_from_fmu`), and a
        semi-active (nonlinear) law has none.
    step_validity : bool
        Refuse a step longer than the figures allow (:func:`check_study_step`). False
        runs it anyway (a study of the step itself, :func:`coupling_error_sweep`) and
        the study's ``warnings`` say that its figures are not valid.
    linear_of : Network, optional
        The car with its nonlinear elements whose linearization the car FMU is
        (``bodyvib cosim --linear``): the study's ``warnings`` say wherever the run leaves
        the linear model's range (a dynamic tire force beyond the static load, travel
        beyond the stops' gaps; :class:`bodyvib.vehicle.events.LinearRangeStream`).

    Examples
    --------
    >>> StudyOptions(extrapolate=False).block
    4096
    """

    extrapolate: bool = True
    reference: bool = True
    progress: Progress = False
    histories: bool = False
    csv: Optional["StudyCsv"] = None
    block: int = 4096
    window_s: float = 5.0
    controller: Any = None
    step_validity: bool = True
    linear_of: Any = None


@renamed_parameters(quiet=NOT("progress"))
def run_study(
    body_fmus: Dict[str, str],
    car_fmu: str,
    settings: RunSettings = COSIM_DEFAULTS,
    options: Optional[StudyOptions] = None,
    **keywords,
) -> Study:
    """Co-simulate the car with each body FMU on one road; figures, references, transmissibility.

    Parameters
    ----------
    body_fmus : dict of str to str
        Label -> body FMU path.
    car_fmu : str
        Car FMU path.
    settings : bodyvib.vehicle.road.driven.RunSettings
        The road (ISO 8608 class ``A``-``H``, ``bump``, ``sweep`` or a road file, faded in
        from level: :func:`bodyvib.vehicle.road.driven.driven_road`), speed (m/s), duration
        (s), communication step (s), random-road seed and road options; by default those of
        ``bodyvib cosim``.
    options : StudyOptions, optional
        The master, the reference, the histories kept, the CSV stream, progress and
        messages; by default ``StudyOptions()``.
    **keywords
        Any field of :class:`StudyOptions` (``extrapolate``, ``reference``, ``progress``,
        ``histories``, ``csv``, ``block``, ``window_s``, ``controller``,
        ``step_validity``, ``linear_of``), replacing that of ``options``.

    Returns
    -------
    Study
        Settings, the road's description, time, road input and a :class:`BodyRun`
        per label.

    Raises
    ------
    BodyvibError
        Bad settings, missing or unsuitable FMUs, a step longer than the figures allow
        (:func:`check_study_step`; a ``ValueError`` naming ``step``).
    TypeError
        A keyword that is no field of :class:`StudyOptions`.
    """
    opts = _study_options(options, keywords)
    rd = check_settings(settings, bodies=len(body_fmus), histories=opts.histories)
    n = int(round(settings.duration / settings.step)) + 1
    check_fmu(car_fmu, "car")  # a body FMU given as the car: named, before any work
    for path in body_fmus.values():
        check_fmu(path, "body")
    controller_fmu = opts.controller if isinstance(opts.controller, (str, os.PathLike)) else None
    law = controller_from_fmu(controller_fmu) if controller_fmu else opts.controller
    reference = opts.reference and (law is None or law.linear)
    car_model = model_from_fmu(car_fmu)
    validity = check_study_step(
        settings.step,
        car_model,
        [model_from_fmu(p) for p in body_fmus.values()],
        enforce=opts.step_validity,
    )
    car_net = car_model if reference else None
    behind, roads = _wheels(car_fmu, car_net, settings, rd)
    window = _window(n, settings.step, opts.window_s)
    bodies = _recorders(
        body_fmus, car_model, (settings.step, n, window), opts, (car_net, reference, law)
    )
    progress_lines(opts.progress)(_opening(body_fmus, rd, settings, bodies))
    pairs = {(a, b): [0.0, 0.0] for a in bodies for b in bodies if a != b}
    bar = progress_bar(n, opts.progress, "co-simulation")
    with contextlib.ExitStack() as stack:
        for rec in bodies.values():
            rec.open(stack, car_fmu, controller_fmu, law, n, opts.extrapolate)
        try:
            for a in range(0, n, opts.block):
                t = np.arange(a, min(n, a + opts.block)) * settings.step
                zw, vw = roads_input(roads, settings.speed, t, behind)
                z, v = zw[:, 0], vw[:, 0]  # the (front) wheel's: the study's road columns
                wheels = (z, v) if len(behind) == 1 else (zw, vw)
                heads = {}
                for label, rec in bodies.items():
                    sig, ref = rec.advance(a, t.size, wheels)
                    heads[label] = sig["head_acceleration"]
                    if opts.csv is not None:
                        opts.csv.add(label, sig, ref)
                _add_pairs(pairs, heads)
                if opts.csv is not None:
                    opts.csv.flush(t, z, v)
                if bar is not None:
                    bar.update(t.size)
        finally:
            if bar is not None:
                bar.close()
    out = _study(settings, opts, controller_fmu, (rd, roads), window, pairs, bodies)
    out.warnings += validity + [w for rec in bodies.values() for w in rec.warnings()]
    return out


def _recorders(body_fmus, car_model, points, opts, reference):
    """A :class:`_BodyRecorder` per body label: the run's ``points`` (step, count and the
    plot's window), its monolithic reference where ``reference`` (the car model or None,
    whether to read the bodies' models and run it, the control law) asks, its tires'
    static loads, the occupant's start values, the linear range it watches and the seat's
    height."""
    step, n, window = points
    car_net, run_reference, law = reference
    bodies = {
        label: _BodyRecorder(label, path, step, n, window, opts.histories)
        for label, path in body_fmus.items()
    }
    for rec in bodies.values():
        rec.add_reference(car_net, run_reference, law)
    tire_load, occupant = _static_load(car_model, body_fmus, {k: r.net for k, r in bodies.items()})
    for label, rec in bodies.items():
        rec.watch_events(tire_load[label], occupant.get(label), opts.linear_of)
        rec.seat = seat_height(car_model)
    return bodies


#: Frequencies the model's own transmissibility peak is searched over, Hz: the run
#: estimate's band at 0.01 Hz (a peak's frequency to well under the estimate's resolution).
MODEL_PEAK_HZ = np.arange(TRANSMISSIBILITY_BAND_HZ[0], TRANSMISSIBILITY_BAND_HZ[1] + 1e-9, 0.01)


def model_peak(body) -> Optional[Peak]:
    """The highest peak of a body model's seat-to-head transmissibility ``|X_head / X_seat|``.

    Parameters
    ----------
    body : Network or None
        A body model (base ``seat``).

    Returns
    -------
    Peak or None
        Over :data:`MODEL_PEAK_HZ` (the run estimate's band); None without a model.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> p = model_peak(load_model("reduced-paper"))
    >>> round(p.frequency_hz, 1), round(p.modulus, 2)
    (4.4, 1.45)
    """
    if body is None:
        return None
    modulus = np.abs(transmissibility(body, MODEL_PEAK_HZ))
    peaks = find_peaks(MODEL_PEAK_HZ, modulus)
    return max(peaks, key=lambda p: p.modulus) if peaks else None


def check_study_step(step: float, car, bodies, enforce: bool = True) -> List[str]:
    """Refuse a study's step that cannot give the figures (:func:`bodyvib.comfort.check_step`).

    The models are the seated systems of the car with each body (either alone where
    the other is unknown, a foreign FMU).

    Parameters
    ----------
    step : float
        Communication step, s.
    car : Network or None
        The car's model.
    bodies : sequence of Network or None
        The bodies' models.
    enforce : bool
        False: do not refuse; return the line saying the figures are not valid.

    Returns
    -------
    list of str
        Empty, or (``enforce=False``) the one line of a step too long.

    Raises
    ------
    BodyvibError
        The step longer than the largest valid one (``enforce=True``), naming it.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> check_study_step(0.05, load_car(), [load_model("reduced-paper")], enforce=False)[0][:60]
    'step 0.05 s is too long for the figures: the Wk band up to 8'
    """
    models = [
        seated_system(car, b) if car is not None and b is not None else (car or b)
        for b in (bodies or [None])
    ]
    models = [m for m in models if m is not None]
    if enforce:
        check_step(step, models)
        return []
    try:
        check_step(step, models)
    except BodyvibError as exc:
        return [f"{exc} (not refused: step_validity=False): the figures are not valid"]
    return []


def _study_options(options, keywords):
    """``options`` with the keyword arguments of :func:`run_study` put in."""
    opts = StudyOptions() if options is None else options
    unknown = sorted(set(keywords) - {f.name for f in fields(StudyOptions)})
    if unknown:
        raise TypeError(f"run_study() got an unexpected keyword argument '{unknown[0]}'")
    return replace(opts, **keywords)


def _window(n, step, window_s):
    """First and last communication point of the plot's window, mid-run."""
    w0 = max(0.0, (n - 1) * step / 2 - window_s / 2)
    k0 = int(math.ceil(w0 / step - 1e-9))
    k1 = min(n - 1, int(math.floor((w0 + window_s) / step + 1e-9)))  # a run shorter than it
    return k0, k1


def _opening(body_fmus, rd, settings, bodies):
    """The study's first stage message."""
    return (
        f"co-simulating {', '.join(f'{b} ({os.path.basename(p)})' for b, p in body_fmus.items())}"
        f" on {rd.name} at {settings.speed:g} m/s, {settings.duration:g} s, "
        f"step {settings.step:g} s"
        + (
            " with the monolithic reference"
            if any(rec.ref is not None for rec in bodies.values())
            else ""
        )
    )


def _add_pairs(pairs, heads):
    """Add one block's ``sum((a - b)^2)`` and ``sum(b^2)`` of each pair of heads."""
    for (x, y), acc in pairs.items():
        d = heads[x] - heads[y]
        acc[0] += float(np.dot(d, d))
        acc[1] += float(np.dot(heads[y], heads[y]))


class _BodyRecorder:
    """One body of a study: its master, reference and the running figures of its run.

    Parameters
    ----------
    label : str
        The body's label.
    path : str
        Body FMU path.
    step : float
        Communication step, s.
    n : int
        Communication points of the run.
    window : (int, int)
        First and last communication point of the plot's window.
    histories : bool
        Keep every signal at full length.
    """

    def __init__(self, label, path, step, n, window, histories):
        fs = 1.0 / step
        self.label, self.path, self.step, self.window = label, path, step, window
        self.comfort = ComfortStream(fs, 2)  # head, seat
        self.measures = SeatMeasureStream(fs)
        self.trans = TransmissibilityStream(fs, n)
        self.forces = {name: ForceStream(step) for name in OPTIONAL_SIGNALS}
        self.net = self.ref = self.master = None
        self.err = [0.0, 0.0]  # sum (a - r)^2, sum r^2
        self.head_window = []
        self.kept = [] if histories else None
        self.kept_ref = [] if histories else None
        self.events, self.occupant = CarEventStream(step, {}), None
        self.range: Optional[LinearRangeStream] = None  # a linear car's range (linear_of)
        self.tire_loads = {}
        self.seat_blocks = []  # the seat's x, y, z (a car that has x and y: half, full car)
        self.seat = None  # the seat's height and whether the body rolls (seat_height)
        self.seat_warnings: List[str] = []  # the seat's axes beyond the basic method

    def watch_events(self, tire_loads, occupant, linear_of=None):
        """The tires' static loads (N, by tire-force output: ``tire_force``,
        ``tire_force_front``, ...) for the events, the car FMU's start values that put
        this body's weight on its seat (None: the car's own), and the nonlinear car whose
        linearization the car FMU is (None: watch no range)."""
        self.tire_loads = tire_loads
        self.occupant = occupant
        if linear_of is not None:
            net = self.net or model_from_fmu(self.path)
            mass = net.total_mass() if net is not None else None
            self.range = LinearRangeStream(self.step, linear_ranges(linear_of, mass))

    def warnings(self) -> List[str]:
        """The run's lines beyond validity: its coupling error, a linear car's range, the
        seat's axes where the basic method is not sufficient (after :meth:`result`)."""
        lines = [coupling_warning(self._coupling(), self.step)]
        lines += self.range.warnings() if self.range is not None else []
        lines += self.seat_warnings
        return [f"{self.label}: {w}" for w in lines if w is not None]

    def add_reference(self, car_net, reference, law):
        """Read the body's model and set up its monolithic reference (``reference``)."""
        self.net = model_from_fmu(self.path) if reference else None
        if self.net is not None and car_net is not None:
            self.ref = ReferenceStream(car_net, self.net, self.step, law)

    def open(self, stack, car_fmu, controller_fmu, law, n, extrapolate):
        """Open the car, the body (and the controller FMU) on ``stack``; their master."""
        car = stack.enter_context(open_fmu(car_fmu, "car", "car", self.occupant))
        body = stack.enter_context(open_fmu(self.path, "body", self.label))
        if controller_fmu is not None:
            law = stack.enter_context(open_controller(controller_fmu, car))
        watch = self.range.columns if self.range is not None else ()  # a linear car's wheels
        self.master = Master(
            car, body, self.step, n, extrapolate=extrapolate, controller=law, watch=watch
        )
        self.events = CarEventStream(self.step, self.tire_loads, self.master.wheels)

    def advance(self, a, size, wheels):
        """Run one block from point ``a``; its signals and the reference's (or None)."""
        rows = self.master.advance(*wheels)
        sig = dict(zip(self.master.columns, rows.T))
        head, seat = sig["head_acceleration"], sig["seat_acceleration"]
        self.comfort.update(np.vstack([head, seat]))
        self.measures.update(seat, sig["seat_force"], sig["seat_velocity"])
        self.trans.update(seat, head)
        for name, stream in self.forces.items():
            stream.update(sig[name])
        self.events.update(sig)
        if self.range is not None:
            self.range.update_columns(sig)
        if not np.isnan(sig["seat_acceleration_x"][0]):  # a car that has them
            self.seat_blocks.append((sig["seat_acceleration_x"], sig["seat_acceleration_y"], seat))
        ref = None
        if self.ref is not None:
            interrupts.check()
            ref = self.ref.advance(*wheels)
            r = ref["head_acceleration"]
            self.err[0] += float(np.dot(head - r, head - r))
            self.err[1] += float(np.dot(r, r))
        k0, k1 = self.window
        lo, hi = max(k0, a) - a, min(k1 + 1, a + size) - a
        if hi > lo:
            self.head_window.append(head[lo:hi])
        if self.kept is not None:
            self.kept.append(sig)
            if ref is not None:
                self.kept_ref.append(ref)
        return sig, ref

    def result(self, road, duration):
        """The body's :class:`BodyRun`; ``road`` holds the study's time and road columns."""
        figs = self.comfort.figures()
        seat_axes, self.seat_warnings = _seat_axes(self.seat_blocks, 1.0 / self.step, self.seat)
        return BodyRun(
            fmu=os.fspath(self.path),
            model=self.net.name if self.net is not None else None,
            run=self._histories(road, self.kept, self.master.columns),
            reference=self._histories(road, self.kept_ref, None),
            figures=figs.case(0),
            seat_figures=figs.case(1),
            coupling_nrmse=self._coupling(),
            transmissibility=self.trans.result(),
            real_time_factor=duration / max(self.master.wall_s, 1e-12),
            head_window=np.concatenate(self.head_window) if self.head_window else np.empty(0),
            seat_measures=self.measures.figures(),
            forces={
                name: f
                for name, f in ((k, s.figures()) for k, s in self.forces.items())
                if math.isfinite(f.rms)
            },
            events=self.events.result(),
            wheel_events=self.events.wheel_results(),
            reference_events=self.ref.events() if self.ref is not None else {},
            seat_axes=seat_axes,
            model_transmissibility_peak=model_peak(self.net or model_from_fmu(self.path)),
        )

    @staticmethod
    def _histories(road, blocks, names):
        """The time and road columns with the blocks joined (None when none were kept)."""
        if not blocks:
            return None
        names = names if names is not None else blocks[0]
        return {**road, **{k: np.concatenate([b[k] for b in blocks]) for k in names}}

    def _coupling(self):
        if self.ref is None:
            return None
        if self.err[1] == 0:
            raise BodyvibError("reference signal is zero throughout; NRMSE undefined")
        return math.sqrt(self.err[0] / self.err[1])


def _study(settings, opts, controller_fmu, road_and_wheels, window, pairs, bodies):
    """The :class:`Study` of a finished run; ``road_and_wheels``: the road, each wheel's."""
    rd, roads = road_and_wheels
    step = settings.step
    n = int(round(settings.duration / step)) + 1
    controller = opts.controller
    out = Study(
        settings=replace(settings, road=str(settings.road)),
        master="gauss-seidel, seat force "
        + ("extrapolated linearly" if opts.extrapolate else "held")
        + (
            f", actuators: {os.path.basename(controller_fmu) if controller_fmu else ''}"
            f"{describe(controller_from_fmu(controller_fmu) if controller_fmu else controller)}"
            if controller is not None
            else ""
        ),
        road=_road_description(rd, roads),
        window_time=np.arange(window[0], window[1] + 1) * step,
        history_sums={k: tuple(v) for k, v in pairs.items()},
    )
    road = {}
    if opts.histories:
        out.time = np.arange(n) * step
        out.road_displacement, out.road_velocity = road_input(rd, settings.speed, out.time)
        road = {
            "time": out.time,
            "road_displacement": out.road_displacement,
            "road_velocity": out.road_velocity,
        }
    for label, rec in bodies.items():
        out.bodies[label] = rec.result(road, settings.duration)
    return out


def _static_load(car, body_fmus, nets):
    """Per body label, the tires' static loads and the car FMU's start values that put
    that body's weight on the seat (the car's static load at its seat point).

    The loads are by tire-force output (``tire_force``, ``tire_force_front``, ...): the
    static force of that output's element, N, or None where it is no contact. A body FMU
    without its model leaves the car's own value.
    """
    loads, occupant = {}, {}
    if car is None:
        return {label: {} for label in body_fmus}, occupant
    tires = {
        o["name"]: o["signal"].rpartition(".")[0]
        for o in car.fmu_outputs
        if o["name"].startswith("tire_force")
    }
    for label, path in body_fmus.items():
        body = nets.get(label) or model_from_fmu(path)
        pre, start = seated_preloads(car, body.total_mass() if body is not None else None)
        if start:
            occupant[label] = start
        loads[label] = {name: pre.get(el) for name, el in tires.items()}
    return loads, occupant


def _road_description(road, roads) -> dict:
    """The run's road described; a full car's tracks, when they are other roads, beside it.

    A random road's right track is the class's second track (``right_track`` says so, the
    left being the road itself); a road file's tracks are each read from the file
    (``tracks``: each track described, in the order of the wheels on them, left first for
    the full car: an OpenCRG surface's lateral offsets or a two-track profile's columns).
    """
    out = road.describe()
    others = [r for r in roads if r is not road]
    if not others:
        return out
    if any(r is road for r in roads):
        out["right_track"] = (
            "the class's second track, a track width to the right, correlated with the "
            "left (this road) as an isotropic surface (bodyvib.vehicle.road.two_track_road)"
        )
        return out
    distinct = list({id(r): r for r in roads}.values())  # in the wheels' order
    out["tracks"] = [r.describe() for r in distinct]
    return out


def _seat_axes(blocks, fs: float, seat) -> Tuple[Optional[Dict[str, float]], List[str]]:
    """:func:`seat_figures` of the seat's recorded blocks (None: none were recorded), and
    a line for each axis where ISO 2631-1's basic method is not sufficient."""
    if not blocks:
        return None, []
    x, y, z = (np.concatenate(b) for b in zip(*blocks))
    totals = seat_totals(x, y, z, fs, seat)
    return seat_figures(totals), seat_method_warnings(totals, x.size / fs)


def _wheels(car_fmu, car_net, settings, road):
    """Distance of each road input pair of the car FMU behind the first, m, and the road
    of each (a full car's left and right tracks, :func:`bodyvib.vehicle.road.tracks.wheel_roads`)."""
    net = car_net if car_net is not None else model_from_fmu(car_fmu)
    if net is not None:
        return wheel_offsets(net), wheel_roads(settings, road, wheel_sides(net), track_width(net))
    from fmpy import read_model_description

    from .cosim import road_pairs

    pairs = road_pairs(v.name for v in read_model_description(car_fmu).modelVariables)
    if len(pairs) > 1:
        raise BodyvibError(
            f"car FMU '{car_fmu}' has {len(pairs)} road inputs but carries no bodyvib "
            "model, so the distance between its wheels is unknown; use a car FMU built "
            "by build_fmus (HalfCar)",
            parameters=("build_fmus",),
        )
    return (0.0,), (road,)


class StudyCsv:
    """A study's time histories streamed to CSV, one row per communication point.

    Columns: ``time``, the road, the car's signals, and per body its head acceleration,
    head and torso displacement, seat force and the reference's head acceleration
    (prefixed ``<label>.`` when the study has several bodies); header ``name [unit]``.
    Nothing is placed at the path before :meth:`place` (see :class:`bodyvib.vehicle.cosim.CsvStream`).

    Parameters
    ----------
    path : str
        The CSV file; left as it was until :meth:`place`.
    labels : sequence of str
        The study's bodies, in order.
    """

    _BODY = tuple(s.name for s in BODY_SIGNALS)

    def __init__(self, path, labels):
        self._out = CsvStream(path)
        self._labels = list(labels)
        self._blocks = {}

    def add(self, label, signals, reference):
        """Hold one body's signals of the current block.

        Parameters
        ----------
        label : str
            One of the study's ``labels``.
        signals : dict of str to ndarray
            The block's :data:`bodyvib.vehicle.signals.MASTER_SIGNALS` (and a car's
            per-wheel signals: the master's ``columns``).
        reference : dict of str to ndarray or None
            The reference's signals of the block.
        """
        self._blocks[label] = (signals, reference)

    def flush(self, t, z, v):
        """Write the current block, once every body has added its signals.

        Parameters
        ----------
        t, z, v : ndarray
            The block's times (s), road displacement (m) and road velocity (m/s).
        """
        many = len(self._labels) > 1
        cols = {"time": t, "road_displacement": z, "road_velocity": v}
        for label in self._labels:
            sig, ref = self._blocks[label]
            for k in sig:  # the master's columns: a car's per-wheel ones too
                if many and k not in self._BODY:
                    cols.setdefault(k, sig[k])
                elif not many or k in self._BODY:
                    cols[f"{label}.{k}" if many else k] = sig[k]
            if ref is not None:
                cols[
                    f"{label}.reference_head_acceleration"
                    if many
                    else "reference_head_acceleration"
                ] = ref["head_acceleration"]
        self._out.write(cols)
        self._blocks = {}

    def place(self):
        """Put the file at its path (or stage it with the other outputs)."""
        self._out.place()

    def discard(self):
        """Delete the unfinished file."""
        self._out.discard()


def coupling_error_sweep(
    steps,
    body_fmu: str,
    car_fmu: str,
    settings: RunSettings = SWEEP_DEFAULTS,
    extrapolate: bool = True,
) -> List[dict]:
    """Head-acceleration coupling NRMSE against the monolithic reference, per step.

    Parameters
    ----------
    steps : sequence of float
        Communication steps, s.
    body_fmu, car_fmu : str
        FMU paths (bodyvib FMUs: the reference comes from their parameter files).
    settings : bodyvib.vehicle.road.driven.RunSettings
        As :func:`run_study` takes them (a 10 s run by default); each step replaces its
        ``step``.
    extrapolate : bool
        Master with (True) or without seat-force extrapolation.

    Returns
    -------
    list of dict
        ``{"step", "coupling_nrmse", "real_time_factor", "warnings"}`` per step; the
        steps are run even where the figures are not valid (``warnings`` says so,
        :attr:`Study.warnings`).
    """
    rows = []
    for h in steps:
        st = run_study(
            {"body": body_fmu},
            car_fmu,
            replace(settings, step=float(h)),
            extrapolate=extrapolate,
            step_validity=False,  # the coupling error at steps the figures do not allow
        )
        b = st.bodies["body"]
        rows.append(
            {
                "step": float(h),
                "coupling_nrmse": b.coupling_nrmse,
                "real_time_factor": b.real_time_factor,
                "warnings": st.warnings,
            }
        )
    return rows
