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
import sys
from dataclasses import dataclass, field, replace
from typing import Dict, List, Optional

import numpy as np

from bodyvib.comfort.axes import vibration_totals
from bodyvib.comfort.figures import ComfortFigures
from bodyvib.comfort.forces import ForceFigures, ForceStream
from bodyvib.comfort.measures import SeatMeasures, SeatMeasureStream
from bodyvib.comfort.stream import ComfortStream
from bodyvib.frequency.estimate import TransmissibilityEstimate, TransmissibilityStream
from bodyvib.process import interrupts
from bodyvib.process.limits import require_memory
from bodyvib.process.progress import progress_bar
from bodyvib.runtime.errors import BodyvibError

from .control import controller_from_fmu, describe
from .cosim import CsvStream, Master, check_fmu, model_from_fmu, open_controller, open_fmu
from .quarter_car import track_width, wheel_offsets, wheel_sides
from .reference import ReferenceStream
from .road import roads_input, wheel_roads
from .road.driven import RunSettings, driven_road
from .road.synthetic import Road, road_input
from .signals import BODY_SIGNALS, MASTER_SIGNALS, OPTIONAL_SIGNALS

__all__ = [
    "BodyRun",
    "Study",
    "StudyCsv",
    "check_settings",
    "run_study",
    "coupling_error_sweep",
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
    seat_axes : dict of str to float or None
        A car with the seat's horizontal accelerations (a full car): the seat's ISO
        2631-1 weighted r.m.s. per axis, ``seat_aw_x``, ``seat_aw_y`` (Wd) and
        ``seat_aw_z`` (Wk), and its point vibration total value for comfort ``seat_av``
        (k = 1.4, 1.4, 1; :func:`bodyvib.comfort.vibration_totals`), m/s2. The seat's
        records are kept for it (24 bytes a step).
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
    seat_axes: Optional[Dict[str, float]] = None

    def to_dict(self) -> dict:
        """The body's entry of the JSON document (figures, no histories; docs/getting_started.md, "JSON output")."""
        return {
            "fmu": self.fmu,
            "model": self.model,
            **self.figures.to_dict(),
            "coupling_nrmse": self.coupling_nrmse,
            "seat_weighted_rms": self.seat_figures.weighted_rms,
            "transmissibility_peak": self.transmissibility.peak.to_dict(),
            "real_time_factor": self.real_time_factor,
            **(self.seat_measures.to_dict() if self.seat_measures is not None else {}),
            **{name: f.to_dict() for name, f in self.forces.items()},
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

    def to_dict(self) -> dict:
        """The study as JSON: ``settings``, ``road`` and ``bodies`` (figures, no histories).

        ``settings`` holds the run's road, speed, duration, step and seed, and the master.
        """
        settings = self.settings.to_dict()
        del settings["road_options"]  # described with the road
        return {
            "settings": {**settings, "master": self.master},
            "road": dict(self.road),
            "bodies": {label: b.to_dict() for label, b in self.bodies.items()},
        }


def _say(msg, quiet):
    if not quiet:
        print(msg, file=sys.stderr, flush=True)


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
SWEEP_DEFAULTS = RunSettings(duration_s=10.0)


def check_settings(settings: RunSettings, bodies: int = 1, histories: bool = False) -> Road:
    """Validate run settings before any work is done; returns the road.

    Parameters
    ----------
    settings : bodyvib.vehicle.road.driven.RunSettings
        The road, speed, duration, step, seed and road options of the run.
    bodies : int
        Number of bodies the study will run (for its memory estimate).
    histories : bool
        The study keeps its histories (memory grows with the run).

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
    speed, duration, step = settings.speed_m_s, settings.duration_s, settings.step_s
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
            "of wall time per body): shorten --duration or lengthen --step"
        )
    if histories:
        require_memory(
            steps * BYTES_PER_STEP * max(1, bodies),
            f"a {duration:g} s run at a {step:g} s step ({steps:.3g} steps, "
            f"{max(1, bodies)} body/bodies) with its histories",
            "shorten the run or do not keep the histories",
        )
    return driven_road(settings)


def run_study(
    body_fmus: Dict[str, str],
    car_fmu: str,
    settings: RunSettings = COSIM_DEFAULTS,
    extrapolate: bool = True,
    reference: bool = True,
    progress: bool = False,
    quiet: bool = True,
    histories: bool = False,
    csv: "StudyCsv" = None,
    block: int = 4096,
    window_s: float = 5.0,
    controller=None,
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
    extrapolate : bool
        Seat-force extrapolation in the master (see :mod:`bodyvib.vehicle.cosim`).
    reference : bool
        Also run the monolithic reference and report the coupling error.
    progress : bool
        tqdm progress bars on stderr.
    quiet : bool
        No stage messages on stderr.
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

    Returns
    -------
    Study
        Settings, the road's description, time, road input and a :class:`BodyRun`
        per label.

    Raises
    ------
    BodyvibError
        Bad settings, missing or unsuitable FMUs.
    """
    rd = check_settings(settings, bodies=len(body_fmus), histories=histories)
    speed, duration, step = settings.speed_m_s, settings.duration_s, settings.step_s
    n = int(round(duration / step)) + 1
    fs = 1.0 / step
    labels = list(body_fmus)
    check_fmu(car_fmu, "car")  # a body FMU given as the car: named, before any work
    for path in body_fmus.values():
        check_fmu(path, "body")
    controller_fmu = controller if isinstance(controller, (str, os.PathLike)) else None
    law = controller_from_fmu(controller_fmu) if controller_fmu else controller
    reference = reference and (law is None or law.linear)
    car_net = model_from_fmu(car_fmu) if reference else None
    behind, roads = _wheels(car_fmu, car_net, settings, rd)
    nets = {label: model_from_fmu(path) if reference else None for label, path in body_fmus.items()}
    refs = {
        label: ReferenceStream(car_net, net, step, law)
        for label, net in nets.items()
        if net is not None and car_net is not None
    }
    comfort = {label: ComfortStream(fs, 2) for label in labels}  # head, seat
    seat_measures = {label: SeatMeasureStream(fs) for label in labels}
    trans = {label: TransmissibilityStream(fs, n) for label in labels}
    forces = {label: {name: ForceStream(step) for name in OPTIONAL_SIGNALS} for label in labels}
    seat_axes = {label: [] for label in labels}  # the seat's x, y, z blocks (a full car)
    err = {label: [0.0, 0.0] for label in refs}  # sum (a - r)^2, sum r^2
    pairs = {(a, b): [0.0, 0.0] for a in labels for b in labels if a != b}
    w0 = max(0.0, (n - 1) * step / 2 - window_s / 2)  # the plot's window
    k0 = int(math.ceil(w0 / step - 1e-9))
    k1 = min(n - 1, int(math.floor((w0 + window_s) / step + 1e-9)))  # a run shorter than it
    windows = {label: [] for label in labels}
    kept = {label: [] for label in labels} if histories else None
    kept_ref = {label: [] for label in refs} if histories else None
    _say(
        f"co-simulating {', '.join(f'{b} ({os.path.basename(p)})' for b, p in body_fmus.items())}"
        f" on {rd.name} at {speed:g} m/s, {duration:g} s, step {step:g} s"
        + (" with the monolithic reference" if refs else ""),
        quiet,
    )
    bar = progress_bar(n, progress, "co-simulation")
    with contextlib.ExitStack() as stack:
        masters = {}
        for label, path in body_fmus.items():
            car = stack.enter_context(open_fmu(car_fmu, "car", "car"))
            body = stack.enter_context(open_fmu(path, "body", label))
            if controller_fmu is not None:
                law = stack.enter_context(open_controller(controller_fmu, car))
            masters[label] = Master(car, body, step, n, extrapolate=extrapolate, controller=law)
        try:
            for a in range(0, n, block):
                t = np.arange(a, min(n, a + block)) * step
                zw, vw = roads_input(roads, speed, t, behind)
                z, v = zw[:, 0], vw[:, 0]  # the (front) wheel's: the study's road columns
                wheels = (z, v) if len(behind) == 1 else (zw, vw)
                heads = {}
                for label in labels:
                    rows = masters[label].advance(*wheels)
                    sig = dict(zip(MASTER_SIGNALS, rows.T))
                    head, seat = sig["head_acceleration"], sig["seat_acceleration"]
                    heads[label] = head
                    comfort[label].update(np.vstack([head, seat]))
                    seat_measures[label].update(seat, sig["seat_force"], sig["seat_velocity"])
                    trans[label].update(seat, head)
                    for name, stream in forces[label].items():
                        stream.update(sig[name])
                    if not np.isnan(sig["seat_acceleration_x"][0]):  # a car that has them
                        seat_axes[label].append(
                            (sig["seat_acceleration_x"], sig["seat_acceleration_y"], seat)
                        )
                    ref = None
                    if label in refs:
                        interrupts.check()
                        ref = refs[label].advance(*wheels)
                        r = ref["head_acceleration"]
                        err[label][0] += float(np.dot(head - r, head - r))
                        err[label][1] += float(np.dot(r, r))
                    lo, hi = max(k0, a) - a, min(k1 + 1, a + t.size) - a
                    if hi > lo:
                        windows[label].append(head[lo:hi])
                    if histories:
                        kept[label].append(sig)
                        if ref is not None:
                            kept_ref[label].append(ref)
                    if csv is not None:
                        csv.add(label, sig, ref)
                for (x, y), acc in pairs.items():
                    d = heads[x] - heads[y]
                    acc[0] += float(np.dot(d, d))
                    acc[1] += float(np.dot(heads[y], heads[y]))
                if csv is not None:
                    csv.flush(t, z, v)
                if bar is not None:
                    bar.update(t.size)
        finally:
            if bar is not None:
                bar.close()
    out = Study(
        settings=replace(settings, road=str(settings.road)),
        master="gauss-seidel, seat force "
        + ("extrapolated linearly" if extrapolate else "held")
        + (
            f", actuators: {os.path.basename(controller_fmu) if controller_fmu else ''}"
            f"{describe(controller_from_fmu(controller_fmu) if controller_fmu else controller)}"
            if controller is not None
            else ""
        ),
        road=_road_description(rd, roads),
        window_time=np.arange(k0, k1 + 1) * step,
        history_sums={k: tuple(v) for k, v in pairs.items()},
    )
    if histories:
        out.time = np.arange(n) * step
        out.road_displacement, out.road_velocity = road_input(rd, speed, out.time)
    for label, path in body_fmus.items():
        figs = comfort[label].figures()
        head_fig, seat_fig = figs.case(0), figs.case(1)
        run = ref_hist = None
        if histories:
            run = {
                "time": out.time,
                "road_displacement": out.road_displacement,
                "road_velocity": out.road_velocity,
            }
            run.update({k: np.concatenate([b[k] for b in kept[label]]) for k in MASTER_SIGNALS})
            if label in refs:
                ref_hist = {
                    "time": out.time,
                    "road_displacement": out.road_displacement,
                    "road_velocity": out.road_velocity,
                }
                ref_hist.update(
                    {k: np.concatenate([b[k] for b in kept_ref[label]]) for k in kept_ref[label][0]}
                )
        coupling = None
        if label in err:
            if err[label][1] == 0:
                raise BodyvibError("reference signal is zero throughout; NRMSE undefined")
            coupling = math.sqrt(err[label][0] / err[label][1])
        net = nets[label]
        out.bodies[label] = BodyRun(
            fmu=os.fspath(path),
            model=net.name if net is not None else None,
            run=run,
            reference=ref_hist,
            figures=head_fig,
            seat_figures=seat_fig,
            coupling_nrmse=coupling,
            transmissibility=trans[label].result(),
            real_time_factor=duration / max(masters[label].wall_s, 1e-12),
            head_window=np.concatenate(windows[label]) if windows[label] else np.empty(0),
            seat_measures=seat_measures[label].figures(),
            seat_axes=_seat_axes(seat_axes[label], fs),
            forces={
                name: f
                for name, f in ((k, s.figures()) for k, s in forces[label].items())
                if math.isfinite(f.rms)
            },
        )
    return out


def _road_description(road, roads) -> dict:
    """The run's road described; a full car's right track (another road) named beside it."""
    out = road.describe()
    if any(r is not road for r in roads):
        out["right_track"] = (
            "the class's second track, a track width to the right, correlated with the "
            "left (this road) as an isotropic surface (bodyvib.vehicle.road.two_track_road)"
        )
    return out


def _seat_axes(blocks, fs: float) -> Optional[Dict[str, float]]:
    """The seat's ISO 2631-1 figures in x, y and z from its recorded blocks (None: none).

    Returns the per-axis frequency-weighted r.m.s. (``seat_aw_x``, ``seat_aw_y`` with
    Wd, ``seat_aw_z`` with Wk) and the point vibration total value for comfort
    ``seat_av`` (:func:`bodyvib.comfort.vibration_totals`), m/s2.
    """
    if not blocks:
        return None
    x, y, z = (np.concatenate(b) for b in zip(*blocks))
    tot = vibration_totals({"seat_x": x, "seat_y": y, "seat_z": z}, fs)
    out = {f"seat_aw_{a}": tot.axes[f"seat_{a}"].weighted_rms for a in "xyz"}
    out["seat_av"] = tot.points["seat"]
    return out


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
            "by bodyvib (bodyvib build --fmus HalfCar)"
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
            The block's :data:`bodyvib.vehicle.signals.MASTER_SIGNALS`.
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
            for k in MASTER_SIGNALS:
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
        ``step_s``.
    extrapolate : bool
        Master with (True) or without seat-force extrapolation.

    Returns
    -------
    list of dict
        ``{"step_s", "coupling_nrmse", "real_time_factor"}`` per step.
    """
    rows = []
    for h in steps:
        st = run_study(
            {"body": body_fmu},
            car_fmu,
            replace(settings, step_s=float(h)),
            extrapolate=extrapolate,
        )
        b = st.bodies["body"]
        rows.append(
            {
                "step_s": float(h),
                "coupling_nrmse": b.coupling_nrmse,
                "real_time_factor": b.real_time_factor,
            }
        )
    return rows
