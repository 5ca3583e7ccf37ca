"""Co-simulation studies: one road and car, one or more body FMUs, figures and references.

:func:`run_study` drives the quarter car over a road with one or more body FMUs
(:func:`vehicle.cosim.cosimulate`), runs the monolithic reference of each
(:func:`vehicle.reference.reference_run`) and reports, per body, the ISO 2631-1
figures of the head acceleration (:mod:`bodyvib.comfort`), the coupling error
and the seat-to-head transmissibility estimated from the run
(:mod:`bodyvib.estimate`).
"""

import math
import os
import sys
import time
from typing import Dict, List

import numpy as np

from bodyvib.comfort import comfort_figures
from bodyvib.estimate import estimate_transmissibility
from bodyvib.runtime.errors import BodyvibError

from .cosim import cosimulate, model_from_fmu, open_fmu
from .reference import nrmse, reference_run
from .roads import make_road, road_input

__all__ = ["check_settings", "run_study", "coupling_error_sweep"]


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
              quiet: bool = True) -> dict:
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
    dict
        ``settings``, ``road`` (its description), ``time``, ``road_displacement``,
        ``road_velocity`` and ``bodies``: label -> ``{"fmu", "run", "reference",
        "figures", "coupling_nrmse", "transmissibility", "real_time_factor"}``.

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
    out = {
        "settings": {"road": str(road), "speed_m_s": speed, "duration_s": duration,
                     "step_s": step, "seed": seed, "master": "gauss-seidel, seat force "
                     + ("extrapolated linearly" if extrapolate else "held")},
        "road": rd.describe(),
        "time": t, "road_displacement": z, "road_velocity": v,
        "bodies": {},
    }
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
        out["bodies"][label] = {
            "fmu": os.fspath(path),
            "model": body_net.name if body_net is not None else None,
            "run": run,
            "reference": ref,
            "figures": comfort_figures(run["head_acceleration"], fs),
            "seat_figures": comfort_figures(run["seat_acceleration"], fs),
            "coupling_nrmse": err,
            "transmissibility": estimate_transmissibility(run["seat_acceleration"],
                                                          run["head_acceleration"], fs),
            "real_time_factor": duration / wall,
        }
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
        b = st["bodies"]["body"]
        rows.append({"step_s": float(h), "coupling_nrmse": b["coupling_nrmse"],
                     "real_time_factor": b["real_time_factor"]})
    return rows
