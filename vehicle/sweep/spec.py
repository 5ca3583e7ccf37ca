"""Sweep specifications: what a study varies, expanded into one case per combination.

A spec is a JSON object (or the same dict in Python). Every key takes one
value or a list; the cases are all combinations (the Cartesian product, in
the order road, seed, speed, duration, step, body, car)::

    {
      "road": ["A", "B", "C", "D", "E"],   ISO 8608 class A-H, "bump", "sweep", a bump shape
                                           ("hump:h=0.075,l=3.7", bodyvib.vehicle.road.bumps) or a road file
                                           (.crg, .csv, .txt, .erd; relative to the working folder)
      "road_options": {"taper_m": 5},      how roads are driven: taper_m, track_m, units,
                                           envelope, repeat, contact (as the --road-* options)
      "seed": [0],                         random-road seed(s), or a range "0..24" (no effect on bump/sweep)
      "speed": [10, 15, 20, 25, 30],       m/s
      "duration": 30,                      s
      "step": 0.001,                       s
      "body": ["reduced-paper",            shipped name, a parameter file, or a range:
               {"model": "reduced-paper", "vary": {"k1": [0.8, 1.2], "c1": [0.5, 2]},
                "samples": 400, "seed": 0, "method": "lhs", "name": "reduced-varied"}],
      "car": ["quarter-car", "quarter-car-cushion"],  shipped name or a parameter file
      "seat": ["none", "cushion", "suspension"],     a seat on every car: "none", a shipped
                                                     seat or a seat file (bodyvib.vehicle.seats)
      "linear": false                      true: every car linearized (as cosim --linear)
    }

Defaults: ``seed`` 0, ``duration`` 30, ``step`` 0.001, ``car`` ``quarter-car``, ``seat``
``none`` (the car as its file gives it), ``linear`` false (cars with tire contacts and
stops step them: :mod:`bodyvib.vehicle.sweep.engines`); every car is combined with every seat, and a case's
``car`` is then ``CAR+SEAT`` (:func:`bodyvib.vehicle.seats.car_with_seat`);
``road`` is required; ``speed`` defaults to cosim's speed (20 m/s), ``body`` to cosim's body
(the paper's reduced model, ``reduced-paper``) and ``car`` to its car (``quarter-car``).
A step longer than the figures allow for a car with a named body is refused
(:func:`bodyvib.comfort.check_step`; the ``vary`` samples share their model's check).

**Parameter ranges around one model.** ``vary`` maps parameter names of
``model`` to ``[low, high]`` *factors* on the model's own value. ``samples``
parameter sets are drawn with ``method`` ``"lhs"`` (default: a Latin hypercube,
:class:`scipy.stats.qmc.LatinHypercube`, one stratum per sample in every
factor) or ``"uniform"`` (independent uniform factors), from ``seed``
(default 0), uniform in each factor's range. The same entry always gives the
same sets. Each set is one body of the sweep, named by the entry's ``name``
(default: the model's) with its sample number in the ``body_sample`` column.

Each case has a ``case_key``: a hash of everything that determines its result
(settings, the body's and car's parameter values), with which ``--resume``
recognizes the cases already done. The spec hash covers the spec and the
contents of the files it names.
"""

import hashlib
import json
import math
import os
from dataclasses import dataclass
from itertools import product
from typing import Callable, Dict, Iterator, List, Optional, Sequence, Tuple

import numpy as np

from bodyvib.models import load_model
from bodyvib.process.limits import require_memory
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.jsonfile import read_json
from bodyvib.runtime.modelfile import network_to_dict

from ..fmus import FMUS
from ..quarter_car import load_car
from ..road.driven import RoadOptions, RunSettings, is_road_file, road_label
from ..seats import car_with_seat
from ..study import check_settings, check_study_step

__all__ = [
    "Case",
    "ROAD_OPTION_KEYS",
    "SPEC_KEYS",
    "load_spec",
    "grid_spec",
    "expand",
    "iter_cases",
    "count_cases",
    "spec_hash",
    "varied_parameters",
    "seed_range",
]

#: The ``seat`` value of a car without an added seat.
NO_SEAT = "none"

#: Keys of a spec and their defaults (None: required).
SPEC_KEYS = {
    "road": None,
    "seed": 0,
    "speed": 20.0,  # cosim's default speed
    "duration": 30.0,
    "step": 1e-3,
    "body": FMUS["HumanBody3DOF"][1],  # cosim's default body, the paper's reduced model
    "car": "quarter-car",
    "seat": NO_SEAT,
    "road_options": {},
    "linear": False,
}
#: Keys of ``road_options``: the fields of :class:`bodyvib.vehicle.road.driven.RoadOptions`
#: (``taper`` and ``track``, the old names of the first two, work for one release, warned).
ROAD_OPTION_KEYS = ("taper_m", "track_m", "units", "envelope", "repeat", "contact")
_BODY_KEYS = {"model", "vary", "samples", "seed", "method", "name"}


@dataclass(frozen=True)
class Case:
    """One case of a sweep: settings, one body, one car.

    Attributes
    ----------
    case_id : int
        Position in the expanded spec.
    road : str
        ISO 8608 class, ``"bump"``, ``"sweep"`` or a road file's absolute path.
    seed : int
        Random-road seed (>= 0; no effect on ``bump`` and ``sweep``).
    speed : float
        m/s.
    duration, step : float
        s.
    body : str
        The body entry's name.
    body_model : str
        Shipped name or parameter file of the body.
    body_sample : int
        Parameter-set number of a ``vary`` entry, -1 for a plain body.
    body_values : tuple of (str, float)
        Parameter values replaced in ``body_model`` (SI units).
    car : str
        Shipped name or parameter file of the car.
    case_key : str
        Hash of everything that determines the result.
    road_options : tuple of (str, object)
        Fields of :class:`bodyvib.vehicle.road.driven.RoadOptions` that differ from the defaults.
    linear : bool
        Run the car linearized about static equilibrium (the spec's ``linear``).
    """

    case_id: int
    road: str
    seed: int
    speed: float
    duration: float
    step: float
    body: str
    body_model: str
    body_sample: int
    body_values: Tuple[Tuple[str, float], ...]
    car: str
    case_key: str = ""
    road_options: Tuple[Tuple[str, object], ...] = ()
    linear: bool = False

    @property
    def steps(self) -> int:
        """Number of samples, ``round(duration / step) + 1`` (as ``bodyvib cosim``)."""
        return int(round(self.duration / self.step)) + 1

    def road_settings(self):
        """The :class:`bodyvib.vehicle.road.driven.RoadOptions` of this case."""
        from ..road.driven import RoadOptions

        return RoadOptions(**dict(self.road_options))

    def run_settings(self):
        """The :class:`bodyvib.vehicle.road.driven.RunSettings` of this case's run."""
        from ..road.driven import RunSettings

        return RunSettings.from_attributes(self, self.road_settings())

    def body_network(self):
        """The body model with this case's parameter values."""
        net = load_model(self.body_model)
        return net.with_parameters(**dict(self.body_values)) if self.body_values else net

    def car_network(self):
        """The car model: with its tire contacts and stops, or linearized (``linear``)."""
        return load_car(self.car, linear=self.linear)


def _list(value):
    return list(value) if isinstance(value, (list, tuple)) else [value]


def seed_range(text: str) -> List[int]:
    """Seeds of a range written ``"FIRST..LAST"`` (both included).

    Parameters
    ----------
    text : str
        ``"FIRST..LAST"`` with integers 0 <= FIRST <= LAST (a spec's ``seed`` entry or a
        ``--grid seed=`` item).

    Returns
    -------
    list of int
        FIRST, FIRST + 1, ..., LAST.

    Raises
    ------
    BodyvibError
        Not two non-negative integers with FIRST <= LAST.

    Examples
    --------
    >>> seed_range("0..3")
    [0, 1, 2, 3]
    """
    a, b = _seed_bounds(text)
    return list(range(a, b + 1))


def _seed_bounds(text: str) -> Tuple[int, int]:
    """FIRST and LAST of a ``"FIRST..LAST"`` range, checked (nothing expanded)."""
    first, sep, last = str(text).partition("..")
    try:
        a, b = int(first), int(last)
    except ValueError:
        a = b = -1
    if not sep or a < 0 or b < a:
        raise BodyvibError(
            f"spec: seed range '{text}' must look like FIRST..LAST with "
            "0 <= FIRST <= LAST, e.g. 0..24"
        )
    return a, b


def _seed_count(value) -> int:
    """Number of seeds of a spec's ``seed`` entry, its ranges counted without expanding them."""
    n = 0
    for v in _list(value):
        if isinstance(v, str):
            a, b = _seed_bounds(v)
            n += b - a + 1
        else:
            n += 1
    return n


def _seed_list(value) -> list:
    out = []
    for v in _list(value):
        out += seed_range(v) if isinstance(v, str) else [v]
    return out


def _number(v, what, unit, integer=False):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
    if integer:
        ok = ok and float(v).is_integer() and v >= 0
    elif ok:
        ok = v > 0
    if not ok:
        kind = "a non-negative integer" if integer else f"a positive number of {unit}"
        raise BodyvibError(f"spec: {what} must be {kind}, got {v!r}")
    return int(v) if integer else float(v)


def load_spec(path) -> dict:
    """Read a spec file (JSON).

    Parameters
    ----------
    path : str
        JSON file holding one object (keys in the module docstring).

    Returns
    -------
    dict
        The object as read, not yet validated (:func:`iter_cases` validates it).

    Raises
    ------
    BodyvibError
        Missing or unreadable file, not a JSON object.
    """
    spec = read_json(path, "sweep spec")
    if not isinstance(spec, dict):
        raise BodyvibError(f"sweep spec '{path}' must be a JSON object")
    return spec


def grid_spec(
    items: Sequence[str],
    duration: float = 30.0,
    step: float = 1e-3,
    road_options: Optional[dict] = None,
) -> dict:
    """A spec from command-line ``key=v1,v2`` items (``bodyvib sweep --grid``).

    Parameters
    ----------
    items : sequence of str
        e.g. ``["road=C,D", "speed=10,20", "seed=0,1", "body=reduced-paper,iso7962"]``;
        keys road, seed, speed, body, car, seat (and duration, step).
    duration, step : float
        Used unless given as items.
    road_options : dict, optional
        The spec's ``road_options`` (from the ``--road-*`` options).

    Returns
    -------
    dict
        A spec, not yet validated: each item's key with its list of values (speeds,
        durations and steps as floats; seeds as ints or ``"FIRST..LAST"`` ranges; roads,
        bodies and cars as text), ``duration`` and ``step`` (the arguments unless given as
        items) and ``road_options`` when given.

    Raises
    ------
    BodyvibError
        An item without ``=``, an unknown or repeated key, a non-numeric number.

    Examples
    --------
    >>> grid_spec(["road=C,D", "speed=10,20"])["speed"]
    [10.0, 20.0]
    >>> grid_spec(["road=hump:h=0.075,l=3.7,hump:h=0.1", "speed=5"])["road"]
    ['hump:h=0.075,l=3.7', 'hump:h=0.1']
    """
    spec = {"duration": duration, "step": step}
    if road_options:
        spec["road_options"] = dict(road_options)
    seen = set()
    for item in items:
        key, sep, values = str(item).partition("=")
        key = key.strip()
        if not sep or not values.strip():
            raise BodyvibError(
                f"grid_spec item '{item}' must look like key=v1,v2", parameters=("grid_spec",)
            )
        if key not in SPEC_KEYS or key == "road_options":
            raise BodyvibError(
                f"grid_spec key '{key}' is unknown; keys are "
                + ", ".join(k for k in SPEC_KEYS if k != "road_options"),
                parameters=("grid_spec",),
            )
        if key in seen:
            raise BodyvibError(f"grid_spec key '{key}' is given twice", parameters=("grid_spec",))
        seen.add(key)
        parts = [v.strip() for v in values.split(",") if v.strip()]
        if key == "road":
            parts = _join_bump_keys(parts)
        if key == "seed" and any(".." in v for v in parts):
            parts = [v if ".." in v else _grid_number(v, key, values) for v in parts]
        elif key in ("speed", "duration", "step", "seed"):
            try:
                nums = [float(v) for v in parts]
            except ValueError:
                raise _not_numbers(key, values) from None
            parts = (
                [int(v) for v in nums]
                if key == "seed" and all(v.is_integer() for v in nums)
                else nums
            )
        spec[key] = parts
    return spec


def _join_bump_keys(parts: List[str]) -> List[str]:
    """Roads of a ``--grid`` item: a ``key=value`` part belongs to the bump before it.

    ``hump:h=0.075,l=3.7,table`` is two roads, ``hump:h=0.075,l=3.7`` and ``table``.
    """
    roads: List[str] = []
    for p in parts:
        if roads and "=" in p and ":" not in p and ":" in roads[-1]:
            roads[-1] += "," + p
        else:
            roads.append(p)
    return roads


def _grid_number(v, key, values):
    try:
        x = float(v)
    except ValueError:
        raise _not_numbers(key, values) from None
    return int(x) if x.is_integer() else x


def _not_numbers(key, values) -> BodyvibError:
    return BodyvibError(
        f"grid_spec {key}: '{values}' is not a list of numbers", parameters=("grid_spec",)
    )


def _file_digest(source: str) -> Optional[str]:
    if os.path.isfile(source):
        with open(source, "rb") as f:
            return hashlib.sha256(f.read()).hexdigest()[:16]
    return None


def spec_hash(spec: dict) -> str:
    """Hash of a spec and of the contents of the files it names (12 hex digits).

    Parameters
    ----------
    spec : dict
        A spec (keys in the module docstring); need not be validated. The files its
        roads, bodies and cars name are read; names that are not files are hashed as text.

    Returns
    -------
    str
        The first 12 hex digits of the SHA-256 of the spec (keys sorted) and of the
        files' contents: equal for equal studies, different when a named file changes.

    Examples
    --------
    >>> len(spec_hash({"road": "C", "speed": 10, "body": "reduced-paper"}))
    12
    """
    files = {}
    for entry in (
        _list(spec.get("body", []))
        + _list(spec.get("car", []))
        + _list(spec.get("seat", []))
        + _list(spec.get("road", []))
    ):
        src = entry.get("model") if isinstance(entry, dict) else entry
        if isinstance(src, str) and _file_digest(src):
            files[src] = _file_digest(src)
    text = json.dumps({"spec": spec, "files": files}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _samples(entry: dict, where: str) -> Tuple[str, List[Tuple[Tuple[str, float], ...]]]:
    """Parameter sets of a ``vary`` entry: (model, [((name, value), ...), ...])."""
    unknown = sorted(set(entry) - _BODY_KEYS)
    if unknown:
        raise BodyvibError(
            f"spec: {where} has unknown key(s) {', '.join(unknown)}; "
            f"keys are {', '.join(sorted(_BODY_KEYS))}"
        )
    if "model" not in entry:
        raise BodyvibError(f"spec: {where} needs a 'model'")
    net = load_model(entry["model"])
    vary = entry.get("vary", {})
    if not isinstance(vary, dict) or not vary:
        raise BodyvibError(f"spec: {where}: 'vary' must map parameter names to [low, high] factors")
    names = list(vary)
    lo, hi = [], []
    for name in names:
        if name not in net.parameters:
            raise BodyvibError(
                f"spec: {where}: model '{net.name}' has no parameter '{name}'; "
                f"its parameters are {', '.join(net.parameters)}"
            )
        r = vary[name]
        if (
            not isinstance(r, (list, tuple))
            or len(r) != 2
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in r)
            or not (0 < r[0] <= r[1] and math.isfinite(r[1]))
        ):
            raise BodyvibError(
                f"spec: {where}: vary['{name}'] must be [low, high] with "
                f"0 < low <= high (factors on the model's value), got {r!r}"
            )
        lo.append(float(r[0]))
        hi.append(float(r[1]))
    count = entry.get("samples", 1)
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise BodyvibError(f"spec: {where}: 'samples' must be a positive integer, got {count!r}")
    seed = _number(entry.get("seed", 0), f"{where} seed", "", integer=True)
    method = entry.get("method", "lhs")
    if method == "lhs":
        from scipy.stats import qmc

        unit = qmc.LatinHypercube(d=len(names), seed=np.random.default_rng(seed)).random(count)
    elif method == "uniform":
        unit = np.random.default_rng(seed).random((count, len(names)))
    else:
        raise BodyvibError(f"spec: {where}: method must be 'lhs' or 'uniform', got {method!r}")
    factors = np.asarray(lo) + unit * (np.asarray(hi) - np.asarray(lo))
    sets = [
        tuple((n, float(net.parameters[n]) * float(f)) for n, f in zip(names, row))
        for row in factors
    ]
    return entry["model"], sets


def _bodies(spec) -> List[Tuple[str, str, int, tuple]]:
    """(name, model, sample, values) for every body of the spec."""
    out, names = [], set()
    for i, entry in enumerate(_list(spec["body"])):
        where = f"body[{i}]"
        if isinstance(entry, str):
            load_model(entry)  # a bad name or file is refused before any work
            name = os.path.splitext(os.path.basename(entry))[0] if os.path.isfile(entry) else entry
            rows = [(name, entry, -1, ())]
        elif isinstance(entry, dict):
            model, sets = _samples(entry, where)
            name = entry.get("name") or (
                os.path.splitext(os.path.basename(model))[0] if os.path.isfile(model) else model
            )
            rows = [(name, model, j, values) for j, values in enumerate(sets)]
        else:
            raise BodyvibError(
                f"spec: {where} must be a model name, a file or an object with 'model' and 'vary'"
            )
        if name in names:
            raise BodyvibError(f"spec: two body entries are named '{name}'; give one a 'name'")
        names.add(name)
        out.extend(rows)
    return out


#: Memory one case holds while a sweep is planned, run and tabulated, bytes: its Case
#: (about 600 B measured by tracemalloc over 2,000 and 10,000 cases), its task and its
#: result row.
CASE_BYTES = 2048


def _count(spec, roads, n_seeds, speeds, durations, steps) -> int:
    """Number of cases of a spec, from the lengths of its lists and the number of its seeds
    (nothing is sampled or expanded)."""
    bodies = 0
    for entry in _list(spec["body"]):
        n = entry.get("samples", 1) if isinstance(entry, dict) else 1
        bodies += n if isinstance(n, int) and not isinstance(n, bool) and n > 0 else 1
    return (
        len(roads)
        * n_seeds
        * len(speeds)
        * len(durations)
        * len(steps)
        * bodies
        * len(_list(spec["car"]))
        * len(_list(spec["seat"]))
    )


def _digest(net) -> str:
    """Hash of a model's content (topology and parameter values)."""
    text = json.dumps(network_to_dict(net), sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


class _Prepared:
    """A validated spec: the value lists of every key and the digests the case keys need."""

    def __init__(self, spec: dict, counted: Optional[Callable[[int], None]] = None):
        if not isinstance(spec, dict):
            raise BodyvibError("sweep spec must be a JSON object")
        unknown = sorted(set(spec) - set(SPEC_KEYS))
        if unknown:
            raise BodyvibError(
                f"spec: unknown key(s) {', '.join(unknown)}; keys are " + ", ".join(SPEC_KEYS)
            )
        for k, default in SPEC_KEYS.items():
            if default is None and k not in spec:
                raise BodyvibError(f"spec: '{k}' is required")
        spec = {**SPEC_KEYS, **spec}
        roads = [road_label(r) for r in _list(spec["road"])]
        road_opts = _road_options(spec["road_options"])
        speeds = [_number(v, "speed", "m/s") for v in _list(spec["speed"])]
        durations = [_number(v, "duration", "s") for v in _list(spec["duration"])]
        steps = [_number(v, "step", "s") for v in _list(spec["step"])]
        # counted before anything is expanded or sampled: a seed range of a billion is
        # refused here, in a moment, not after minutes of making a list
        count = _count(spec, roads, _seed_count(spec["seed"]), speeds, durations, steps)
        require_memory(
            count * CASE_BYTES,
            f"a sweep of {count:.3g} cases",
            "fewer cases (samples, seeds, speeds, roads), or several sweeps",
        )
        if counted is not None:  # the caller's head start (the sweep's workers)
            counted(count)
        seeds = [_number(s, "seed", "", integer=True) for s in _seed_list(spec["seed"])]
        for name, values in (
            ("road", roads),
            ("seed", seeds),
            ("speed", speeds),
            ("duration", durations),
            ("step", steps),
            ("body", _list(spec["body"])),
            ("car", _list(spec["car"])),
            ("seat", _list(spec["seat"])),
        ):
            if not values:
                raise BodyvibError(f"spec: '{name}' is an empty list")
        for r, sd, v, d, h in product(roads, seeds[:1], speeds, durations, steps):
            # refuses unknown roads and files that cannot be driven, steps longer than half a run
            options = RoadOptions(**dict(road_opts))
            check_settings(RunSettings(r, v, d, h, sd, road_options=options))
        self.roads, self.road_options = roads, road_opts
        self.road_digests = {r: _file_digest(r) for r in roads if is_road_file(r)}
        self.seeds, self.speeds, self.durations, self.steps = seeds, speeds, durations, steps
        self.bodies = _bodies(spec)
        self.cars = [
            str(c) if str(s) == NO_SEAT else car_with_seat(str(c), str(s))
            for c in _list(spec["car"])
            for s in _list(spec["seat"])
        ]
        linear = spec["linear"]
        if not isinstance(linear, bool):
            raise BodyvibError(f"spec: 'linear' must be true or false, not {linear!r}")
        self.linear = linear
        self.car_digests = {c: _digest(load_car(c, linear=linear)) for c in self.cars}
        base = {m: load_model(m) for m in dict.fromkeys(b[1] for b in self.bodies)}
        # the figures' step, of each car (linearized: its modes) and named body
        for net in (load_car(c, linear=True) for c in self.cars):
            check_study_step(max(steps), net, list(base.values()))
        self.body_digests = [
            _digest(base[m].with_parameters(**dict(v)) if v else base[m])
            for _, m, _, v in self.bodies
        ]
        # the same case twice: a repeated value in a list, or two bodies (cars) with one content
        for name, values in (
            ("road", self.roads),
            ("seed", seeds),
            ("speed", speeds),
            ("duration", durations),
            ("step", steps),
            ("body", self.body_digests),
            ("car", [self.car_digests[c] for c in self.cars]),
        ):
            seen: Dict[object, int] = {}
            for i, x in enumerate(values):
                if x in seen:
                    raise BodyvibError(
                        f"spec: '{name}' entries {seen[x]} and {i} give the same "
                        "cases (listed twice?)"
                    )
                seen[x] = i
        self.count = (
            len(roads)
            * len(seeds)
            * len(speeds)
            * len(durations)
            * len(steps)
            * len(self.bodies)
            * len(self.cars)
        )

    #: The run settings the product varies, outermost first (the fields of :meth:`_axes`).
    _AXIS_NAMES = ("road", "seed", "speed", "duration", "step")

    def _axes(self):
        return (self.roads, self.seeds, self.speeds, self.durations, self.steps)

    def case_at(self, case_id: int) -> Case:
        """The case at a product-order position (made from the spec, nothing stored)."""
        inner = len(self.bodies) * len(self.cars)
        i, j = divmod(int(case_id), inner)
        heads = self.__dict__.setdefault("_heads", {})  # settings and their JSON, bounded
        got = heads.get(i)
        if got is None:
            if len(heads) > 65536:
                heads.clear()
            out, k = [], i
            for a in reversed(self._axes()):
                k, pos = divmod(k, len(a))
                out.append(a[pos])
            run = dict(zip(self._AXIS_NAMES, out[::-1]))
            keyed = dict(run)
            if self.road_options:
                keyed["road_options"] = dict(self.road_options)
            if run["road"] in self.road_digests:  # a road file is its content, not its name
                keyed["road_file"] = self.road_digests[run["road"]]
            got = heads[i] = (run, json.dumps(keyed, sort_keys=True))
        run, head = got
        b, c = divmod(j, len(self.cars))
        bname, model, sample, values = self.bodies[b]
        car = self.cars[c]
        key = hashlib.sha256((head + self.body_digests[b] + self.car_digests[car]).encode())
        return Case(
            case_id=int(case_id),
            **run,
            body=bname,
            body_model=model,
            body_sample=sample,
            body_values=values,
            car=car,
            case_key=key.hexdigest()[:20],
            road_options=self.road_options,
            linear=self.linear,
        )

    def order(self, body_major: bool = False) -> Iterator[int]:
        """The case ids, one at a time, in the order cases are run.

        Product order (road, seed, speed, duration, step, body, car: consecutive
        cases share a road) or, with ``body_major``, body and car first
        (consecutive cases share a model); a ``case_id`` is the product-order
        position either way.
        """
        n_settings = math.prod(len(a) for a in self._axes())
        inner = len(self.bodies) * len(self.cars)
        if body_major:
            return (i * inner + j for j in range(inner) for i in range(n_settings))
        return iter(range(n_settings * inner))

    def cases(self, body_major: bool = False) -> Iterator[Case]:
        """The cases, made one at a time, in :meth:`order`."""
        return (self.case_at(k) for k in self.order(body_major))

    def __getstate__(self):  # sent to workers without the cache
        return {k: v for k, v in self.__dict__.items() if k != "_heads"}


def count_cases(spec: dict) -> int:
    """Number of cases of a spec, validated, without making them.

    Parameters
    ----------
    spec : dict
        A spec (keys in the module docstring), e.g. from :func:`load_spec`.

    Returns
    -------
    int
        The product of the numbers of roads, seeds, speeds, durations, steps, body
        parameter sets and cars.

    Raises
    ------
    BodyvibError
        As :func:`expand`.

    Examples
    --------
    >>> count_cases({"road": ["C", "D"], "speed": [10, 20], "seed": "0..24",
    ...              "body": "reduced-paper"})
    100
    """
    return _Prepared(spec).count


def iter_cases(spec: dict) -> Iterator[Case]:
    """The cases of a spec one at a time (validated first): a million cases in little memory.

    Parameters
    ----------
    spec : dict
        A spec (keys in the module docstring); the whole spec is checked, and every
        body and car loaded, before the iterator is returned.

    Returns
    -------
    iterator of Case
        In product order, as :func:`expand`.

    Raises
    ------
    BodyvibError
        As :func:`expand` (at the call, before the first case).
    """
    return _Prepared(spec).cases()


def expand(spec: dict) -> List[Case]:
    """All cases of a spec, validated.

    Parameters
    ----------
    spec : dict
        See the module docstring.

    Returns
    -------
    list of Case
        In product order (road, seed, speed, duration, step, body, car).

    Raises
    ------
    BodyvibError
        Unknown or missing keys, bad values, unknown roads, models or cars,
        bad ranges, a case listed twice; the message names the key. More cases than half
        the available memory can hold (:data:`CASE_BYTES` each), before any is made.

    Examples
    --------
    >>> cases = expand({"road": ["C", "D"], "speed": [10, 20], "body": "reduced-paper"})
    >>> len(cases), cases[-1].road, cases[-1].speed
    (4, 'D', 20.0)
    """
    return list(iter_cases(spec))


def _road_options(value) -> Tuple[Tuple[str, object], ...]:
    """``road_options`` of a spec as RoadOptions fields that differ from the defaults."""
    from ..road.contact import CONTACTS
    from ..road.driven import RoadOptions, renamed_road_options

    if not isinstance(value, dict):
        raise BodyvibError(
            'spec: \'road_options\' must be an object like {"taper_m": 5, "track_m": 0.8}'
        )
    value = renamed_road_options(value, "spec: road_options")
    unknown = sorted(set(value) - set(ROAD_OPTION_KEYS))
    if unknown:
        raise BodyvibError(
            f"spec: unknown road option(s) {', '.join(unknown)}; options are "
            + ", ".join(ROAD_OPTION_KEYS)
        )
    default = RoadOptions()
    out = []
    for k in ROAD_OPTION_KEYS:
        if k not in value:
            continue
        v = value[k]
        if k in ("taper_m", "track_m"):
            ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            if not ok or (k == "taper_m" and v < 0):
                raise BodyvibError(
                    f"spec: road option '{k}' must be a "
                    f"{'non-negative ' if k == 'taper_m' else ''}number of m, "
                    f"got {v!r}"
                )
            v = float(v)
        elif k in ("envelope", "repeat") and not isinstance(v, bool):
            raise BodyvibError(f"spec: road option '{k}' must be true or false, got {v!r}")
        elif k == "contact" and v not in CONTACTS:
            raise BodyvibError(
                f"spec: road option 'contact' must be one of {', '.join(CONTACTS)}, got {v!r}"
            )
        elif k == "units" and v is not None and not isinstance(v, str):
            raise BodyvibError(f"spec: road option 'units' must be text like \"m,mm\", got {v!r}")
        if v != getattr(default, k):
            out.append((k, v))
    return tuple(out)


def varied_parameters(cases: Sequence[Case]) -> List[str]:
    """Names of the body parameters varied anywhere in the cases, in first-seen order.

    Parameters
    ----------
    cases : sequence of Case
        From :func:`expand` or :func:`iter_cases`.

    Returns
    -------
    list of str
        Parameter names of the ``vary`` entries' models; empty when no body varies.

    Examples
    --------
    >>> varied_parameters(expand({"road": "C", "speed": 10, "body": [
    ...     {"model": "reduced-paper", "vary": {"c1": [0.5, 2]}, "samples": 2}]}))
    ['c1']
    """
    names: Dict[str, None] = {}
    for c in cases:
        for n, _ in c.body_values:
            names.setdefault(n, None)
    return list(names)
