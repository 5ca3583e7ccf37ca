"""Settings of the refit: the shipped default configuration, user overrides, pairs.

A configuration is a JSON document (``bodyvib/data/fit/default-config.json``):
search bounds of the genes, the genetic algorithm's settings, the polish, the
quadrature grid of the frequency-domain objective and the time-domain horizon.
A user's file overrides any subset of it; every value is checked here, before
the search starts, so a typo costs nothing. :func:`load_config` gives a frozen
:class:`FitConfig`; its ``to_dict()`` is the JSON form.
"""

import copy
import functools
import math
import os
from dataclasses import dataclass, fields
from typing import Dict, Mapping, Optional, Tuple

import numpy as np

from ..models import MODEL_DIR
from ..runtime.errors import BodyvibError
from ..runtime.jsonfile import read_json
from ..runtime.renames import warn_renamed
from .methods import COORDINATES, METHODS
from .space import GENES, PAIR_ROLES

__all__ = [
    "DEFAULT_CONFIG_PATH",
    "POLISH_METHODS",
    "DE_STRATEGIES",
    "FitConfig",
    "GaSettings",
    "CmaesSettings",
    "DeSettings",
    "ParetoSettings",
    "PolishSettings",
    "QuadratureSettings",
    "TimeDomainSettings",
    "Restarts",
    "load_config",
    "log_bounds",
    "parse_pairs",
]
#: The shipped default configuration (bounds, GA settings, quadrature).
DEFAULT_CONFIG_PATH = os.path.join(MODEL_DIR, "fit", "default-config.json")

#: Local polish methods of ``scipy.optimize.minimize`` that honour bounds.
POLISH_METHODS = ("L-BFGS-B", "TNC", "SLSQP", "Powell", "Nelder-Mead", "trust-constr")

#: Strategies of ``scipy.optimize.differential_evolution`` (``de.strategy``).
DE_STRATEGIES = (
    "best1bin",
    "best1exp",
    "rand1bin",
    "rand1exp",
    "rand2bin",
    "rand2exp",
    "randtobest1bin",
    "randtobest1exp",
    "currenttobest1bin",
    "currenttobest1exp",
    "best2bin",
    "best2exp",
)


class _Section:
    """A section of the configuration: its JSON form, keys in the file's order."""

    def to_dict(self) -> dict:
        """The section as in the JSON file."""
        return {
            f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v)
            for f in fields(self)
        }


@dataclass(frozen=True)
class GaSettings(_Section):
    """The genetic algorithm (``ga``): :func:`bodyvib.fit.methods.ga_search`."""

    population: int
    generations: int
    tournament_size: int
    elitism: int
    crossover_eta: float
    mutation_probability: float
    mutation_scale: float
    ftol: float
    stall_generations: int
    coordinates: str


@dataclass(frozen=True)
class CmaesSettings(_Section):
    """CMA-ES (``cmaes``): :func:`bodyvib.fit.methods.cmaes_search`; population 0: its default."""

    sigma0: float
    population: int
    max_evaluations: int
    ftol: float
    stall_generations: int
    coordinates: str


@dataclass(frozen=True)
class DeSettings(_Section):
    """Differential evolution (``de``): :func:`bodyvib.fit.methods.de_search`."""

    population_per_gene: int
    generations: int
    tol: float
    strategy: str
    mutation: Tuple[float, float]
    recombination: float
    coordinates: str


@dataclass(frozen=True)
class ParetoSettings(_Section):
    """NSGA-II of ``bodyvib fit --pareto`` (``pareto``): :func:`bodyvib.fit.pareto.pareto_front`."""

    population: int
    generations: int
    crossover_eta: float
    mutation_eta: float


@dataclass(frozen=True)
class PolishSettings(_Section):
    """The local polish after each search (``polish``)."""

    enabled: bool
    method: str
    max_iterations: int


@dataclass(frozen=True)
class QuadratureSettings(_Section):
    """The frequency grid of the objective (``quadrature``):
    :func:`bodyvib.fit.objective.quadrature_grid`'s arguments."""

    f_first_panel_hz: float
    f_split_hz: float
    panels: int
    nodes_per_panel: int
    tail_nodes: int


@dataclass(frozen=True)
class TimeDomainSettings(_Section):
    """The time-domain form of the objective (``time_domain``)."""

    step: float
    decay_time_constants: float


@dataclass(frozen=True)
class Restarts(_Section):
    """Independent searches per target kind: a reference ``model`` or ``measured`` data."""

    model: int
    measured: int


_SECTIONS = {
    "ga": GaSettings,
    "cmaes": CmaesSettings,
    "de": DeSettings,
    "pareto": ParetoSettings,
    "polish": PolishSettings,
    "quadrature": QuadratureSettings,
    "time_domain": TimeDomainSettings,
}


@dataclass(frozen=True)
class FitConfig:
    """The refit's settings, checked (:func:`load_config`).

    Attributes
    ----------
    pairs : mapping of str to float
        Role (``head``, ``torso``) -> weight in the objective.
    bounds_per_kg_total_mass : mapping of str to (float, float)
        Gene (:data:`bodyvib.fit.space.GENES`) -> ``(low, high)``, per kg of total mass.
    method : str
        The search: ``ga``, ``cmaes`` or ``de``.
    restarts : Restarts
    ga, cmaes, de : GaSettings, CmaesSettings, DeSettings
        Each method's settings.
    pareto : ParetoSettings
    polish : PolishSettings
    quadrature : QuadratureSettings
    time_domain : TimeDomainSettings
    """

    pairs: Mapping[str, float]
    bounds_per_kg_total_mass: Mapping[str, Tuple[float, float]]
    method: str
    restarts: Restarts
    ga: GaSettings
    cmaes: CmaesSettings
    de: DeSettings
    pareto: ParetoSettings
    polish: PolishSettings
    quadrature: QuadratureSettings
    time_domain: TimeDomainSettings

    def settings(self, method: str):
        """The settings section of a search method (``ga``, ``cmaes`` or ``de``).

        Raises
        ------
        BodyvibError
            Not a search method.
        """
        if method not in METHODS:
            raise BodyvibError(
                f"unknown search method '{method}'; methods are {', '.join(METHODS)}"
            )
        return getattr(self, method)

    def to_dict(self) -> dict:
        """The configuration as a JSON document (the file's keys, without ``description``)."""
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "bounds_per_kg_total_mass":
                v = {g: list(b) for g, b in v.items()}
            elif isinstance(v, Mapping):
                v = dict(v)
            elif isinstance(v, _Section):
                v = v.to_dict()
            out[f.name] = v
        return out


#: Keys renamed (section -> old key -> new key): a file with an old key still loads, warned.
RENAMED_KEYS = {"time_domain": {"dt_s": "step"}}


def _merge(base: dict, over: dict, where: str) -> dict:
    out = copy.deepcopy(base)
    section = where.rpartition(": ")[2]
    for old, new in RENAMED_KEYS.get(section, {}).items():
        if old in over and new not in over:
            warn_renamed(where, old, new, stacklevel=4)
            over = {new if k == old else k: v for k, v in over.items()}
    for k, v in over.items():
        if k not in base:
            raise BodyvibError(f"{where}: unknown key '{k}'; keys are {', '.join(base)}")
        if isinstance(base[k], dict) and k != "pairs" and (k != "restarts" or isinstance(v, dict)):
            if not isinstance(v, dict):
                raise BodyvibError(f"{where}: '{k}' must be an object")
            out[k] = _merge(base[k], v, f"{where}: {k}")
        else:
            out[k] = v
    return out


def _read_json(path: str) -> dict:
    data = read_json(path, "configuration")
    if not isinstance(data, dict):
        raise BodyvibError(f"{path}: expected a JSON object")
    data.pop("description", None)
    return data


# Read once per process: the shipped file does not change while bodyvib runs, and every
# objective built without a configuration would otherwise read and check it again.
# Callers get a deep copy (the merge below edits its own).
@functools.lru_cache(maxsize=1)
def _default_document() -> dict:
    return _read_json(DEFAULT_CONFIG_PATH)


def load_config(path=None, overrides: Optional[dict] = None) -> FitConfig:
    """The fit configuration: shipped defaults, then a user file, then overrides.

    Parameters
    ----------
    path : str or os.PathLike, optional
        A JSON file with any subset of the keys of the shipped
        ``bodyvib/data/fit/default-config.json``.
    overrides : dict, optional
        Nested dictionary applied last (tests use small GA settings this way).

    Returns
    -------
    FitConfig
        ``pairs``, ``bounds_per_kg_total_mass``, ``method`` (the search:
        ``ga``, ``cmaes`` or ``de``), ``restarts`` (``model`` and ``measured``;
        an integer in a file sets both), one section per method
        (``ga``, ``cmaes``, ``de``), ``pareto`` (NSGA-II), ``polish``, ``quadrature``,
        ``time_domain``.

    Raises
    ------
    BodyvibError
        Unknown key, wrong type, a size or step that is not positive, an
        unknown method, polish method or coordinates, or a bound that is not ``0 < low < high``
        (``m1`` also below 1, a fraction of the total mass).

    Examples
    --------
    >>> cfg = load_config(overrides={"ga": {"generations": 5}})
    >>> cfg.ga.generations, cfg.bounds_per_kg_total_mass["m1"]
    (5, (0.02, 0.4))
    """
    cfg = copy.deepcopy(_default_document())
    if path is not None:
        cfg = _merge(cfg, _read_json(os.fspath(path)), os.fspath(path))
    if overrides:
        cfg = _merge(cfg, overrides, "configuration")
    check = _Check(cfg, os.fspath(path) if path is not None else "configuration")
    for section in _CHECKS:
        section(check)
    return FitConfig(
        pairs=cfg["pairs"],
        bounds_per_kg_total_mass={g: tuple(b) for g, b in cfg["bounds_per_kg_total_mass"].items()},
        method=cfg["method"],
        restarts=Restarts(**cfg["restarts"]),
        **{
            name: section(
                **{k: (tuple(v) if isinstance(v, list) else v) for k, v in cfg[name].items()}
            )
            for name, section in _SECTIONS.items()
        },
    )


class _Check:
    """The merged document of :func:`load_config` and the checks its sections share."""

    def __init__(self, cfg: dict, where: str):
        self.cfg, self.where = cfg, where

    def fail(self, message: str):
        raise BodyvibError(f"{self.where}: {message}")

    def positive(self, section: str, *keys: str, integer: bool = False):
        kind = int if integer else (int, float)
        for key in keys:
            v = self.cfg[section][key]
            if isinstance(v, bool) or not isinstance(v, kind) or not (math.isfinite(v) and v > 0):
                self.fail(
                    f"{section}.{key} must be a positive "
                    f"{'integer' if integer else 'number'}, got {v!r}"
                )

    def one_of(self, name: str, value, choices, note: str = ""):
        if value not in choices:
            self.fail(f"{name} must be one of {', '.join(choices)}{note}, got {value!r}")


def _check_pairs(check: _Check):
    pairs = check.cfg["pairs"]
    if not isinstance(pairs, dict):
        check.fail("'pairs' must be an object of role: weight")
    check.cfg["pairs"] = check_pairs(pairs.items())


def _check_bounds(check: _Check):
    bounds = check.cfg["bounds_per_kg_total_mass"]
    for g in GENES:
        b = bounds.get(g)
        ok = (
            isinstance(b, list)
            and len(b) == 2
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in b)
            and all(math.isfinite(v) for v in b)
            and 0 < b[0] < b[1]
        )
        if not ok:
            check.fail(
                f"bounds_per_kg_total_mass.{g} must be [low, high] with 0 < low < high, got {b!r}"
            )
    if bounds["m1"][1] >= 1:
        check.fail(
            "bounds_per_kg_total_mass.m1 is the head's fraction of the "
            "total mass and must stay below 1"
        )


def _check_method(check: _Check):
    check.one_of("method", check.cfg["method"], METHODS)


def _check_restarts(check: _Check):
    r = check.cfg["restarts"]
    if isinstance(r, int) and not isinstance(r, bool):
        r = check.cfg["restarts"] = {"model": r, "measured": r}
    if not (
        isinstance(r, dict)
        and set(r) == {"model", "measured"}
        and all(isinstance(v, int) and not isinstance(v, bool) and v >= 1 for v in r.values())
    ):
        check.fail(
            "restarts must be a positive integer or "
            '{"model": N, "measured": N} (reference model / measured data), '
            f"got {check.cfg['restarts']!r}"
        )


def _check_ga(check: _Check):
    check.positive(
        "ga",
        "population",
        "generations",
        "tournament_size",
        "elitism",
        "stall_generations",
        integer=True,
    )
    if check.cfg["ga"]["elitism"] >= check.cfg["ga"]["population"]:
        check.fail("ga.elitism must be below ga.population")
    check.positive("ga", "crossover_eta", "mutation_probability", "mutation_scale", "ftol")


def _check_cmaes(check: _Check):
    check.positive("cmaes", "max_evaluations", "stall_generations", integer=True)
    check.positive("cmaes", "sigma0", "ftol")
    p = check.cfg["cmaes"]["population"]
    if isinstance(p, bool) or not isinstance(p, int) or p < 0:
        check.fail(
            f"cmaes.population must be a non-negative integer (0: CMA-ES's default), got {p!r}"
        )


def _check_de(check: _Check):
    check.positive("de", "population_per_gene", "generations", integer=True)
    check.positive("de", "tol", "recombination")
    mut = check.cfg["de"]["mutation"]
    if not (
        isinstance(mut, list)
        and len(mut) == 2
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in mut)
        and 0 <= mut[0] <= mut[1] < 2
    ):
        check.fail(f"de.mutation must be [low, high] with 0 <= low <= high < 2, got {mut!r}")
    check.one_of("de.strategy", check.cfg["de"]["strategy"], DE_STRATEGIES)


def _check_pareto(check: _Check):
    check.positive("pareto", "population", "generations", integer=True)
    check.positive("pareto", "crossover_eta", "mutation_eta")


def _check_coordinates(check: _Check):
    for m in METHODS:
        check.one_of(f"{m}.coordinates", check.cfg[m]["coordinates"], COORDINATES)


def _check_polish(check: _Check):
    pol = check.cfg["polish"]
    if not isinstance(pol["enabled"], bool):
        check.fail("polish.enabled must be true or false")
    check.one_of(
        "polish.method", pol["method"], POLISH_METHODS, " (bounded scipy.optimize.minimize methods)"
    )
    check.positive("polish", "max_iterations", integer=True)


def _check_quadrature(check: _Check):
    check.positive("quadrature", "f_first_panel_hz", "f_split_hz")
    check.positive("quadrature", "panels", "nodes_per_panel", "tail_nodes", integer=True)
    q = check.cfg["quadrature"]
    if not q["f_first_panel_hz"] < q["f_split_hz"]:
        check.fail("quadrature needs 0 < f_first_panel_hz < f_split_hz")


def _check_time_domain(check: _Check):
    check.positive("time_domain", "step", "decay_time_constants")


#: The checks of :func:`load_config`, one per section of the document, in this order
#: (the first error found is the one reported).
_CHECKS = (
    _check_pairs,
    _check_bounds,
    _check_method,
    _check_restarts,
    _check_ga,
    _check_cmaes,
    _check_de,
    _check_pareto,
    _check_coordinates,
    _check_polish,
    _check_quadrature,
    _check_time_domain,
)


def log_bounds(cfg: FitConfig):
    """Bounds of the genes (``log10`` of the ratios per kg of total mass).

    Parameters
    ----------
    cfg : FitConfig
        As :func:`load_config` returns it; its ``bounds_per_kg_total_mass`` are used.

    Returns
    -------
    lo, hi : ndarray, shape (6,)
        In :data:`bodyvib.fit.space.GENES` order.
    """
    b = cfg.bounds_per_kg_total_mass
    return np.log10([b[g][0] for g in GENES]), np.log10([b[g][1] for g in GENES])


def parse_pairs(text: str) -> Dict[str, float]:
    """Parse position pairs ``"head=1,torso=0.5"`` into ``{role: weight}``.

    Parameters
    ----------
    text : str
        Comma-separated ``role=weight`` (a bare ``role`` means weight 1).
        Roles: ``head`` (reduced m1 with the reference's head) and ``torso``
        (reduced m2 with the reference's torso).

    Returns
    -------
    dict of str to float
        As :func:`check_pairs`, which raises on bad pairs.

    Examples
    --------
    >>> parse_pairs("head=1,torso=0.5")
    {'head': 1.0, 'torso': 0.5}
    """
    items = []
    for item in (t.strip() for t in text.split(",")):
        if item:
            role, _, w = item.partition("=")
            items.append((role.strip(), w.strip() or 1.0))
    return check_pairs(items)


def check_pairs(items) -> Dict[str, float]:
    """Check ``(role, weight)`` pairs (a configuration's ``pairs`` or ``--pairs``).

    Parameters
    ----------
    items : iterable of (str, float or str)

    Returns
    -------
    dict of str to float

    Raises
    ------
    BodyvibError
        Unknown role, repeated role, or a weight that is not a positive number.

    Examples
    --------
    >>> check_pairs([("head", 1), ("torso", "0.5")])
    {'head': 1.0, 'torso': 0.5}
    """
    out: Dict[str, float] = {}
    for role, w in items:
        if role not in PAIR_ROLES:
            raise BodyvibError(
                f"pairs: unknown role '{role}'; roles are "
                f"{', '.join(PAIR_ROLES)} (e.g. head=1,torso=0.5)"
            )
        if role in out:
            raise BodyvibError(f"pairs: role '{role}' given twice")
        try:
            if isinstance(w, bool):
                raise ValueError
            weight = float(w)
        except (TypeError, ValueError):
            raise BodyvibError(f"pairs: weight of '{role}' is not a number: {w!r}") from None
        if not (math.isfinite(weight) and weight > 0):
            raise BodyvibError(f"pairs: weight of '{role}' must be positive, got {w}")
        out[role] = weight
    if not out:
        raise BodyvibError("pairs: give at least one role=weight, e.g. head=1")
    return out
