"""A design specification: what is tuned, within which bounds, for what, on which roads.

A specification is a JSON object (``bodyvib design SPEC.json``)::

    {
      "car": "quarter-car",                      # shipped name or car parameter file
      "body": "reduced-paper",                   # body model, or null for the car alone
      "parameters": {                            # car parameters and their bounds (SI)
        "ks": {"min": 10000, "max": 40000, "scale": "log"},
        "cs": {"min": 300, "max": 6000, "scale": "log"}
      },
      "operating_points": [                      # ISO 8608 class x speed, weighted
        {"road": "C", "speed": 20, "weight": 1}
      ],
      "objectives": ["head_wk_rms", "tire_load_ratio"],
      "constraints": {"travel_ratio": 1.0},      # objective name -> upper limit
      "rattle_space": 0.07,                      # m, for travel_ratio
      "search": {"method": "nsga2", "population": 40, "generations": 40, "seed": 1},
      "verify": {"duration": 30, "step": 0.001, "seed": 0}
    }

**Objectives** (:data:`OBJECTIVES`) are named, or refer to any output of the seated
model by name: ``"rms:<output>"`` (r.m.s.) and ``"wk_rms:<output>"`` (ISO 2631-1
Wk-weighted r.m.s.), e.g. ``"rms:body.upper_body.force"`` (the reduced body's neck
element). An objective's value is the weighted mean of its figure over the operating
points; a constraint holds at every operating point. An output that follows the road
statically (an absolute displacement) has no stationary r.m.s. and is refused.

Every check runs when the specification is read, before any search: an unknown key,
parameter, objective or road, a value that is not a JSON number (``"8000"``), a bound
below zero or an empty range, an empty operating set, a method that does not fit the
number of objectives, a search that would evaluate more than :data:`MAX_EVALUATIONS`
designs or a population whose search would not fit in half the memory at hand, and a
verification whose step is not below its duration, is longer than the figures allow
(:func:`bodyvib.comfort.check_step`, for the nominal design), runs shorter than the MTVV's
1 s window or would not fit in memory.
"""

import json
import math
import os
from dataclasses import dataclass, field, replace
from typing import Optional, Tuple

from bodyvib.comfort import check_step
from bodyvib.models import load_model
from bodyvib.process.limits import require_memory
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.network import linear_model
from bodyvib.seat.signal import MIN_DURATION_S

from ..quarter_car import load_car, seated_system
from ..road.synthetic import ISO8608_CLASSES
from ..signals import corner_variable
from .stationary import stationary_outputs

__all__ = [
    "OBJECTIVES",
    "METHODS",
    "MAX_EVALUATIONS",
    "NSGA2_BYTES_PER_PAIR",
    "BYTES_PER_CANDIDATE",
    "VERIFY_BYTES_PER_VALUE",
    "Bound",
    "OperatingPoint",
    "Objective",
    "SearchSettings",
    "VerifySettings",
    "DesignSpec",
    "parse_spec",
    "load_spec",
    "objective",
    "seated_model",
]

#: Named objectives: kind, output, unit, meaning. Kinds: ``wk_rms`` (Wk-weighted
#: r.m.s.), ``rms``, ``load_ratio`` (r.m.s. over the static wheel load), ``rattle_ratio``
#: (3 r.m.s. over the rattle space), ``power`` (the occupant's absorbed power, W),
#: ``seat`` (ISO 10326-1 SEAT: 100 Wk r.m.s. of the seat pan over that of the floor
#: under the seat, %).
OBJECTIVES = {
    "head_wk_rms": ("wk_rms", "body.head.a", "m/s2", "Wk-weighted r.m.s. head acceleration"),
    "seat_wk_rms": ("wk_rms", "seat.a", "m/s2", "Wk-weighted r.m.s. seat acceleration"),
    "tire_load_ratio": (
        "load_ratio",
        "tire.force",
        "-",
        "r.m.s. dynamic tire load over the static wheel load",
    ),
    "travel_rms": ("rms", "suspension.deflection", "m", "r.m.s. suspension travel"),
    "travel_ratio": (
        "rattle_ratio",
        "suspension.deflection",
        "-",
        "3-sigma suspension travel over the rattle space",
    ),
    "absorbed_power": (
        "power",
        "seat.v",
        "W",
        "mean power the seat puts into the occupant, E[seat force x seat velocity]",
    ),
    "seat_seat": (
        "seat",
        "seat.a",
        "%",
        "ISO 10326-1 SEAT: Wk r.m.s. seat pan over Wk r.m.s. floor (sprung mass), %",
    ),
}

#: Search methods: NSGA-II (pymoo) for two objectives or more; the fit's genetic
#: algorithm and CMA-ES (:mod:`bodyvib.fit.methods`) for one.
METHODS = ("nsga2", "ga", "cmaes")

#: Most designs one search may evaluate (population times generations and one): about 4 to
#: 11 hours at the 1.2 to 4 ms one evaluation of the shipped quarter car with the reduced
#: body takes (measured), as a run is bounded by its steps (``bodyvib.vehicle.study.MAX_STEPS``).
MAX_EVALUATIONS = 1e7

#: Memory of NSGA-II per pair of candidates, bytes: pymoo's duplicate elimination holds
#: the distances between a generation's offspring and the population, ``2 population^2``
#: doubles (measured 17 B per squared population at 8000).
NSGA2_BYTES_PER_PAIR = 16

#: Memory per candidate of every method, bytes (chosen: twice the 1.1 kB per member of
#: the population measured for CMA-ES, the largest of the three).
BYTES_PER_CANDIDATE = 2000

#: Memory of a verification run per step and per state or output of the seated model,
#: bytes: the states, the outputs and a copy, three doubles each (measured 640 to 690 B
#: a step for the quarter car with the reduced body, 9 states and 26 outputs: 840 here).
VERIFY_BYTES_PER_VALUE = 24

_KEYS = {
    "car",
    "body",
    "parameters",
    "operating_points",
    "objectives",
    "constraints",
    "rattle_space",
    "search",
    "verify",
    "description",
}


@dataclass(frozen=True)
class Bound:
    """A tuned car parameter: name, range (SI) and whether it is searched in ``log``."""

    name: str
    lo: float
    hi: float
    log: bool = False

    def value(self, u):
        """Parameter value at the unit coordinate ``u`` in [0, 1] (array or float)."""
        if self.log:
            return self.lo * (self.hi / self.lo) ** u
        return self.lo + (self.hi - self.lo) * u


@dataclass(frozen=True)
class OperatingPoint:
    """An ISO 8608 road class driven at a speed (m/s), with its weight in the objectives."""

    road: str
    speed: float
    weight: float = 1.0


@dataclass(frozen=True)
class Objective:
    """A figure of the design: its name, kind, model output, unit and meaning."""

    name: str
    kind: str
    output: str
    unit: str
    description: str


@dataclass(frozen=True)
class SearchSettings:
    """The search: method, population, generations, seed."""

    method: str = "nsga2"
    population: int = 40
    generations: int = 40
    seed: int = 1


@dataclass(frozen=True)
class VerifySettings:
    """The time-domain verification of chosen designs: run length, step (s) and road seed."""

    duration: float = 30.0
    step: float = 0.001
    seed: int = 0


@dataclass(frozen=True)
class DesignSpec:
    """A checked design specification (:func:`parse_spec`).

    Attributes
    ----------
    car : str
        Shipped car name or parameter file.
    body : str or None
        Body model (shipped name or file), None for the car alone.
    parameters : tuple of Bound
    operating_points : tuple of OperatingPoint
    objectives : tuple of Objective
    constraints : tuple of (Objective, float)
        Upper limits, in the objective's unit.
    rattle_space : float or None
        m.
    search : SearchSettings
        The spec's ``search`` (defaults where it has none).
    verify : VerifySettings
        The spec's ``verify`` (defaults where it has none).
    description : str
        The spec's own words for the design, empty if it gives none.
    """

    car: str
    body: Optional[str]
    parameters: Tuple[Bound, ...]
    operating_points: Tuple[OperatingPoint, ...]
    objectives: Tuple[Objective, ...]
    constraints: Tuple[Tuple[Objective, float], ...] = ()
    rattle_space: Optional[float] = None
    search: SearchSettings = field(default_factory=SearchSettings)
    verify: VerifySettings = field(default_factory=VerifySettings)
    description: str = ""


def objective(name: str) -> Objective:
    """The objective a name stands for (:data:`OBJECTIVES`, ``rms:OUT``, ``wk_rms:OUT``).

    Parameters
    ----------
    name : str
        A key of :data:`OBJECTIVES`, or ``rms:`` or ``wk_rms:`` and an output's name.

    Returns
    -------
    Objective

    Raises
    ------
    BodyvibError
        An unknown name.

    Examples
    --------
    >>> objective("rms:body.upper_body.force").output
    'body.upper_body.force'
    """
    name = str(name)
    if name in OBJECTIVES:
        return Objective(name, *OBJECTIVES[name])
    kind, _, out = name.partition(":")
    if kind in ("rms", "wk_rms") and out:
        unit = "m/s2" if kind == "wk_rms" else "SI"
        what = "Wk-weighted r.m.s." if kind == "wk_rms" else "r.m.s."
        return Objective(name, kind, out, unit, f"{what} of {out}")
    raise BodyvibError(
        f"unknown objective '{name}'; use one of {', '.join(OBJECTIVES)}, "
        "'rms:OUTPUT' or 'wk_rms:OUTPUT'"
    )


def seated_model(car, body, values=None):
    """The linear model of a car (with its tuned values) and its occupant, if any.

    Parameters
    ----------
    car : str or Network
        Shipped car name, parameter file, or the car network.
    body : str, Network or None
        Body model, or None for the car alone.
    values : dict of str to float, optional
        Car parameter values replaced.

    Returns
    -------
    LinearModel
    """
    net = load_car(car) if isinstance(car, str) else car
    if values:
        net = net.with_parameters(**values)
    if body is not None:
        net = seated_system(net, load_model(body) if isinstance(body, str) else body)
    return linear_model(net)


def _number(value, what, positive=False, integer=False):
    """A JSON number of the spec, checked; a string (``"8000"``) is not one."""
    if isinstance(value, str):
        raise BodyvibError(
            f"{what} must be a number, not the string {value!r}; write it without quotes"
        )
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise BodyvibError(f"{what} must be a number, not {value!r}") from None
    if isinstance(value, bool) or not math.isfinite(x) or (positive and x <= 0):
        raise BodyvibError(
            f"{what} must be a {'positive ' if positive else ''}number, not {value!r}"
        )
    if integer and x != int(x):
        raise BodyvibError(f"{what} must be a whole number, not {value!r}")
    return int(x) if integer else x


def _only(d, keys, where):
    if not isinstance(d, dict):
        raise BodyvibError(f"{where} must be a JSON object")
    unknown = sorted(set(d) - set(keys))
    if unknown:
        raise BodyvibError(
            f"{where}: unknown key(s) {', '.join(unknown)}; allowed: {', '.join(sorted(keys))}"
        )


def _bounds(params, car_params) -> Tuple[Bound, ...]:
    if not isinstance(params, dict) or not params:
        raise BodyvibError("'parameters' must name at least one car parameter with its bounds")
    out = []
    for name, b in params.items():
        if name not in car_params:
            raise BodyvibError(
                f"unknown parameter '{name}'; the car's parameters are {', '.join(car_params)}"
            )
        _only(b, {"min", "max", "scale"}, f"parameter '{name}'")
        if "min" not in b or "max" not in b:
            raise BodyvibError(f"parameter '{name}' needs 'min' and 'max'")
        lo = _number(b["min"], f"parameter '{name}' min")
        hi = _number(b["max"], f"parameter '{name}' max")
        if lo < 0:
            raise BodyvibError(
                f"parameter '{name}': min {lo:g} is below zero; masses, stiffnesses and "
                "dampings are not negative"
            )
        if not hi > lo:
            raise BodyvibError(f"parameter '{name}': max {hi:g} must exceed min {lo:g}")
        scale = b.get("scale", "linear")
        if scale not in ("linear", "log"):
            raise BodyvibError(f"parameter '{name}': scale must be 'linear' or 'log'")
        if scale == "log" and lo == 0:
            raise BodyvibError(f"parameter '{name}': a log scale needs min > 0")
        out.append(Bound(name, lo, hi, scale == "log"))
    return tuple(out)


def _operating_points(points) -> Tuple[OperatingPoint, ...]:
    if not isinstance(points, list) or not points:
        raise BodyvibError(
            '\'operating_points\' is empty; give at least one, e.g. [{"road": "C", "speed": 20}]'
        )
    out = []
    for i, p in enumerate(points):
        where = f"operating point {i + 1}"
        _only(p, {"road", "speed", "weight"}, where)
        road = str(p.get("road", "")).strip().upper()
        if road not in ISO8608_CLASSES:
            raise BodyvibError(
                f"{where}: road must be an ISO 8608 class ({', '.join(ISO8608_CLASSES)}), "
                f"not {p.get('road')!r}"
            )
        speed = _number(p.get("speed"), f"{where} speed (m/s)", positive=True)
        weight = _number(p.get("weight", 1.0), f"{where} weight")
        if weight < 0:
            raise BodyvibError(f"{where}: weight must not be negative")
        out.append(OperatingPoint(road, speed, weight))
    if sum(p.weight for p in out) <= 0:
        raise BodyvibError("the operating points' weights sum to zero")
    return tuple(out)


def _on_car(obj: Objective, lm) -> Objective:
    """A named objective's output on a car with axles or corners: a half car's front
    axle's (``tire_front.force``), a full car's front left corner's
    (``tire_front_left.force``), where the car has no output of the plain name."""
    if obj.output in lm.outputs:
        return obj
    element, dot, signal = obj.output.partition(".")
    parts = {o.partition(".")[0] for o in lm.outputs}
    return replace(obj, output=corner_variable(element, parts) + dot + signal)


def _check_computable(obj: Objective, lm, rattle, body) -> None:
    """Refuse an objective the model cannot compute (before any search)."""
    if (obj.output.startswith("body.") or obj.kind == "power") and body is None:
        raise BodyvibError(f"objective '{obj.name}' needs a body model; the spec has none")
    if obj.kind in ("power", "seat") and len(lm.network.bases) > 1:
        raise BodyvibError(
            f"objective '{obj.name}' is computed for a car on one road point (a quarter car); "
            "this car has several: choose another objective"
        )
    if obj.kind == "rattle_ratio" and rattle is None:
        raise BodyvibError(f"objective '{obj.name}' needs 'rattle_space' (m) in the spec")
    outs = [obj.output] + (["sprung.a"] if obj.kind == "seat" else [])
    for out in outs:
        try:
            i = lm.output_index(out)
        except BodyvibError as exc:
            raise BodyvibError(f"objective '{obj.name}': {exc}") from None
        if not stationary_outputs(lm)[i]:
            raise BodyvibError(
                f"objective '{obj.name}' cannot be computed: output '{out}' has no stationary "
                "r.m.s. on a random road (it follows the road, or has white noise in it); "
                "use an acceleration, deflection or force"
            )


def _search(s, objectives: int) -> SearchSettings:
    """The ``search`` block, its sizes bounded by the time and memory the search would take."""
    _only(s, {"method", "population", "generations", "seed"}, "'search'")
    method = s.get("method", "nsga2" if objectives > 1 else "ga")
    if method not in METHODS:
        raise BodyvibError(f"unknown search method '{method}'; methods are {', '.join(METHODS)}")
    if method == "nsga2" and objectives < 2:
        raise BodyvibError("nsga2 needs two objectives or more; use 'ga' or 'cmaes' for one")
    if method != "nsga2" and objectives != 1:
        raise BodyvibError(f"'{method}' minimizes one objective; use 'nsga2' for a Pareto front")
    population = _number(s.get("population", 40), "search population", True, True)
    generations = _number(s.get("generations", 40), "search generations", True, True)
    evaluations = population * (generations + 1)  # the first population, then each generation
    if evaluations > MAX_EVALUATIONS:
        raise BodyvibError(
            f"a search of population {population:.3g} over {generations:.3g} generations "
            f"evaluates about {float(evaluations):.3g} designs; the limit is "
            f"{MAX_EVALUATIONS:.3g} (hours of wall time at a few ms each): lower the "
            "population or the generations"
        )
    pairs = population**2 * NSGA2_BYTES_PER_PAIR if method == "nsga2" else 0
    require_memory(
        pairs + population * BYTES_PER_CANDIDATE,
        f"a {method} search of population {population}",
        "lower the population",
    )
    return SearchSettings(
        method=method,
        population=population,
        generations=generations,
        seed=_number(s.get("seed", 1), "search seed", integer=True),
    )


def _verify(v, lm) -> VerifySettings:
    """The ``verify`` block: runs the Wk weighting and the MTVV can take, that fit in memory."""
    _only(v, {"duration", "step", "seed"}, "'verify'")
    duration = _number(v.get("duration", 30.0), "verify duration (s)", positive=True)
    step = _number(v.get("step", 0.001), "verify step (s)", positive=True)
    if step >= duration:
        raise BodyvibError(
            f"verify step {step:g} s is not shorter than its duration {duration:g} s; "
            "use a step of 0.001 s (the default)"
        )
    check_step(step, [lm], name="verify step")  # the figures' step (the nominal design)
    if duration < MIN_DURATION_S:
        raise BodyvibError(
            f"verify duration {duration:g} s is shorter than the {MIN_DURATION_S:g} s the "
            "figures need (the MTVV's window); 30 s by default"
        )
    steps = duration / step + 1
    require_memory(
        steps * VERIFY_BYTES_PER_VALUE * (lm.A.shape[0] + len(lm.outputs)),
        f"a verification run of {duration:g} s at a {step:g} s step ({steps:.3g} steps)",
        "shorten the verify duration or lengthen its step",
    )
    return VerifySettings(
        duration=duration, step=step, seed=_number(v.get("seed", 0), "verify seed", integer=True)
    )


def parse_spec(spec: dict) -> DesignSpec:
    """Check a design specification and return it typed.

    Parameters
    ----------
    spec : dict
        As in the module docstring.

    Returns
    -------
    DesignSpec

    Raises
    ------
    BodyvibError
        The first problem found, in one line naming it and the fix.

    Examples
    --------
    >>> s = parse_spec({"car": "quarter-car", "body": None,
    ...                 "parameters": {"cs": {"min": 200, "max": 5000, "scale": "log"}},
    ...                 "operating_points": [{"road": "C", "speed": 20}],
    ...                 "objectives": ["rms:sprung.a"]})
    >>> s.search.method, s.parameters[0].log
    ('ga', True)
    >>> parse_spec({**{"car": "quarter-car", "body": None, "objectives": ["rms:sprung.a"],
    ...               "operating_points": [{"road": "C", "speed": 20}]},
    ...             "parameters": {"cs": {"min": -1, "max": 5000}}})
    Traceback (most recent call last):
    ...
    bodyvib.runtime.errors.BodyvibError: parameter 'cs': min -1 is below zero; masses, stiffnesses and dampings are not negative
    """
    _only(spec, _KEYS, "design spec")
    car = str(spec.get("car", "quarter-car"))
    body = spec.get("body", "reduced-paper")
    body = None if body is None else str(body)
    car_net = load_car(car)
    if body is not None:
        load_model(body)  # a missing or invalid body is refused here
    bounds = _bounds(spec.get("parameters"), car_net.parameters)
    points = _operating_points(spec.get("operating_points"))
    rattle = spec.get("rattle_space")
    rattle = None if rattle is None else _number(rattle, "rattle_space (m)", positive=True)
    names = spec.get("objectives")
    if isinstance(names, str):
        names = [names]
    if not isinstance(names, list) or not names:
        raise BodyvibError("'objectives' must list at least one objective, e.g. ['head_wk_rms']")
    objectives = tuple(objective(n) for n in names)
    if len({o.name for o in objectives}) != len(objectives):
        raise BodyvibError("an objective is listed twice")
    cons = spec.get("constraints") or {}
    if not isinstance(cons, dict):
        raise BodyvibError("'constraints' must map objective names to upper limits")
    constraints = tuple(
        (objective(k), _number(v, f"constraint '{k}'", positive=True)) for k, v in cons.items()
    )
    lm = seated_model(car, body)
    objectives = tuple(_on_car(o, lm) for o in objectives)
    constraints = tuple((_on_car(c, lm), lim) for c, lim in constraints)
    for obj in objectives + tuple(c for c, _ in constraints):
        _check_computable(obj, lm, rattle, body)
    return DesignSpec(
        car=car,
        body=body,
        parameters=bounds,
        operating_points=points,
        objectives=objectives,
        constraints=constraints,
        rattle_space=rattle,
        search=_search(spec.get("search") or {}, len(objectives)),
        verify=_verify(spec.get("verify") or {}, lm),
        description=str(spec.get("description", "")),
    )


def load_spec(path, car: Optional[str] = None) -> DesignSpec:
    """Read and check a design specification file (JSON).

    Relative car and body file paths are taken from the spec file's folder.

    Parameters
    ----------
    path : str or os.PathLike
    car : str, optional
        A car (shipped name or parameter file) in place of the spec's ``car``: the
        spec's parameters must be its own.

    Returns
    -------
    DesignSpec
        As :func:`parse_spec` returns it, with the car (and body) paths resolved.

    Raises
    ------
    BodyvibError
        An unreadable file, invalid JSON, or what :func:`parse_spec` refuses.
    """
    path = os.fspath(path)
    try:
        with open(path, encoding="utf-8") as f:
            spec = json.load(f)
    except OSError as exc:
        raise BodyvibError(f"cannot read design spec '{path}': {exc.strerror}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise BodyvibError(f"design spec '{path}' is not valid JSON: {exc}") from None
    except RecursionError:
        raise BodyvibError(f"design spec '{path}' is nested too deeply to be a spec") from None
    if isinstance(spec, dict):
        here = os.path.dirname(os.path.abspath(path))
        for key in ("car", "body"):
            val = spec.get(key)
            if isinstance(val, str) and val.endswith(".json") and not os.path.isabs(val):
                spec = {**spec, key: os.path.join(here, val)}
        if car is not None:
            spec = {**spec, "car": car}
    return parse_spec(spec)
