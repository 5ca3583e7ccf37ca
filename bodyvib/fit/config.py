"""Settings of the refit: the shipped default configuration, user overrides, pairs.

A configuration is a JSON document (``bodyvib/data/fit/default-config.json``):
search bounds of the genes, the genetic algorithm's settings, the polish, the
quadrature grid of the frequency-domain objective and the time-domain horizon.
A user's file overrides any subset of it; every value is checked here, before
the search starts, so a typo costs nothing.
"""

import copy
import math
import os
from typing import Dict, Optional

import numpy as np

from .methods import COORDINATES, METHODS
from .space import GENES, PAIR_ROLES
from ..models import MODEL_DIR
from ..runtime.errors import BodyvibError
from ..runtime.jsonfile import read_json

__all__ = [
    "DEFAULT_CONFIG_PATH",
    "POLISH_METHODS",
    "DE_STRATEGIES",
    "load_config",
    "log_bounds",
    "parse_pairs",
]

#: The shipped default configuration (bounds, GA settings, quadrature).
DEFAULT_CONFIG_PATH = os.path.join(MODEL_DIR, "fit", "default-config.json")

#: Local polish methods of ``scipy.optimize.minimize`` that honour bounds.
POLISH_METHODS = ("L-BFGS-B", "TNC", "SLSQP", "Powell", "Nelder-Mead", "trust-constr")

#: Strategies of ``scipy.optimize.differential_evolution`` (``de.strategy``).
DE_STRATEGIES = ("best1bin", "best1exp", "rand1bin", "rand1exp", "rand2bin", "rand2exp",
                 "randtobest1bin", "randtobest1exp", "currenttobest1bin", "currenttobest1exp",
                 "best2bin", "best2exp")


def _merge(base: dict, over: dict, where: str) -> dict:
    out = copy.deepcopy(base)
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
    return data


def load_config(path=None, overrides: Optional[dict] = None) -> dict:
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
    dict
        Keys ``pairs``, ``bounds_per_kg_total_mass``, ``method`` (the search:
        ``ga``, ``cmaes`` or ``de``), ``restarts`` (``{"model": N, "measured":
        N}``; an integer in a file sets both), one section per method
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
    >>> cfg["ga"]["generations"], cfg["bounds_per_kg_total_mass"]["m1"]
    (5, [0.02, 0.4])
    """
    cfg = _read_json(DEFAULT_CONFIG_PATH)
    cfg.pop("description", None)
    if path is not None:
        user = _read_json(os.fspath(path))
        user.pop("description", None)
        cfg = _merge(cfg, user, os.fspath(path))
    if overrides:
        cfg = _merge(cfg, overrides, "configuration")
    where = os.fspath(path) if path is not None else "configuration"
    pairs = cfg["pairs"]
    if not isinstance(pairs, dict):
        raise BodyvibError(f"{where}: 'pairs' must be an object of role: weight")
    cfg["pairs"] = parse_pairs(",".join(f"{k}={v}" for k, v in pairs.items()))
    bounds = cfg["bounds_per_kg_total_mass"]
    for g in GENES:
        b = bounds.get(g)
        ok = (isinstance(b, list) and len(b) == 2
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in b)
              and all(math.isfinite(v) for v in b) and 0 < b[0] < b[1])
        if not ok:
            raise BodyvibError(f"{where}: bounds_per_kg_total_mass.{g} must be [low, high] with "
                               f"0 < low < high, got {b!r}")
    if bounds["m1"][1] >= 1:
        raise BodyvibError(f"{where}: bounds_per_kg_total_mass.m1 is the head's fraction of the "
                           "total mass and must stay below 1")

    def positive(section, key, integer=False):
        v = cfg[section][key]
        kind = int if integer else (int, float)
        if isinstance(v, bool) or not isinstance(v, kind) or not (math.isfinite(v) and v > 0):
            raise BodyvibError(f"{where}: {section}.{key} must be a positive "
                               f"{'integer' if integer else 'number'}, got {v!r}")

    if cfg["method"] not in METHODS:
        raise BodyvibError(f"{where}: method must be one of {', '.join(METHODS)}, "
                           f"got {cfg['method']!r}")
    r = cfg["restarts"]
    if isinstance(r, int) and not isinstance(r, bool):
        r = cfg["restarts"] = {"model": r, "measured": r}
    if not (isinstance(r, dict) and set(r) == {"model", "measured"} and all(
            isinstance(v, int) and not isinstance(v, bool) and v >= 1 for v in r.values())):
        raise BodyvibError(f"{where}: restarts must be a positive integer or "
                           '{"model": N, "measured": N} (reference model / measured data), '
                           f"got {cfg['restarts']!r}")
    for k in ("population", "generations", "tournament_size", "elitism", "stall_generations"):
        positive("ga", k, integer=True)
    if cfg["ga"]["elitism"] >= cfg["ga"]["population"]:
        raise BodyvibError(f"{where}: ga.elitism must be below ga.population")
    for k in ("crossover_eta", "mutation_probability", "mutation_scale", "ftol"):
        positive("ga", k)
    for k in ("max_evaluations", "stall_generations"):
        positive("cmaes", k, integer=True)
    positive("cmaes", "sigma0")
    positive("cmaes", "ftol")
    p = cfg["cmaes"]["population"]
    if isinstance(p, bool) or not isinstance(p, int) or p < 0:
        raise BodyvibError(f"{where}: cmaes.population must be a non-negative integer (0: "
                           f"CMA-ES's default), got {p!r}")
    for k in ("population_per_gene", "generations"):
        positive("de", k, integer=True)
    positive("de", "tol")
    positive("de", "recombination")
    mut = cfg["de"]["mutation"]
    if not (isinstance(mut, list) and len(mut) == 2 and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in mut)
            and 0 <= mut[0] <= mut[1] < 2):
        raise BodyvibError(f"{where}: de.mutation must be [low, high] with 0 <= low <= high < 2, "
                           f"got {mut!r}")
    if cfg["de"]["strategy"] not in DE_STRATEGIES:
        raise BodyvibError(f"{where}: de.strategy must be one of {', '.join(DE_STRATEGIES)}, "
                           f"got {cfg['de']['strategy']!r}")
    for k in ("population", "generations"):
        positive("pareto", k, integer=True)
    positive("pareto", "crossover_eta")
    positive("pareto", "mutation_eta")
    for m in METHODS:
        if cfg[m]["coordinates"] not in COORDINATES:
            raise BodyvibError(f"{where}: {m}.coordinates must be one of "
                               f"{', '.join(COORDINATES)}, got {cfg[m]['coordinates']!r}")
    pol = cfg["polish"]
    if not isinstance(pol["enabled"], bool):
        raise BodyvibError(f"{where}: polish.enabled must be true or false")
    if pol["method"] not in POLISH_METHODS:
        raise BodyvibError(f"{where}: polish.method must be one of {', '.join(POLISH_METHODS)} "
                           f"(bounded scipy.optimize.minimize methods), got {pol['method']!r}")
    positive("polish", "max_iterations", integer=True)
    for k in ("f_first_panel_hz", "f_split_hz"):
        positive("quadrature", k)
    for k in ("panels", "nodes_per_panel", "tail_nodes"):
        positive("quadrature", k, integer=True)
    q = cfg["quadrature"]
    if not q["f_first_panel_hz"] < q["f_split_hz"]:
        raise BodyvibError(f"{where}: quadrature needs 0 < f_first_panel_hz < f_split_hz")
    positive("time_domain", "dt_s")
    positive("time_domain", "decay_time_constants")
    return cfg


def log_bounds(cfg: dict):
    """Bounds of the genes (``log10`` of the ratios per kg of total mass).

    Parameters
    ----------
    cfg : dict
        As :func:`load_config`.

    Returns
    -------
    lo, hi : ndarray, shape (6,)
        In :data:`bodyvib.fit.space.GENES` order.
    """
    b = cfg["bounds_per_kg_total_mass"]
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

    Raises
    ------
    BodyvibError
        Unknown role, repeated role, or a weight that is not a positive number.

    Examples
    --------
    >>> parse_pairs("head=1,torso=0.5")
    {'head': 1.0, 'torso': 0.5}
    """
    out: Dict[str, float] = {}
    for item in (t.strip() for t in text.split(",")):
        if not item:
            continue
        role, _, w = item.partition("=")
        role = role.strip()
        if role not in PAIR_ROLES:
            raise BodyvibError(f"pairs: unknown role '{role}'; roles are "
                               f"{', '.join(PAIR_ROLES)} (e.g. head=1,torso=0.5)")
        if role in out:
            raise BodyvibError(f"pairs: role '{role}' given twice")
        try:
            weight = float(w) if w.strip() else 1.0
        except ValueError:
            raise BodyvibError(f"pairs: weight of '{role}' is not a number: {w!r}") from None
        if not (math.isfinite(weight) and weight > 0):
            raise BodyvibError(f"pairs: weight of '{role}' must be positive, got {w}")
        out[role] = weight
    if not out:
        raise BodyvibError("pairs: give at least one role=weight, e.g. head=1")
    return out
