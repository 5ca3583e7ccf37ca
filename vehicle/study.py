"""Co-simulation studies: one road and car, one or more body FMUs, figures and references.

:func:`run_study` drives the quarter car over a road with one or more body FMUs
(:func:`vehicle.cosim.cosimulate`), runs the monolithic reference of each
(:func:`vehicle.reference.reference_run`) and reports, per body, the ISO 2631-1
figures of the head acceleration (:mod:`bodyvib.comfort`), the coupling error
and the seat-to-head transmissibility estimated from the run
(:mod:`bodyvib.estimate`). The result is a :class:`Study` of :class:`BodyRun`;
their ``to_dict()`` is the JSON form (figures, no time histories).
"""

import math
import os
import sys
import time
from dataclasses import asdict, dataclass, field
from typing import Dict, List, Optional

import numpy as np

from bodyvib.comfort import ComfortFigures, comfort_figures
from bodyvib.estimate import TransmissibilityEstimate, estimate_transmissibility
from bodyvib.runtime.errors import BodyvibError

from .cosim import cosimulate, model_from_fmu, open_fmu
from .reference import nrmse, reference_run
from .roads import make_road, road_input

__all__ = ["StudySettings", "BodyRun", "Study", "check_settings", "run_study",
           "coupling_error_sweep"]


@dataclass(frozen=True)
class StudySettings:
    """The settings of a study, as given to :func:`run_study`.

    Attributes
    ----------
    road : str
        Road name as given (``"C"``, ``"bump"``, ...).
    speed_m_s, duration_s, step_s : float
        Vehicle speed (m/s), simulated time (s), communication step (s).
    seed : int
        Random-road seed.
    master : str
        The co-simulation master in words.
    """

    road: str
    speed_m_s: float
    duration_s: float
    step_s: float
    seed: int
    master: str

    def to_dict(self) -> dict:
        """The settings as a JSON-ready dict."""
        return asdict(self)


@dataclass
class BodyRun:
    """One body FMU on the study's road: its histories, reference, figures and estimate.

    Attributes
    ----------
    fmu : str
        Body FMU path.
    model : str or None
        Name of the model baked into the FMU (None for a foreign FMU).
    run : dict of str to ndarray
        Recorded histories of the co-simulation (:func:`vehicle.cosim.cosimulate`).
    reference : dict of str to ndarray or None
        Monolithic reference histories (:func:`vehicle.reference.reference_run`).
    figures, seat_figures : ComfortFigures
        ISO 2631-1 figures of the head and of the seat acceleration.
    coupling_nrmse : float or None
        Head-acceleration NRMSE of the run against the reference.
    transmissibility : TransmissibilityEstimate
        Seat-to-head transmissibility estimated from the run.
    real_time_factor : float
        Simulated time / wall time of the co-simulation.
    """

    fmu: str
    model: Optional[str]
    run: Dict[str, np.ndarray]
    reference: Optional[Dict[str, np.ndarray]]
    figures: ComfortFigures
    seat_figures: ComfortFigures
    coupling_nrmse: Optional[float]
    transmissibility: TransmissibilityEstimate
    real_time_factor: float

    def to_dict(self) -> dict:
        """The body's entry of the JSON document (figures, no histories; README "JSON output")."""
        return {"fmu": self.fmu, "model": self.model, **self.figures.to_dict(),
                "coupling_nrmse": self.coupling_nrmse,
                "seat_weighted_rms": self.seat_figures.weighted_rms,
                "transmissibility_peak": self.transmissibility.peak.to_dict(),
                "real_time_factor": self.real_time_factor}


@dataclass
class Study:
    """One road and car with one or more body FMUs (:func:`run_study`).

    Attributes
    ----------
    settings : StudySettings
    road : dict
        The road's description (:meth:`vehicle.roads.Road.describe`).
    time, road_displacement, road_velocity : ndarray
        Communication points (s) and the road input under the tire (m, m/s).
    bodies : dict of str to BodyRun
        Label -> the body's run, in the order given.
    """

    settings: StudySettings
    road: dict
    time: np.ndarray
    road_displacement: np.ndarray
    road_velocity: np.ndarray
    bodies: Dict[str, BodyRun] = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The study as JSON: ``settings``, ``road`` and ``bodies`` (figures, no histories)."""
        return {"settings": self.settings.to_dict(), "road": dict(self.road),
                "bodies": {label: b.to_dict() for label, b in self.bodies.items()}}


def _say(msg, quiet):
    if not quiet:
        print(msg, file=sys.stderr, flush=True)


def check_settings(road: str, speed: float, duration: float, step: float, seed: int = 0):
    """Validate run settings before any work is done; returns the road.

    Parameters
    ----------
    road, speed, duration, step, seed
        As :func:`run_study`.

    Returns
    -------
    vehicle.roads.Road

    Raises
    ------
    BodyvibError
        A speed, duration or step that is not a positive number, a step longer
        than half the duration, an unknown road, or a negative seed.
    """
    for value, what, unit in ((speed, "speed", "m/s"), (duration, "duration", "s"),
                              (step, "step", "s")):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise BodyvibError(f"{what} must be a positive number of {unit}, got {value!r}")
    if step > duration / 2:
        raise BodyvibError(f"step {step:g} s is too long for a {duration:g} s run; use a step "
                           "of at most half the duration")
    return make_road(road, speed, duration, seed=seed)


def run_study(body_fmus: Dict[str, str], car_fmu: str, road: str = "C", speed: float = 20.0,
              duration: float = 30.0, step: float = 1e-3, seed: int = 0,
              extrapolate: bool = True, reference: bool = True, progress: bool = False,
              quiet: bool = True) -> Study:
    """Co-simulate the car with each body FMU on one road; figures, references, transmissibility.

    Parameters
    ----------
    body_fmus : dict of str to str
        Label -> body FMU path.
    car_fmu : str
        Car FMU path.
    road : str
        ISO 8608 class ``A``-``H``, ``bump`` or ``sweep`` (:func:`vehicle.roads.make_road`).
    speed : float
        m/s.
    duration : float
        s.
    step : float
        Communication step, s.
    seed : int
        Random-road seed.
    extrapolate : bool
        Seat-force extrapolation in the master (see :mod:`vehicle.cosim`).
    reference : bool
        Also run the monolithic reference and report the coupling error.
    progress : bool
        tqdm progress bars on stderr.
    quiet : bool
        No stage messages on stderr.

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
    rd = check_settings(road, speed, duration, step, seed)
    n = int(round(duration / step)) + 1
    t = np.arange(n) * step
    z, v = road_input(rd, speed, t)
    fs = 1.0 / step
    car_net = model_from_fmu(car_fmu) if reference else None
    out = Study(
        settings=StudySettings(road=str(road), speed_m_s=speed, duration_s=duration,
                               step_s=step, seed=seed, master="gauss-seidel, seat force "
                               + ("extrapolated linearly" if extrapolate else "held")),
        road=rd.describe(), time=t, road_displacement=z, road_velocity=v)
    for label, path in body_fmus.items():
        _say(f"co-simulating {label} ({os.path.basename(path)}) on {rd.name} at {speed:g} m/s, "
             f"{duration:g} s, step {step:g} s", quiet)
        with open_fmu(car_fmu, "car", "car") as car, open_fmu(path, "body", label) as body:
            t0 = time.perf_counter()
            run = cosimulate(car, body, z, v, step, extrapolate=extrapolate, progress=progress)
            wall = time.perf_counter() - t0
        ref, err = None, None
        body_net = model_from_fmu(path) if reference else None
        if reference and body_net is not None and car_net is not None:
            _say(f"monolithic reference of {label}", quiet)
            ref = reference_run(car_net, body_net, z, v, step)
            err = nrmse(run["head_acceleration"], ref["head_acceleration"])
        out.bodies[label] = BodyRun(
            fmu=os.fspath(path),
            model=body_net.name if body_net is not None else None,
            run=run,
            reference=ref,
            figures=comfort_figures(run["head_acceleration"], fs),
            seat_figures=comfort_figures(run["seat_acceleration"], fs),
            coupling_nrmse=err,
            transmissibility=estimate_transmissibility(run["seat_acceleration"],
                                                       run["head_acceleration"], fs),
            real_time_factor=duration / wall,
        )
    return out


def coupling_error_sweep(steps, body_fmu: str, car_fmu: str, road: str = "C", speed: float = 20.0,
                         duration: float = 10.0, seed: int = 0, extrapolate: bool = True
                         ) -> List[dict]:
    """Head-acceleration coupling NRMSE against the monolithic reference, per step.

    Parameters
    ----------
    steps : sequence of float
        Communication steps, s.
    body_fmu, car_fmu : str
        FMU paths (bodyvib FMUs: the reference comes from their parameter files).
    road, speed, duration, seed : see :func:`run_study`.
    extrapolate : bool
        Master with (True) or without seat-force extrapolation.

    Returns
    -------
    list of dict
        ``{"step_s", "coupling_nrmse", "real_time_factor"}`` per step.
    """
    rows = []
    for h in steps:
        st = run_study({"body": body_fmu}, car_fmu, road, speed, duration, float(h), seed,
                       extrapolate=extrapolate)
        b = st.bodies["body"]
        rows.append({"step_s": float(h), "coupling_nrmse": b.coupling_nrmse,
                     "real_time_factor": b.real_time_factor})
    return rows
