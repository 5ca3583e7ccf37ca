"""The sweep engines: how the figures of a block of cases are computed.

* ``batched`` -- the monolithic car-plus-occupant network of
  :func:`bodyvib.vehicle.quarter_car.seated_system` (the co-simulation's reference,
  :mod:`bodyvib.vehicle.reference`), discretized exactly per case
  (:class:`bodyvib.runtime.discretize.Discretization`) and advanced for all cases of a
  block together by one compiled loop (:mod:`bodyvib.vehicle.sweep.kernel`),
  ``[x_{k+1}; y_k] = [Phi; C] x_k + [Gamma; D] (z_k, v_k)``, with the road's
  in-step slope as in :func:`bodyvib.runtime.discretize.input_rates`. The same loop
  weights the head and seat accelerations with the recursion of
  :class:`bodyvib.comfort.stream.WkFilter` and keeps the sums the figures of
  :class:`bodyvib.comfort.stream.ComfortStream` come from; no time history is kept.
* A car with tire contacts and stops (unless the spec's ``linear``) runs on the batched
  engine linearized, its switching functions watched
  (:class:`bodyvib.runtime.regimes.PiecewiseModel`, each scaled so that it switches at
  1: a tire's dynamic force over its static load, reversed; a stop side's force over
  stiffness times gap) and their largest values kept by the same loop. A case whose
  largest value reaches :data:`SWITCH_MARGIN` would switch: it is run again, alone,
  with exact steps and located events (:class:`bodyvib.vehicle.reference.ReferenceStream`:
  the seated car's monolithic reference, the car's events counted). A case that does
  not switch is the nonlinear car's run bit for bit (the regime in force never
  changes), so the batched figures are its figures. The row's ``stepping`` says which
  (``linear``, ``batched``, ``events``) and the event columns (:data:`EVENTS`) say what
  the tires and the stops did.
* ``spectral`` -- for an ISO 8608 random road, the expected weighted mean
  square of a long run, ``a_w^2 = int |H(f)|^2 |Wk(f)|^2 S(f) df``, with
  ``H`` the road-to-head (or seat) acceleration response
  (:func:`bodyvib.frequency.response.frequency_response`), ``Wk``
  (:func:`bodyvib.comfort.figures.wk_response`) and the road's time-domain PSD at the
  speed ``S(f) = Gd(f / V) / V`` (:func:`bodyvib.vehicle.road.synthetic.displacement_psd`)
  over the band the road is synthesized in; a car with left and right wheels on the
  road's two tracks, correlated as an isotropic surface (its cross-spectrum
  ``rho(n) Gd(n)``, :func:`~bodyvib.vehicle.road.synthetic.track_coherence`). It
  gives the weighted r.m.s. only:
  VDV, peak and crest factor depend on the particular record (NaN). It is the
  stationary road's expectation: the fade-in every road starts with (5 m of a run's
  hundreds) is a transient outside it, and a road file, not stationary, is refused.
  It is the linearized car's expectation (no events: ``stepping`` ``linear``); where
  its car has tire contacts and stops, the row says how far that expectation is from
  leaving the linear car's range (:data:`RANGE`: three standard deviations of the
  dynamic tire force over the static load, of the suspension travel over the stop gap).
* ``cosim`` -- real FMU co-simulations (:class:`bodyvib.vehicle.cosim.Master`,
  extrapolating master): the FMUs are built once per task (into a temporary
  folder deleted with the task) and body and car parameters are set for each
  case through the FMUs' parameter variables before initialization. The car FMU is
  the one ``bodyvib cosim`` builds: the car with its tire contacts and stops, which
  locates its events inside each step, its tires loaded by the case's body (the
  occupant start values of :func:`bodyvib.vehicle.study.run_study`); the event
  columns are read from its contact flags, stop forces and tire forces at the
  communication points as ``bodyvib cosim`` reads them
  (:class:`bodyvib.vehicle.events.CarEventStream`; ``stepping`` ``events``). With the
  spec's ``linear`` the car FMU is the linearized car (``stepping`` ``linear``).

Every case sees the road of ``bodyvib cosim`` with the same road, seed, speed,
duration and road options, faded in from level: :func:`bodyvib.vehicle.road.driven.driven_road` and
:func:`bodyvib.vehicle.road.synthetic.road_input` on ``t_k = k * step``, ``k = 0 ...
round(duration / step)``. Each engine returns one figures dict per case; a
case that fails carries its error instead of figures.
"""

import math
import os
import tempfile
from dataclasses import replace
from typing import Dict, List, NamedTuple, Optional, Sequence

import numpy as np

from bodyvib.comfort import governing_method
from bodyvib.comfort.axes import SEATED_AXES, WEIGHTINGS, weighting
from bodyvib.comfort.figures import comfort_category, wk_response
from bodyvib.comfort.stream import (
    BatchComfortFigures,
    ComfortStream,
    WkFilter,
    weighting_statespace,
)
from bodyvib.frequency.response import frequency_response
from bodyvib.models import load_model
from bodyvib.runtime.discretize import Discretization
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.network import linear_model, linearized
from bodyvib.runtime.regimes import PiecewiseModel

from ..events import CarEventStream
from ..quarter_car import seated_system, track_width, wheel_offsets, wheel_sides
from ..road import roads_input, wheel_roads
from ..road.driven import driven_road
from ..road.synthetic import (
    ISO8608_CLASSES,
    N_BAND,
    displacement_psd,
    road_input,
    track_coherence,
)
from ..seat_motion import SEAT_FIGURES, seat_axes, seat_height, seat_point
from . import kernel
from .kernel import SUMS
from .spec import Case

__all__ = [
    "ENGINES",
    "ENGINE_SETTINGS",
    "FIGURES",
    "FORCES",
    "EVENTS",
    "RANGE",
    "SWITCH_MARGIN",
    "run_engine",
    "run_batched",
    "run_spectral",
    "run_cosim",
    "case_road_input",
    "case_wheel_inputs",
    "check_engine",
    "comfort_method",
]

#: Engine names.
ENGINES = ("batched", "spectral", "cosim")
#: What a car's tire contacts and stops did, in every row after the figures (NaN for a
#: linear run): lift-offs and stop contacts (counts, summed over the wheels), time in
#: the air (s, summed over the wheels), the largest stop force (N) and the smallest
#: tire-load ratio (total over static tire force, the lowest wheel), and ``stepping``:
#: ``linear`` (a linear car, ``linear`` in the spec, the spectral engine), ``batched``
#: (nothing switched: the batched engine's run) or ``events`` (run again with exact
#: steps and located events; the cosim engine's car FMU, which locates them inside each
#: step, its columns counted at the communication points).
EVENTS = (
    "lift_offs",
    "time_in_air",
    "stop_contacts",
    "largest_stop_force",
    "smallest_tire_load_ratio",
    "stepping",
)
#: Where a spectral row's linear car stands against its range, three standard deviations
#: of a stationary Gaussian response over the limit (NaN for the other engines, which
#: have a record, and for a car without contacts or stops): ``tire_force_3sigma_ratio``,
#: 3 r.m.s. dynamic tire force over the static tire load (the largest over the wheels),
#: and ``stop_travel_3sigma_ratio``, 3 r.m.s. suspension travel over the stop gap (the
#: largest over the stops). Above 1 the linear expectation is out of its range: the
#: road is Gaussian, the linear response too, and the level ``-3 sigma`` is crossed
#: downwards ``nu_0 exp(-9 / 2) = 0.011 nu_0`` times a second (Rice; ``nu_0`` the
#: response's mean frequency, 11-15 Hz for the quarter car's tire force at 10-30 m/s,
#: 3.4 Hz for its travel: at the ratio 1 about 4 lift-offs, or 1 stop contact, in a 30 s
#: run, and more as it grows), which the linear car does not have.
RANGE = ("tire_force_3sigma_ratio", "stop_travel_3sigma_ratio")
#: Figure columns every engine returns (NaN where it has none); ``head_comfort_method``
#: is added to every engine's rows by :func:`run_engine` (:func:`comfort_method`).
FIGURES = (
    (
        "head_weighted_rms",
        "head_vdv",
        "head_peak",
        "head_crest_factor",
        "head_comfort",
        "head_comfort_method",
        "seat_weighted_rms",
        "head_mtvv",
        "neck_force_peak",
        "lumbar_force_peak",
    )
    + SEAT_FIGURES
    + EVENTS
    + RANGE
)
#: The body's named forces a sweep reports, as outputs of the seated system.
FORCES = ("neck_force", "lumbar_force")
#: A watched switching function at this fraction of its switching sends the case to the
#: event stepper (chosen: the functions are looked at only at the samples; between two
#: samples 1 ms apart a 10 Hz wheel hop's force moves past its sampled peak by about
#: (pi f h)^2 / 2 = 5e-4 of its amplitude, and 2 % covers that forty times over).
SWITCH_MARGIN = 0.98
#: Settings of each engine as stored in the table's ``engine_settings`` column (JSON).
ENGINE_SETTINGS = {
    "batched": '{"method": "exact zero-order-hold-plus-slope step"}',
    "spectral": '{"method": "expected Wk r.m.s. from the ISO 8608 PSD", "points": 500}',
    "cosim": '{"method": "FMU co-simulation, extrapolating master"}',
}
#: Points of the spectral engine's log-spaced frequency grid per road band
#: (0.011-2.83 cycle/m at one speed): relative quadrature error below 1e-7 for
#: the shipped bodies and cars (5e-8 measured against 32,000 points).
SPECTRAL_POINTS = 500


def check_engine(engine: str, cases: Sequence[Case]) -> None:
    """Refuse an engine that cannot run these cases (before any work).

    Parameters
    ----------
    engine : str
    cases : sequence of Case

    Raises
    ------
    BodyvibError
        Unknown engine, or ``spectral`` with a road that is not an ISO 8608 class.

    Examples
    --------
    >>> from bodyvib.vehicle.sweep.spec import expand
    >>> check_engine("spectral", expand({"road": "bump", "speed": 10, "body": "reduced-paper"}))
    Traceback (most recent call last):
    ...
    bodyvib.runtime.errors.BodyvibError: the spectral engine needs stationary ISO 8608 roads (A-H); not bump: use the batched engine
    """
    if engine not in ENGINES:
        raise BodyvibError(f"unknown engine '{engine}'; engines are {', '.join(ENGINES)}")
    if engine == "spectral":
        bad = sorted({c.road for c in cases if c.road not in ISO8608_CLASSES})
        if bad:
            raise BodyvibError(
                f"the spectral engine needs stationary ISO 8608 roads (A-H); "
                f"not {', '.join(bad)}: use the batched engine"
            )


def case_road_input(case: Case):
    """Road displacement and velocity of a case, sampled as ``bodyvib cosim`` samples them.

    Parameters
    ----------
    case : Case

    Returns
    -------
    z, v : (steps,) ndarray
        m, m/s at ``t_k = k * step``.

    Examples
    --------
    >>> from bodyvib.vehicle.sweep.spec import expand
    >>> z, v = case_road_input(expand({"road": "C", "speed": 20, "duration": 2,
    ...                                "body": "reduced-paper"})[0])
    >>> z.shape
    (2001,)
    """
    road = driven_road(case.run_settings())
    t = np.arange(case.steps) * case.step
    return road_input(road, case.speed, t)


def case_wheel_inputs(case: Case, behind=(0.0,), sides=None, track=0.0):
    """Road displacement and velocity under each wheel of a case's car (columns).

    Parameters
    ----------
    case : Case
    behind : sequence of float
        Each wheel's distance behind the first, m
        (:func:`bodyvib.vehicle.quarter_car.wheel_offsets`).
    sides : sequence of int, optional
        Each wheel's track, 1 left, -1 right, 0 centre
        (:func:`bodyvib.vehicle.quarter_car.wheel_sides`); all on one track by default.
    track : float
        Distance between the tracks, m (:func:`bodyvib.vehicle.quarter_car.track_width`).

    Returns
    -------
    z, v : (steps, wheels) ndarray
        m, m/s at ``t_k = k * step`` (:func:`bodyvib.vehicle.road.tracks.roads_input`).
    """
    settings = case.run_settings()
    road = driven_road(settings)
    roads = wheel_roads(settings, road, sides or [0] * len(behind), track)
    return roads_input(roads, case.speed, np.arange(case.steps) * case.step, behind)


def _seat_columns(figures: Optional[Dict[str, float]]) -> Dict[str, float]:
    """A row's seat columns (:data:`SEAT_FIGURES`): the figures a car gives, NaN for the
    rest (a quarter car's seat has no x and y, a half car's does not roll)."""
    return {k: float((figures or {}).get(k, math.nan)) for k in SEAT_FIGURES}


def _failed(exc) -> Dict[str, object]:
    row = {k: float("nan") for k in FIGURES}
    row["head_comfort"] = row["stepping"] = None
    row["error"] = f"{type(exc).__name__}: {exc}" if not isinstance(exc, BodyvibError) else str(exc)
    return row


class _Seated:
    """The monolithic model of a case's body on its car, with its output rows."""

    def __init__(self, case: Case, cars: dict):
        car = cars.get((case.car, case.linear))
        if car is None:
            car = cars[(case.car, case.linear)] = case.car_network()
        base = cars.get(("body", case.body_model))
        if base is None:  # the model file read once per task, not once per parameter set
            base = cars[("body", case.body_model)] = load_model(case.body_model)
        body = base.with_parameters(**dict(case.body_values)) if case.body_values else base
        self.lm = linear_model(seated_system(linearized(car), body))
        self.watch = _watched(seated_system(car, body), self.lm)
        # exact step matrices once per step size, for every case of this body on this car
        self.discretization = Discretization(self.lm)
        self.step_rows = {}  # step size -> the step rows of every case (_case_rows)
        self.seat = car.roles["seat"]
        self.bases = car.bases
        self.behind = wheel_offsets(car)  # each road point's distance behind the first, m
        self.sides = wheel_sides(car)  # and its track: 1 left, -1 right, 0 centre
        self.track = track_width(car)
        self.height = seat_height(car)  # the seat's height and roll (None: no x and y)
        self.floor = seat_point(car)  # the body point of the seat's x and y
        self.outputs = [self.lm.output_index("body.head.a"), self.lm.output_index(f"{self.seat}.a")]
        # the named forces, None where the body names none (a zero row, reported as NaN)
        self.forces = [
            self.lm.output_index(f"body.{f}") if f"body.{f}" in self.lm.outputs else None
            for f in FORCES
        ]

    def rows(self, matrix, watched):
        """The output rows of ``matrix`` (C or D): head, seat, each force (0 if none), then
        the ``watched`` rows (the switching functions' part on the states or the inputs)."""
        out = np.zeros((2 + len(FORCES) + watched.shape[0],) + matrix.shape[1:])
        out[:2] = matrix[self.outputs]
        for r, i in enumerate(self.forces):
            if i is not None:
                out[2 + r] = matrix[i]
        out[2 + len(FORCES) :] = watched
        return out


class _Watched(NamedTuple):
    """A car's switching functions as output rows of the linear seated system, scaled to
    switch at 1 (:func:`_watched`)."""

    x: np.ndarray  # (w, n): on the states
    u: np.ndarray  # (w, inputs): on the inputs
    contact: np.ndarray  # (w,) bool: a tire's (its load ratio is 1 - the row)
    always: bool  # a function that switches at any motion (an asymmetric damper)


def _watched(seated, lm) -> _Watched:
    """The switching functions of a seated car with contacts and stops on ``lm`` (the
    linearized seated system's state space): ``g = G [x; u] + g0`` switches at
    ``G [x; u] = -g0``, the row ``G / -g0`` at 1."""
    n, ni = lm.A.shape[0], len(lm.inputs)
    if not seated.nonlinear_elements:
        return _Watched(np.zeros((0, n)), np.zeros((0, ni)), np.zeros(0, bool), False)
    pw = PiecewiseModel(seated)
    if pw.linear.states != lm.states or pw.linear.inputs != lm.inputs:
        raise BodyvibError("the nonlinear car's states differ from its linearization's")
    scale = np.where(pw.g0 != 0.0, -1.0 / np.where(pw.g0 != 0.0, pw.g0, 1.0), 0.0)
    contact = np.array([side == "contact" for _, side in pw.switches])
    return _Watched(
        pw.Gx * scale[:, None], pw.Gu * scale[:, None], contact, bool(np.any(pw.g0 == 0.0))
    )


def _seated(case, models, cars):
    key = (case.body_model, case.body_values, case.car, case.linear)
    m = models.get(key)
    if m is None:
        if len(models) > 256:
            models.clear()
        m = models[key] = _Seated(case, cars)
    return m


def _road_key(case) -> tuple:
    """What makes a case's road input: the road, its seed, the speed, the run and the options."""
    return (case.road, case.seed, case.speed, case.duration, case.step, case.road_options)


def _roads(case, roads, behind=(0.0,), sides=None, track=0.0):
    key = _road_key(case) + (tuple(behind), tuple(sides or ()), track)
    r = roads.get(key)
    if r is None:
        if len(roads) > 64:
            roads.clear()
        r = roads[key] = (
            case_road_input(case)
            if len(behind) == 1
            else case_wheel_inputs(case, behind, sides, track)
        )
    return r


def _case_rows(s, step, m):
    """A body on its car's step rows at ``step``: ``M`` (m, n), ``gz`` and ``gv`` (points, m).

    Every case of that body and car shares them (whatever its road and speed): kept with
    the seated model, one entry per step size.
    """
    rows = s.step_rows.get(step)
    if rows is not None:
        return rows
    lm = s.lm
    n = lm.A.shape[0]
    with np.errstate(over="ignore", invalid="ignore"):
        Phi, G0, G1 = s.discretization.matrices(step)
    if not (np.all(np.isfinite(Phi)) and np.all(np.isfinite(G0)) and np.all(np.isfinite(G1))):
        raise BodyvibError(
            "the exact step matrices are not finite (parameters out of numerical range?)"
        )
    M = np.empty((m, n))
    M[:n] = Phi
    M[n:] = s.rows(lm.C, s.watch.x)
    D = s.rows(lm.D, s.watch.u)
    gz = np.zeros((len(s.bases), m))
    gv = np.zeros((len(s.bases), m))
    for j, base in enumerate(s.bases):
        iz, iv = lm.input_index(f"{base}_displacement"), lm.input_index(f"{base}_velocity")
        # in-step road z_k + v_k tau: Gamma0 on (z, v), Gamma1 on the displacement's rate v
        gz[j, :n] = G0[:, iz]
        gv[j, :n] = G0[:, iv] + G1[:, iz]
        gz[j, n:] = D[:, iz]
        gv[j, n:] = D[:, iv]
    rows = s.step_rows[step] = (M, gz, gv)
    return rows


def _step_inputs(cases, sys, roads):
    """Each case's step matrices and road rows: ``M``, ``gz``, ``gv``, ``road``, ``z``, ``v``.

    A car driven at several points (a half car) is linear: each point's road enters
    through its own input columns, ``sum_p (g_z z + g_v v)_p``; cases of one road,
    seed and speed share its rows of ``z`` and ``v``.
    """
    c = len(cases)
    n = sys[0].lm.A.shape[0]
    step = cases[0].step
    # states, then head and seat acceleration, the forces and the watched functions
    m = n + 2 + len(FORCES) + sys[0].watch.x.shape[0]
    P = max(len(s.bases) for s in sys)
    M = np.empty((c, m, n))
    gz = np.zeros((c, P, m))
    gv = np.zeros((c, P, m))
    road = np.zeros((c, P), dtype=np.int64)
    rows_of: Dict[tuple, int] = {}
    zs, vs = [], []
    for i, (cs, s) in enumerate(zip(cases, sys)):
        M[i], gz[i, : len(s.bases)], gv[i, : len(s.bases)] = _case_rows(s, step, m)
        for j in range(len(s.bases)):
            rkey = _road_key(cs) + (s.behind[j], s.sides[j], s.track)
            if rkey not in rows_of:
                rows_of[rkey] = len(zs)
                zr, vr = _roads(cs, roads, s.behind, s.sides, s.track)
                zs.append(zr if zr.ndim == 1 else zr[:, j])
                vs.append(vr if vr.ndim == 1 else vr[:, j])
            road[i, j] = rows_of[rkey]
    # (roads, samples) views of (samples, roads) arrays: the loop's layout, one copy
    return M, gz, gv, road, np.stack(zs, axis=1).T, np.stack(vs, axis=1).T


def _with_seat_axes(sys, M, gz, gv):
    """``M``, ``gz`` and ``gv`` with two more output rows, the seat's ``a_x`` and ``a_y``,
    of the cases whose car gives them (a seat with a height; zero rows for the others);
    None: no case's car gives them."""
    have = [i for i, s in enumerate(sys) if s.height is not None]
    if not have:
        return None
    c, P, m = gz.shape
    M2 = np.concatenate([M, np.zeros((c, 2, M.shape[2]))], axis=1)
    gz2 = np.concatenate([gz, np.zeros((c, P, 2))], axis=2)
    gv2 = np.concatenate([gv, np.zeros((c, P, 2))], axis=2)
    for i in have:
        lm, floor = sys[i].lm, sys[i].floor
        rows = [lm.output_index(f"{floor}.ax"), lm.output_index(f"{floor}.ay")]
        M2[i, m:] = lm.C[rows]
        for j, base in enumerate(sys[i].bases):
            iz, iv = lm.input_index(f"{base}_displacement"), lm.input_index(f"{base}_velocity")
            gz2[i, j, m:], gv2[i, j, m:] = lm.D[rows, iz], lm.D[rows, iv]
    return M2, gz2, gv2


def _seat_axes(sys, sums, samples) -> Dict[int, list]:
    """The seat's x and y (Wd) and its roll and pitch (We) of the cases whose car gives
    them (a seat with a height): case index -> ``[x, y, rx, ry]`` weighted r.m.s., from
    the kernel's last rows ``sums`` (x and y with Wd, then with We). The body's pitch
    and roll accelerations are ``-a_x / h``, ``-a_y / h``: We's r.m.s. over the height."""
    x, y, rx, ry = (np.sqrt(s / samples) for s in sums)
    return {
        i: [x[i], y[i], ry[i] / s.height[0], rx[i] / s.height[0]]
        for i, s in enumerate(sys)
        if s.height is not None
    }


def _batched_group(cases, models, cars, roads, record):
    """Figures (and histories) of cases of one state size and length, stepped together."""
    c = len(cases)
    sys = [_seated(cs, models, cars) for cs in cases]
    step = cases[0].step
    M, gz, gv, road, z, v = _step_inputs(cases, sys, roads)
    wk = ComfortStream(1.0 / step, 1)  # the weighting and the MTVV window of the figures
    # the seat's x and y (a car that gives them) weighted in the same pass: Wd, We
    seated_axes = _with_seat_axes(sys, M, gz, gv)
    weightings = None
    if seated_axes is not None:
        M, gz, gv = seated_axes
        weightings = [
            WkFilter(1.0 / step, 1, weighting_statespace(WEIGHTINGS[name])).step()
            for name in ("Wd", "We")
        ]
    packed = kernel.pack(M, gz, gv, road)
    sums, hist = kernel.run(packed, z, v, wk.filter.step(), wk.window, record, weightings)
    if not (np.all(np.isfinite(sums)) and np.all(sums[SUMS.index("check")] == 0)):
        raise BodyvibError("the response is not finite (parameters out of numerical range?)")
    fig = {
        part: BatchComfortFigures.from_sums(
            *(sums[SUMS.index(f"{part}_{k}")] for k in ("s2", "s4", "peak", "window_max")),
            samples=cases[0].steps,
            fs=1.0 / step,
            window=wk.window,
        )
        for part in ("head", "seat")
    }
    head, seat = fig["head"], fig["seat"]
    top = sums[len(SUMS) :]  # the watched rows' maxima (then the seat's x and y)
    axes: Dict[int, list] = {}
    if weightings is not None:
        top, axes = top[:-4], _seat_axes(sys, sums[-4:], cases[0].steps)
    rows = []
    for i in range(c):
        peaks = {
            f"{f}_peak": float(sums[SUMS.index(f"force{r}_peak"), i])
            if sys[i].forces[r] is not None
            else math.nan
            for r, f in enumerate(FORCES)
        }
        rows.append(
            {
                "head_weighted_rms": float(head.weighted_rms[i]),
                "head_vdv": float(head.vdv[i]),
                "head_peak": float(head.peak[i]),
                "head_crest_factor": float(head.crest_factor[i]),
                "head_comfort": head.comfort[i],
                "seat_weighted_rms": float(seat.weighted_rms[i]),
                "head_mtvv": float(head.mtvv[i]),
                **peaks,
                **_seat_columns(
                    _seat_figures(float(seat.weighted_rms[i]), axes[i], sys[i].height)
                    if i in axes
                    else None
                ),
                **_batched_events(sys[i].watch, top[:, i]),
                "error": None,
            }
        )
    return rows, hist


#: A linear run's event columns.
_LINEAR = {**{k: math.nan for k in EVENTS}, "stepping": "linear"}


def _batched_events(watch: _Watched, top: np.ndarray) -> dict:
    """A batched case's event columns from its watched functions' largest values ``top``;
    ``stepping`` None: the case would switch (run it again with events)."""
    if not watch.contact.size:
        return dict(_LINEAR)
    if watch.always or np.any(top >= SWITCH_MARGIN):
        return {**_LINEAR, "stepping": None}
    ratio = 1.0 - float(np.max(top[watch.contact])) if np.any(watch.contact) else math.nan
    return {
        "lift_offs": 0.0,
        "time_in_air": 0.0,
        "stop_contacts": 0.0,
        "largest_stop_force": 0.0,
        "smallest_tire_load_ratio": ratio,
        "stepping": "batched",
    }


def _event_case(cs: Case, record: bool):
    """Figures, event columns (and histories) of one case of a car with contacts and
    stops, with exact steps and located events (the seated car's monolithic reference)."""
    from ..reference import ReferenceStream

    car = cs.car_network()
    z, v = _roads(cs, {}, wheel_offsets(car), wheel_sides(car), track_width(car))
    ref = ReferenceStream(car, cs.body_network(), cs.step)
    run = ref.advance(z, v)
    contacts = [e for e in ref.events().values() if e["kind"] == "contact"]
    stops = [e for e in ref.events().values() if e["kind"] == "stop"]
    events = {
        "lift_offs": float(sum(e["lift_offs"] for e in contacts)),
        "time_in_air": float(sum(e["time_in_air_s"] for e in contacts)),
        "stop_contacts": float(sum(e["contacts"] for e in stops)),
        "largest_stop_force": max([e["largest_force_N"] for e in stops], default=0.0),
        "smallest_tire_load_ratio": min([e["smallest_load_ratio"] for e in contacts]),
        "stepping": "events",
    }
    return _run_row(run, cs.step, events, car), _histories(run, record)


def _run_row(run: dict, step: float, events: dict, car) -> dict:
    """A row of figures from a run's head and seat accelerations and forces, and the
    seat's axes where ``car`` (the run's car) gives them."""
    stream = ComfortStream(1.0 / step, 2)
    stream.update(np.stack([run["head_acceleration"], run["seat_acceleration"]]))
    fig = stream.figures()
    return {
        "head_weighted_rms": float(fig["weighted_rms"][0]),
        "head_vdv": float(fig["vdv"][0]),
        "head_peak": float(fig["peak"][0]),
        "head_crest_factor": float(fig["crest_factor"][0]),
        "head_comfort": fig["comfort"][0],
        "seat_weighted_rms": float(fig["weighted_rms"][1]),
        "head_mtvv": float(fig["mtvv"][0]),
        **{f"{f}_peak": float(np.max(np.abs(run[f]))) for f in FORCES},
        **_seat_columns(_run_seat_axes(run, step, car)),
        **events,
        "error": None,
    }


def _histories(run: dict, record: bool) -> Optional[dict]:
    """The head and seat acceleration of a run (``record``), else None."""
    if not record:
        return None
    return {k: run[k] for k in ("head_acceleration", "seat_acceleration")}


def run_batched(cases: Sequence[Case], record: bool = False):
    """Figures of cases by the batched exact engine.

    Parameters
    ----------
    cases : sequence of Case
    record : bool
        Also return the head and seat acceleration histories.

    Returns
    -------
    rows : list of dict
        One per case, in order: :data:`FIGURES` and ``error`` (None, or the
        reason the case failed).
    histories : list of dict or None
        With ``record``: ``{"head_acceleration", "seat_acceleration"}`` per case
        (None for a failed case).

    Examples
    --------
    >>> from bodyvib.vehicle.sweep.spec import expand
    >>> cases = expand({"road": "C", "speed": [10, 20], "duration": 1, "body": "reduced-paper"})
    >>> rows, _ = run_batched(cases)
    >>> [r["head_weighted_rms"] > 0 for r in rows]
    [True, True]
    """
    models: dict = {}
    cars: dict = {}
    roads: dict = {}
    rows: List[Optional[dict]] = [None] * len(cases)
    hist: List[Optional[dict]] = [None] * len(cases)
    groups: Dict[tuple, List[int]] = {}
    for i, cs in enumerate(cases):
        try:
            s = _seated(cs, models, cars)
        except Exception as exc:  # a case that cannot be built is recorded, not fatal
            rows[i] = _failed(exc)
            continue
        key = (s.lm.A.shape[0], s.watch.x.shape[0], cs.steps, cs.step)
        groups.setdefault(key, []).append(i)

    def run(idx):
        r, h = _batched_group([cases[i] for i in idx], models, cars, roads, record)
        for j, i in enumerate(idx):
            rows[i] = r[j]
            if record:
                hist[i] = {"head_acceleration": h[0, j], "seat_acceleration": h[1, j]}

    for idx in groups.values():
        try:
            run(idx)
        except Exception:
            if len(idx) == 1:
                try:
                    run(idx)
                except Exception as exc:
                    rows[idx[0]] = _failed(exc)
                continue
            for i in idx:  # find the failing case(s): run each alone
                try:
                    run([i])
                except Exception as exc:
                    rows[i] = _failed(exc)
    for i, row in enumerate(rows):  # a case that would switch: again, with events
        if row is not None and row["error"] is None and row["stepping"] is None:
            try:
                rows[i], hist[i] = _event_case(cases[i], record)
            except Exception as exc:
                rows[i], hist[i] = _failed(exc), None
    return rows, (hist if record else None)


def _band_mean_square(g, lnf, lo, hi):
    """``int_lo^hi g df`` from samples of ``g(f) f`` on a uniform grid in ``ln f`` (trapezoid)."""
    a, b = np.log(lo), np.log(hi)
    inside = (lnf > a) & (lnf < b)
    x = np.concatenate([[a], lnf[inside], [b]])
    y = np.concatenate([[np.interp(a, lnf, g)], g[inside], [np.interp(b, lnf, g)]])
    return float(np.trapezoid(y, x))


def _spectral_outputs(s, f):
    """The outputs of the spectral engine and each one's weighting: ``(outputs, [(output
    index, |W|^2 f)])``: head and seat z (Wk), and a seat with a height its x and y (Wd)
    and its pitch and roll ``-a_x / h``, ``-a_y / h`` (We)."""
    wk = np.abs(wk_response(f)) ** 2 * f  # |W|^2 f: the df = f dln f of the integral
    outputs, weights = ["body.head.a", f"{s.seat}.a"], [(0, wk), (1, wk)]
    if s.height is not None:
        outputs += [f"{s.floor}.ax", f"{s.floor}.ay"]
        wd = np.abs(weighting("Wd", f)) ** 2 * f
        we = np.abs(weighting("We", f)) ** 2 * f / s.height[0] ** 2
        weights += [(2, wd), (3, wd), (3, we), (2, we)]  # x, y, roll, pitch
    return outputs, weights


def _seat_figures(z, axes, height) -> Optional[Dict[str, float]]:
    """The seat's figures from its weighted r.m.s., ``z`` (Wk) and ``axes``, ``[x, y]``
    (Wd) and the roll and pitch ``[rx, ry]`` (We), of a car whose seat has a ``height``."""
    if height is None:
        return None
    x, y, rx, ry = axes
    k = {a: SEATED_AXES[a][1] for a in ("seat_rx", "seat_ry")}  # comfort factors, m/rad
    out = {"seat_aw_x": x, "seat_aw_y": y, "seat_aw_z": z, "seat_aw_ry": ry}
    out["seat_av"] = math.sqrt(x * x + y * y + z * z)  # k = 1, 1, 1 (comfort)
    rot = [(k["seat_ry"] * ry) ** 2]
    if height[1]:  # a body that rolls
        out["seat_aw_rx"] = rx
        rot.append((k["seat_rx"] * rx) ** 2)
    out["seat_rotation_av"] = math.sqrt(sum(rot))
    return out


def run_spectral(cases: Sequence[Case], points: int = SPECTRAL_POINTS) -> List[dict]:
    """Expected weighted r.m.s. of cases on ISO 8608 roads from the road PSD.

    Parameters
    ----------
    cases : sequence of Case
        ISO 8608 class roads only.
    points : int
        Frequency points over the road's band at one speed (a factor 257 in
        frequency); cases of one model share one log-spaced grid over all
        their speeds' bands at that density.

    Returns
    -------
    list of dict
        As :func:`run_batched`; VDV, peak and crest factor are NaN (a spectral
        estimate has no record to take them from).

    Examples
    --------
    >>> from bodyvib.vehicle.sweep.spec import expand
    >>> rows = run_spectral(expand({"road": ["A", "C"], "speed": 20, "body": "reduced-paper"}))
    >>> round(rows[1]["head_weighted_rms"] / rows[0]["head_weighted_rms"], 9)
    4.0
    """
    models: dict = {}
    cars: dict = {}
    groups: Dict[tuple, List[int]] = {}
    rows: List[Optional[dict]] = [None] * len(cases)
    for i, cs in enumerate(cases):
        groups.setdefault((cs.body_model, cs.body_values, cs.car), []).append(i)
    density = (points - 1) / math.log(N_BAND[1] / N_BAND[0])  # points per unit of ln f
    for idx in groups.values():
        try:
            # the car with its contacts and stops: its linearization, and its range
            s = _seated(replace(cases[idx[0]], linear=False), models, cars)
            speeds = sorted({cases[i].speed for i in idx})
            lo, hi = N_BAND[0] * speeds[0], N_BAND[1] * speeds[-1]
            lnf = np.linspace(
                math.log(lo), math.log(hi), int(math.ceil(density * math.log(hi / lo))) + 1
            )
            f = np.exp(lnf)
            outputs, weights = _spectral_outputs(s, f)
            lm, watched = _watched_outputs(s)
            weights += [(len(outputs) + r, f) for r in range(len(watched))]  # unweighted
            outputs += watched
            per_speed = {}
            for v in speeds:
                power = _output_power(s, lm, f, outputs, v)
                per_speed[v] = [
                    _band_mean_square(power[i] * w, lnf, N_BAND[0] * v, N_BAND[1] * v)
                    for i, w in weights
                ]
            if not np.all(np.isfinite(list(per_speed.values()))):
                raise BodyvibError(
                    "the response is not finite (parameters out of numerical range?)"
                )
        except Exception as exc:
            for i in idx:
                rows[i] = _failed(exc)
            continue
        for i in idx:
            cs = cases[i]
            if cs.road not in ISO8608_CLASSES:
                rows[i] = _failed(BodyvibError(f"road '{cs.road}' is not an ISO 8608 class"))
                continue
            scale = 4.0 ** ISO8608_CLASSES.index(cs.road)  # Gd(n0) of the class over class A's
            ms = per_speed[cs.speed]
            split = len(ms) - len(watched)
            head, seat, *axes = (math.sqrt(m * scale) for m in ms[:split])
            rows[i] = {
                "head_weighted_rms": head,
                "head_vdv": float("nan"),
                "head_peak": float("nan"),
                "head_crest_factor": float("nan"),
                "head_comfort": comfort_category(head),
                "seat_weighted_rms": seat,
                "head_mtvv": float("nan"),
                "neck_force_peak": float("nan"),  # a peak needs a record
                "lumbar_force_peak": float("nan"),
                **_seat_columns(_seat_figures(seat, axes, s.height)),
                **_LINEAR,
                **_range_ratios(s.watch, ms[split:], scale),
                "error": None,
            }
    return rows


def _output_power(s, lm, f, outputs, v):
    """Each output's PSD over class A's road at speed ``v`` (per Hz, at ``f``).

    Every wheel follows the first a distance behind it, delayed by distance over speed.
    A car with left and right wheels drives two tracks correlated as an isotropic
    surface (the road of :func:`~bodyvib.vehicle.road.synthetic.two_track_road`): with
    ``H_L`` and ``H_R`` the responses to the left and the right wheels and ``rho`` the
    tracks' normalised cross-spectrum (:func:`~bodyvib.vehicle.road.synthetic.track_coherence`),
    ``S_y = (|H_L|^2 + |H_R|^2 + 2 rho Re(H_L conj(H_R))) S``.
    """
    S = displacement_psd(f / v, "A") / v  # the road's PSD in time: S(f) = Gd(f / v) / v
    delays = [d / v for d in s.behind]
    if not any(s.sides):
        return np.abs(frequency_response(lm, f, outputs, delays=delays)) ** 2 * S
    left, right = (
        frequency_response(lm, f, outputs, delays=delays, gains=[float(x == side) for x in s.sides])
        for side in (1, -1)
    )
    rho = track_coherence(f / v, s.track)
    cross = 2 * rho * np.real(left * np.conj(right))
    return (np.abs(left) ** 2 + np.abs(right) ** 2 + cross) * S


def _watched_outputs(s):
    """The seated system's linear model with its car's switching functions as more
    outputs (:func:`_watched`, each 1 where it switches), and their names."""
    names = [f"switching_{i}" for i in range(s.watch.x.shape[0])]
    lm = replace(
        s.lm,
        C=np.vstack([s.lm.C, s.watch.x]),
        D=np.vstack([s.lm.D, s.watch.u]),
        outputs=tuple(s.lm.outputs) + tuple(names),
    )
    return lm, names


def _range_ratios(watch: _Watched, mean_squares, scale: float) -> Dict[str, float]:
    """The :data:`RANGE` columns from the switching functions' mean squares (class A's,
    times ``scale``): three standard deviations of each function (the dynamic tire force
    over the static load, the travel over a stop's gap), the largest of each kind."""
    sigma3 = 3.0 * np.sqrt(np.asarray(mean_squares, dtype=float) * scale)
    out = {}
    for name, rows in zip(RANGE, (watch.contact, ~watch.contact)):
        out[name] = float(np.max(sigma3[rows])) if np.any(rows) else math.nan
    return out


# -- cosim -------------------------------------------------------------------


def _fmu(kind: str, source: str, folder: str, built: Dict[tuple, str], linear=False) -> str:
    """Path of an FMU for a body or car source, built once into ``folder``: a car with its
    tire contacts and stops (the FMU ``bodyvib cosim`` builds), or linearized (``linear``)."""
    from ..fmus import build_project_fmu, car_fmu_name, linear_car_file

    key = (kind, os.path.abspath(source) if os.path.isfile(source) else source, linear)
    path = built.get(key)
    if path is None:
        sub = os.path.join(folder, str(len(built)))
        if kind == "car":
            name = car_fmu_name(source)
            if linear:  # the car as a file of its linear model, as the command's
                os.makedirs(sub, exist_ok=True)
                source = linear_car_file(source, sub)
        elif source == "iso7962":
            name = "HumanBodyISO7962"
        else:
            name = "HumanBody3DOF"
        path = built[key] = str(build_project_fmu(name, sub, source))
    return path


def _parameters(net) -> Dict[str, float]:
    return {k: float(v) for k, v in net.parameters.items()}


def run_cosim(cases: Sequence[Case], record: bool = False):
    """Figures of cases by FMU co-simulation (fmpy, extrapolating master).

    The car FMU is the car with its tire contacts and stops, which locates its events
    inside each step (``stepping`` ``events``, the event columns counted as ``bodyvib
    cosim`` counts them), or the car linearized where the spec says ``linear``
    (``stepping`` ``linear``).

    Parameters
    ----------
    cases, record
        As :func:`run_batched`.

    Returns
    -------
    rows, histories
        As :func:`run_batched`.
    """
    rows, hist = [], []
    built: Dict[tuple, str] = {}
    with tempfile.TemporaryDirectory(prefix="bodyvib-sweep-fmus-") as folder:
        for cs in cases:
            row, h = _cosim_case(cs, folder, built, record)
            rows.append(row)
            hist.append(h)
    return rows, (hist if record else None)


def _cosim_case(cs, folder, built, record):
    """Figures (and histories) of one case by co-simulation; a failure is recorded.

    The car FMU starts with the case's car parameters and, for a car with contacts, the
    body's weight on its seat (the start values and the tires' static loads of ``bodyvib
    cosim``: :func:`bodyvib.vehicle.study.run_study`)."""
    from ..cosim import Master, open_fmu
    from ..study import _static_load

    try:
        body = cs.body_network()
        car = cs.car_network()  # with its contacts and stops, or linearized (the FMU's)
        events = not cs.linear and bool(car.nonlinear_elements)
        body_fmu = _fmu("body", cs.body_model, folder, built)
        car_fmu = _fmu("car", cs.car, folder, built, cs.linear)
        loads, occupant = _static_load(car, {"b": body_fmu}, {"b": body}) if events else ({}, {})
        start = {**_parameters(car), **occupant.get("b", {})}
        z, v = _roads(cs, {}, wheel_offsets(car), wheel_sides(car), track_width(car))
        with (
            open_fmu(car_fmu, "car", "car", start_values=start) as c,
            open_fmu(body_fmu, "body", "body", start_values=_parameters(body)) as b,
        ):
            master = Master(c, b, cs.step, z.shape[0], extrapolate=True)
            run = dict(zip(master.columns, master.advance(z, v).T))
        columns = _cosim_events(run, master.wheels, loads["b"], cs.step) if events else _LINEAR
        return _run_row(run, cs.step, columns, car), _histories(run, record)
    except Exception as exc:
        return _failed(exc), None


def _cosim_events(run: dict, wheels, loads: dict, step: float) -> dict:
    """The event columns of a co-simulated run: the car FMU's contact flags, stop forces
    and tire forces at the communication points read by
    :class:`bodyvib.vehicle.events.CarEventStream` as ``bodyvib cosim`` reads them;
    ``loads`` are the tires' static loads by tire-force output."""
    stream = CarEventStream(step, loads, wheels)
    stream.update(run)
    e = stream.result()
    ratio = e.smallest_tire_load_ratio
    return {
        "lift_offs": float(e.lift_offs),
        "time_in_air": e.time_in_air_s,
        "stop_contacts": float(e.stop_contacts),
        "largest_stop_force": e.largest_stop_force_n,
        "smallest_tire_load_ratio": math.nan if ratio is None else ratio,
        "stepping": "events",
    }


def _run_seat_axes(run, step: float, car) -> Optional[Dict[str, float]]:
    """The seat's axes of a co-simulated run (None: a car without the seat's x and y)."""
    x = run.get("seat_acceleration_x")
    if x is None or not np.all(np.isfinite(x)):
        return None
    y, z = run["seat_acceleration_y"], run["seat_acceleration"]
    return seat_axes(x, y, z, 1.0 / step, seat_height(car))


_pools = None


def _thread_pools():
    """The process's thread pools (BLAS, OpenMP), found once.

    Finding them walks the loaded libraries, a millisecond or more: a sweep task
    runs many blocks, so the controller is kept. It sees the libraries loaded
    when it is made, so the BLAS the engines use (numpy's and scipy's) are
    loaded first.
    """
    global _pools
    if _pools is None:
        import scipy.linalg  # noqa: F401 (loads scipy's BLAS)
        from threadpoolctl import ThreadpoolController

        _pools = ThreadpoolController()
    return _pools


def run_engine(engine: str, cases: Sequence[Case], blas_threads: Optional[int] = 1) -> List[dict]:
    """Figures of a block of cases by one engine (the unit of work of a sweep task).

    Parameters
    ----------
    engine : str
        ``"batched"``, ``"spectral"`` or ``"cosim"``.
    cases : sequence of Case
    blas_threads : int or None
        BLAS threads while the block runs (1 by default: the matrices are
        small, and threaded BLAS on them costs more than it gives; None leaves
        the setting alone).

    Returns
    -------
    list of dict
        One per case (see :func:`run_batched`).

    Raises
    ------
    BodyvibError
        Unknown engine.
    """
    if engine not in ENGINES:
        raise BodyvibError(f"unknown engine '{engine}'; engines are {', '.join(ENGINES)}")
    from contextlib import nullcontext

    ctx = _thread_pools().limit(limits=blas_threads) if blas_threads else nullcontext()
    with ctx:
        if engine == "batched":
            rows = run_batched(cases)[0]
        elif engine == "spectral":
            rows = run_spectral(cases)
        else:
            rows = run_cosim(cases)[0]
    for row, case in zip(rows, cases):
        row["head_comfort_method"] = comfort_method(row, case.duration)
        for k in RANGE:  # a record's engines: the run says what happened (EVENTS)
            row.setdefault(k, math.nan)
    return rows


def comfort_method(row: dict, duration: float) -> Optional[str]:
    """The ``head_comfort_method`` of a sweep row: which ISO 2631-1 method governs.

    :func:`bodyvib.comfort.governing_method` of the row's head figures: ``"basic"``,
    ``"vdv"`` or ``"mtvv"``; a ``spectral`` row (no record: crest factor, VDV and MTVV
    NaN, a stationary Gaussian response) is ``"basic"``.

    Parameters
    ----------
    row : dict
        An engine's row (``head_weighted_rms``, ``head_crest_factor``, ``head_mtvv``,
        ``head_vdv``).
    duration : float
        The case's duration, s.

    Returns
    -------
    str or None
        None for a failed case (no figures).

    Examples
    --------
    >>> comfort_method({"head_weighted_rms": 0.1, "head_crest_factor": 12.0,
    ...                 "head_mtvv": 0.12, "head_vdv": 0.3}, 6.0)
    'vdv'
    """
    rms = row.get("head_weighted_rms")
    if rms is None or not math.isfinite(rms):
        return None
    return governing_method(
        rms, row["head_crest_factor"], row["head_mtvv"], row["head_vdv"], duration
    )
