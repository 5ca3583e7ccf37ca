"""Design search: car (and seat) parameters that minimize occupant and vehicle objectives.

Every candidate is evaluated exactly and without simulation by
:func:`bodyvib.vehicle.design.stationary.unit_rms` (one Lyapunov solve per
candidate, 0.5 ms for the quarter car with the reduced body): the r.m.s. per unit road
intensity, scaled to each operating point by ``sqrt(W)``. The search works on the unit
box of the tuned parameters (each bound mapped linearly or logarithmically):

* one objective: the fit's genetic algorithm or CMA-ES
  (:func:`bodyvib.fit.methods.search`), constraints as a penalty
  ``J (1 + 1000 v)`` with ``v`` the summed relative excess over the limits;
* two or more: NSGA-II (``pymoo``), constraints as pymoo's inequality constraints.

Chosen designs are verified in the time domain by :func:`verify_design`: the seated
model discretized exactly (:class:`bodyvib.runtime.discretize.Discretization`, the
sweep's ``batched`` engine's step) on the road ``bodyvib cosim`` drives (faded in),
the Wk weighting by :class:`bodyvib.comfort.ComfortStream`.
"""

import math
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

import numpy as np

from bodyvib.comfort import ComfortStream
from bodyvib.models import load_model
from bodyvib.process import extras, interrupts
from bodyvib.runtime.discretize import Discretization, input_rates
from bodyvib.runtime.errors import BodyvibError

from ..quarter_car import load_car, track_width, wheel_offsets, wheel_sides
from ..reference import seat_force_weights
from ..road import roads_input, wheel_roads
from ..road.driven import RunSettings, driven_road
from ..road.synthetic import road_input
from .spec import DesignSpec, Objective, seated_model
from .stationary import (
    road_inputs,
    road_velocity_intensity,
    static_output,
    static_wheel_load,
    unit_mean_product,
    unit_rms,
    wheel_spectral_rms,
)

__all__ = [
    "DesignProblem",
    "DesignPoint",
    "DesignResult",
    "design",
    "chosen_points",
    "verify_design",
]

#: Penalty factor of the single-objective search per unit relative constraint excess.
PENALTY = 1000.0

#: How a figure scales with ``sqrt(W)`` of an operating point, by kind (1 if not listed).
_POWER_OF_SCALE = {"seat": 0.0, "power": 2.0}


@dataclass(frozen=True)
class _Basis:
    """What a figure of one design is computed from besides its own r.m.s."""

    model: object  # the seated LinearModel
    rattle_space: Optional[float]
    floor: float  # Wk r.m.s. of the floor under the seat (sprung.a): SEAT's denominator
    power: Optional[float]  # the absorbed power, W
    load: float = 0.0  # the static load of the wheel of a load ratio, N


#: Figure kind -> (computed from the Wk-weighted r.m.s. rather than the plain one, the
#: figure from that r.m.s.); a kind not listed is the plain r.m.s. itself.
_EVALUATORS = {
    "wk_rms": (True, lambda x, b: x),
    "seat": (True, lambda x, b: 100.0 * x / b.floor),
    "load_ratio": (False, lambda x, b: x / b.load),
    "rattle_ratio": (False, lambda x, b: 3.0 * x / b.rattle_space),
    "power": (False, lambda x, b: b.power),
}
_PLAIN = (False, lambda x, b: x)


def _figure(kind: str, x: float, basis: _Basis) -> float:
    """A figure of kind ``kind`` from its r.m.s. ``x`` (weighted or not, as the kind says)."""
    return _EVALUATORS.get(kind, _PLAIN)[1](x, basis)


class DesignProblem:
    """A specification's objectives and constraints as functions of the tuned parameters.

    Parameters
    ----------
    spec : DesignSpec
        As :func:`bodyvib.vehicle.design.spec.parse_spec` returns it.

    Attributes
    ----------
    names : tuple of str
        The tuned parameters.
    evaluations : int
        Candidates evaluated so far.

    Examples
    --------
    >>> from bodyvib.vehicle.design.spec import parse_spec
    >>> p = DesignProblem(parse_spec({"car": "quarter-car", "body": None,
    ...     "parameters": {"cs": {"min": 200, "max": 5000}},
    ...     "operating_points": [{"road": "C", "speed": 20}],
    ...     "objectives": ["travel_rms"]}))
    >>> F, G = p.evaluate(np.array([[1000.0]]))
    >>> round(float(F[0, 0]), 5)  # sqrt(W (ms + mu) / (2 c)), m
    0.01328
    """

    def __init__(self, spec: DesignSpec):
        self.spec = spec
        self.names = tuple(b.name for b in spec.parameters)
        pts = spec.operating_points
        self._scale = np.array([math.sqrt(road_velocity_intensity(p.road, p.speed)) for p in pts])
        w = np.array([p.weight for p in pts])
        self._weights = w / w.sum()
        self._figures: List[Objective] = list(spec.objectives) + [c for c, _ in spec.constraints]
        self._limits = np.array([lim for _, lim in spec.constraints])
        self._car = load_car(spec.car)  # the files read once, not once per candidate
        self._wheels = _wheels(self._car)
        self._body = None if spec.body is None else load_model(spec.body)
        self.evaluations = 0

    def values(self, u) -> np.ndarray:
        """Parameter values (rows) of unit-box coordinates ``u`` (rows in [0, 1])."""
        u = np.clip(np.atleast_2d(np.asarray(u, dtype=float)), 0.0, 1.0)
        return np.column_stack([b.value(u[:, j]) for j, b in enumerate(self.spec.parameters)])

    def unit(self, values) -> np.ndarray:
        """Unit-box coordinates of parameter values (rows)."""
        x = np.atleast_2d(np.asarray(values, dtype=float))
        cols = []
        for j, b in enumerate(self.spec.parameters):
            if b.log:
                cols.append(np.log(x[:, j] / b.lo) / math.log(b.hi / b.lo))
            else:
                cols.append((x[:, j] - b.lo) / (b.hi - b.lo))
        return np.column_stack(cols)

    def _unit_figures(self, lm, rms=unit_rms) -> np.ndarray:
        """Each figure per unit road intensity (before the operating points' scaling);
        with another ``rms(lm, rows, weighted_rows)``, each figure as it gives them."""
        rows, wrows, plan = [], [], []

        def slot(lst, i):  # an output computed once however many figures use it
            if i not in lst:
                lst.append(i)
            return lst.index(i)

        for f in self._figures:
            i = lm.output_index(f.output)
            if _EVALUATORS.get(f.kind, _PLAIN)[0]:
                floor = slot(wrows, lm.output_index("sprung.a")) if f.kind == "seat" else None
                plan.append(("w", slot(wrows, i), floor))
            else:
                plan.append(("r", slot(rows, i), None))
        r, w = rms(lm, rows, wrows)
        power = self._unit_power(lm) if any(f.kind == "power" for f in self._figures) else None
        out = np.empty(len(self._figures))
        for i, (f, (where, j, floor)) in enumerate(zip(self._figures, plan)):
            basis = _Basis(
                lm,
                self.spec.rattle_space,
                w[floor] if floor is not None else 0.0,
                power,
                _wheel_load(lm, f),
            )
            out[i] = _figure(f.kind, r[j] if where == "r" else w[j], basis)
        return out

    def _unit_power(self, lm) -> float:
        """Absorbed power for ``W = 1``: the mean of seat force times seat velocity."""
        seat = self._car.roles["seat"]
        force = seat_force_weights(lm, self._body, seat)
        velocity = np.zeros(len(lm.outputs))
        velocity[lm.output_index(f"{seat}.v")] = 1.0
        return unit_mean_product(lm, force, velocity)

    def figures_at_points(self, values) -> np.ndarray:
        """Every figure of one design at every operating point, ``(figures, points)``.

        SEAT is a ratio and does not scale with the road, the absorbed power scales
        with ``W`` of the operating point, every other figure with ``sqrt(W)``.
        """
        lm = seated_model(self._car, self._body, dict(zip(self.names, values)))
        if self._wheels is not None:  # delays and two tracks: each point on its own
            self.evaluations += 1
            return np.column_stack(
                [
                    self._unit_figures(
                        lm, lambda m, r, w, p=p: wheel_spectral_rms(m, r, w, p, self._wheels)
                    )
                    for p in self.spec.operating_points
                ]
            )
        u = self._unit_figures(lm)
        self.evaluations += 1
        scale = np.array([_POWER_OF_SCALE.get(f.kind, 1.0) for f in self._figures])
        s = self._scale[None, :] ** scale[:, None]
        return u[:, None] * s

    def evaluate(self, values) -> Tuple[np.ndarray, np.ndarray]:
        """Objectives and constraint excesses of designs (rows of parameter values).

        Returns
        -------
        F : (n, objectives) ndarray
            Weighted mean over the operating points (``inf`` for a model that is
            not stable).
        G : (n, constraints) ndarray
            ``max over points / limit - 1``: feasible where every entry is <= 0.
        """
        X = np.atleast_2d(np.asarray(values, dtype=float))
        nobj = len(self.spec.objectives)
        F = np.empty((len(X), nobj))
        G = np.empty((len(X), len(self._limits)))
        for i, x in enumerate(X):
            interrupts.check()  # Ctrl-C: every candidate is a safe point
            with np.errstate(all="ignore"):
                fig = self.figures_at_points(x)
            F[i] = fig[:nobj] @ self._weights
            G[i] = fig[nobj:].max(axis=1) / self._limits - 1.0 if len(self._limits) else []
        return np.nan_to_num(F, nan=np.inf), np.nan_to_num(G, nan=np.inf)


@dataclass(frozen=True)
class DesignPoint:
    """A chosen design with its predicted and verified figures.

    Attributes
    ----------
    label : str
        ``"best"``, ``"compromise"`` or ``"min-<objective>"``.
    values : dict of str to float
        Tuned parameter values (SI).
    predicted : dict of str to float
        Objectives and constraints by the random-response evaluator (operating
        points aggregated as in the search).
    verified : dict of str to float
        The same figures from time-domain runs (:func:`verify_design`).
    """

    label: str
    values: Dict[str, float]
    predicted: Dict[str, float]
    verified: Dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class DesignResult:
    """The outcome of :func:`design`.

    Attributes
    ----------
    spec : DesignSpec
    values : (n, parameters) ndarray
        The front's designs (one row for a single objective), sorted by the first
        objective.
    objectives : (n, objectives) ndarray
    constraints : (n, constraints) ndarray
        Relative excess over each limit (<= 0: met).
    chosen : tuple of DesignPoint
    evaluations : int
    elapsed_s : float
        Search time (without verification).
    verify_s : float
        Time of the verification runs.
    baseline : DesignPoint or None
        The car as its file gives it (label ``"baseline"``), evaluated the same way:
        what the chosen designs improve on.
    """

    spec: DesignSpec
    values: np.ndarray
    objectives: np.ndarray
    constraints: np.ndarray
    chosen: Tuple[DesignPoint, ...]
    evaluations: int
    elapsed_s: float
    verify_s: float = 0.0
    baseline: Optional[DesignPoint] = None

    @property
    def parameter_names(self) -> Tuple[str, ...]:
        """Names of the tuned parameters (the columns of ``values``)."""
        return tuple(b.name for b in self.spec.parameters)

    def to_dict(self) -> dict:
        """JSON summary: spec essentials, chosen points, timings."""
        s = self.spec
        return {
            "car": s.car,
            "body": s.body,
            "method": s.search.method,
            "objectives": [o.name for o in s.objectives],
            "constraints": {c.name: lim for c, lim in s.constraints},
            "operating_points": [
                {"road": p.road, "speed": p.speed, "weight": p.weight} for p in s.operating_points
            ],
            "front_size": int(len(self.values)),
            "evaluations": self.evaluations,
            "elapsed_s": self.elapsed_s,
            "verify_s": self.verify_s,
            "chosen": [
                {
                    "label": c.label,
                    "values": c.values,
                    "predicted": c.predicted,
                    "verified": c.verified,
                }
                for c in self.chosen
            ],
        }


def _nsga2(problem: DesignProblem, spec: DesignSpec):
    from bodyvib.fit.config import ParetoSettings
    from bodyvib.fit.methods import nsga2_front

    ncon = len(spec.constraints)

    def evaluate(u):
        F, G = problem.evaluate(problem.values(u))
        return (np.minimum(F, 1e300), np.minimum(G, 1e300)) if ncon else np.minimum(F, 1e300)

    X, _ = nsga2_front(
        evaluate,
        (len(problem.names), 0.0, 1.0),
        len(spec.objectives),
        # distribution indices (chosen): SBX 10 spreads children wider than pymoo's
        # default 15; mutation 20 is pymoo's default
        ParetoSettings(spec.search.population, spec.search.generations, 10.0, 20.0),
        seed=spec.search.seed,
        constraints=ncon,
    )
    if X is None:
        raise BodyvibError(
            "no design meets the constraints within the bounds; widen the bounds or relax "
            "the limits"
        )
    return problem.values(np.atleast_2d(X))


def _single(problem: DesignProblem, spec: DesignSpec):
    from bodyvib.fit.config import CmaesSettings, GaSettings
    from bodyvib.fit.methods import search

    def penalized(u):
        F, G = problem.evaluate(problem.values(u))
        J = F[:, 0]
        if G.shape[1]:
            J = J * (1.0 + PENALTY * np.maximum(G, 0.0).sum(axis=1))
        return J

    s = spec.search
    if s.method == "ga":
        settings = GaSettings(
            population=s.population,
            generations=s.generations,
            tournament_size=3,
            elitism=2,
            crossover_eta=2.0,
            mutation_probability=0.6,
            mutation_scale=1.0,
            ftol=1e-10,
            stall_generations=15,
            coordinates="genes",
        )
    else:
        settings = CmaesSettings(
            sigma0=0.3,
            population=s.population,
            max_evaluations=s.population * s.generations,
            ftol=1e-12,
            stall_generations=30,
            coordinates="genes",
        )
    d = len(problem.names)
    r = search(s.method, penalized, np.zeros(d), np.ones(d), settings, s.seed)
    return problem.values(_polish(penalized, r.genes))


def _polish(f, u0):
    """Refine a single-objective optimum by bounded Nelder-Mead (the GA ends near it)."""
    from scipy.optimize import minimize

    res = minimize(
        lambda u: float(f(np.atleast_2d(u))[0]),
        u0,
        method="Nelder-Mead",
        bounds=[(0.0, 1.0)] * len(u0),
        options={"xatol": 1e-10, "fatol": 1e-14, "maxiter": 2000},
    )
    return res.x if res.fun <= float(f(np.atleast_2d(u0))[0]) else u0


def chosen_points(objectives: np.ndarray, names) -> Dict[str, int]:
    """Indices of the chosen designs of a front.

    Parameters
    ----------
    objectives : (n, k) ndarray
    names : sequence of str
        The objectives' names.

    Returns
    -------
    dict of str to int
        One objective: ``{"best": 0}``. More: ``min-<name>`` for each objective and
        ``compromise``, the design nearest the ideal point with every objective
        scaled to [0, 1] over the front.

    Examples
    --------
    >>> chosen_points(np.array([[0.0, 1.0], [0.3, 0.3], [1.0, 0.0]]), ["a", "b"])
    {'min-a': 0, 'min-b': 2, 'compromise': 1}
    """
    F = np.asarray(objectives, dtype=float)
    if F.shape[1] == 1:
        return {"best": int(np.argmin(F[:, 0]))}
    out = {f"min-{n}": int(np.argmin(F[:, j])) for j, n in enumerate(names)}
    span = np.where(np.ptp(F, axis=0) > 0, np.ptp(F, axis=0), 1.0)
    out["compromise"] = int(np.argmin(np.linalg.norm((F - F.min(axis=0)) / span, axis=1)))
    return out


def _wheels(car):
    """A car's road points, ``(behind, sides, track)``, or None for a car on one point."""
    if len(car.bases) == 1:
        return None
    return wheel_offsets(car), wheel_sides(car), track_width(car)


def _wheel_load(lm, figure: Objective) -> float:
    """The static load (N) a load-ratio figure divides by: the quarter car's whole weight,
    or a car's tire of that figure under gravity (0 for other figures)."""
    if figure.kind != "load_ratio":
        return 0.0
    if len(lm.network.bases) == 1:
        return static_wheel_load(lm)
    return abs(static_output(lm, figure.output))


#: Samples of a verification run formed into outputs, or weighted, between two safe points
#: (:func:`bodyvib.process.interrupts.check`): a few milliseconds of work each.
_BLOCK = 1 << 16


def _simulate(lm, z, v, step, C=None, D=None):
    """Outputs ``y = C x + D u`` of a model on road samples (rows of ``C``, ``D``: an
    output's rows of ``lm.C``, ``lm.D``, or a combination of them; every output by
    default), by the exact step of
    the batched engine (``z``, ``v``: one column per road point of the model); formed
    block by block, a safe point between blocks."""
    u = np.zeros((len(z), len(lm.inputs)))
    zc, vc = np.reshape(z, (len(z), -1)), np.reshape(v, (len(v), -1))
    for j, (iz, iv) in enumerate(road_inputs(lm)):
        u[:, iz], u[:, iv] = zc[:, j], vc[:, j]
    X = Discretization(lm).run(
        u, input_rates(lm, u), step, safe_point=interrupts.check
    )  # in-step road z_k + v_k tau
    C, D = (lm.C, lm.D) if C is None else (C, D)
    Y = np.empty((len(X), C.shape[0]))
    for a in range(0, len(X), _BLOCK):
        interrupts.check()
        Y[a : a + _BLOCK] = X[a : a + _BLOCK] @ C.T + u[a : a + _BLOCK] @ D.T
    return Y


def verify_design(spec: DesignSpec, values: Dict[str, float]) -> Dict[str, float]:
    """The objectives and constraints of one design from time-domain runs.

    Each operating point is driven for ``spec.verify.duration`` s on the road
    ``bodyvib cosim`` and the sweeps drive (seed ``spec.verify.seed``, faded in from
    level); the seated model is stepped exactly. The figures of the runs are
    aggregated over the operating points as the search aggregates them.

    Parameters
    ----------
    spec : DesignSpec
    values : dict of str to float
        Tuned parameter values.

    Returns
    -------
    dict of str to float
        Objective and constraint names to their time-domain figures.
    """
    car = load_car(spec.car)
    body = None if spec.body is None else load_model(spec.body)
    lm = seated_model(car, body, values)
    figs = list(spec.objectives) + [c for c, _ in spec.constraints]
    seat = car.roles["seat"]
    outs = sorted(
        {f.output for f in figs} | ({"sprung.a"} if any(f.kind == "seat" for f in figs) else set())
    )
    rows = [lm.output_index(o) for o in outs]
    C, D = lm.C[rows], lm.D[rows]
    power = any(f.kind == "power" for f in figs)
    if power:  # two more rows: the seat force and the seat velocity
        force, sv = seat_force_weights(lm, body, seat), lm.output_index(f"{seat}.v")
        C = np.vstack([C, force @ lm.C, lm.C[sv]])
        D = np.vstack([D, force @ lm.D, lm.D[sv]])
    w = np.array([p.weight for p in spec.operating_points])
    w = w / w.sum()
    per_point = []
    for p in spec.operating_points:
        interrupts.check()
        st = spec.verify.step
        road = driven_road(
            RunSettings(p.road, p.speed, spec.verify.duration, st, seed=spec.verify.seed)
        )
        t = np.arange(int(round(spec.verify.duration / st)) + 1) * st
        wheels = _wheels(car)
        if wheels is None:
            z, v = road_input(road, p.speed, t)
        else:  # each wheel on its track, the rear ones later (as cosim drives them)
            settings = RunSettings(p.road, p.speed, spec.verify.duration, st, seed=spec.verify.seed)
            roads = wheel_roads(settings, road, wheels[1], wheels[2])
            z, v = roads_input(roads, p.speed, t, wheels[0])
        Y_all = _simulate(lm, z, v, st, C, D)
        Y = Y_all[:, : len(outs)]
        # seat force times seat velocity
        absorbed = float(np.mean(Y_all[:, -2] * Y_all[:, -1])) if power else None
        stream = ComfortStream(1.0 / st, len(outs))
        for a in range(0, len(Y), _BLOCK):
            interrupts.check()
            stream.update(np.ascontiguousarray(Y[a : a + _BLOCK].T))
        wk = dict(zip(outs, stream.figures()["weighted_rms"]))
        rms = dict(zip(outs, np.sqrt(np.mean(Y**2, axis=0))))
        per_point.append(
            {
                f.name: float(
                    _figure(
                        f.kind,
                        (wk if _EVALUATORS.get(f.kind, _PLAIN)[0] else rms)[f.output],
                        _Basis(
                            lm,
                            spec.rattle_space,
                            wk.get("sprung.a", 0.0),
                            absorbed,
                            _wheel_load(lm, f),
                        ),
                    )
                )
                for f in figs
            }
        )
    out = {}
    for f in spec.objectives:
        out[f.name] = float(sum(wi * pp[f.name] for wi, pp in zip(w, per_point)))
    for c, _ in spec.constraints:
        out[c.name] = float(max(pp[c.name] for pp in per_point))
    return out


def _predicted(problem: DesignProblem, x) -> Dict[str, float]:
    spec = problem.spec
    F, G = problem.evaluate(x)
    out = {o.name: float(F[0, j]) for j, o in enumerate(spec.objectives)}
    for j, (c, lim) in enumerate(spec.constraints):
        out[c.name] = float((G[0, j] + 1.0) * lim)
    return out


def design(spec: DesignSpec, verify: bool = True) -> DesignResult:
    """Search a specification's design space; verify the chosen designs in the time domain.

    Parameters
    ----------
    spec : DesignSpec
        From :func:`bodyvib.vehicle.design.spec.parse_spec` or ``load_spec``.
    verify : bool
        Run :func:`verify_design` for each chosen design (30 s runs by default).

    Returns
    -------
    DesignResult

    Raises
    ------
    BodyvibError
        No design within the bounds meets the constraints.
    bodyvib.process.extras.MissingExtraError
        The fit extra is not installed.

    Examples
    --------
    >>> from bodyvib.vehicle.design.spec import parse_spec
    >>> spec = parse_spec({"car": "quarter-car", "body": None,
    ...     "parameters": {"cs": {"min": 200, "max": 5000, "scale": "log"}},
    ...     "operating_points": [{"road": "C", "speed": 20}],
    ...     "objectives": ["rms:sprung.a"], "search": {"population": 12, "generations": 5}})
    >>> r = design(spec, verify=False)
    >>> round(r.chosen[0].values["cs"])  # 16812 sqrt((290 + 59) / 190000), N s/m
    721
    """
    extras.require("a design search", "fit")
    from threadpoolctl import threadpool_limits

    problem = DesignProblem(spec)
    t0 = time.perf_counter()
    with threadpool_limits(1, user_api="blas"):
        if spec.search.method == "nsga2":
            X = _nsga2(problem, spec)
        else:
            X = _single(problem, spec)
        F, G = problem.evaluate(X)
    order = np.argsort(F[:, 0], kind="stable")
    X, F, G = X[order], F[order], G[order]
    elapsed = time.perf_counter() - t0
    names = [o.name for o in spec.objectives]
    points = []
    t1 = time.perf_counter()
    for label, i in chosen_points(F, names).items():
        vals = dict(zip(problem.names, map(float, X[i])))
        points.append(
            DesignPoint(
                label=label,
                values=vals,
                predicted=_predicted(problem, X[i]),
                verified=verify_design(spec, vals) if verify else {},
            )
        )
    start = dict(zip(problem.names, (problem._car.parameters[n] for n in problem.names)))
    baseline = DesignPoint(
        label="baseline",
        values=start,
        predicted=_predicted(problem, np.array([list(start.values())])),
    )
    return DesignResult(
        baseline=baseline,
        spec=spec,
        values=X,
        objectives=F,
        constraints=G,
        chosen=tuple(points),
        evaluations=problem.evaluations,
        elapsed_s=elapsed,
        verify_s=time.perf_counter() - t1,
    )
