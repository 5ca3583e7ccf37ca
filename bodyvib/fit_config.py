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

from .fit_space import GENES, PAIR_ROLES
from .models import MODEL_DIR
from .runtime.errors import BodyvibError
from .runtime.fileio import read_json

__all__ = [
    "DEFAULT_CONFIG_PATH",
    "POLISH_METHODS",
    "load_config",
    "parse_pairs",
]

#: The shipped default configuration (bounds, GA settings, quadrature).
DEFAULT_CONFIG_PATH = os.path.join(MODEL_DIR, "fit", "default-config.json")

#: Local polish methods of ``scipy.optimize.minimize`` that honour bounds.
POLISH_METHODS = ("L-BFGS-B", "TNC", "SLSQP", "Powell", "Nelder-Mead", "trust-constr")


def _merge(base: dict, over: dict, where: str) -> dict:
    out = copy.deepcopy(base)
    for k, v in over.items():
        if k not in base:
            raise BodyvibError(f"{where}: unknown key '{k}'; keys are {', '.join(base)}")
        if isinstance(base[k], dict) and k != "pairs":
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
        Keys ``pairs``, ``bounds_per_kg_total_mass``, ``ga``, ``polish``,
        ``quadrature``, ``time_domain``.

    Raises
    ------
    BodyvibError
        Unknown key, wrong type, a size or step that is not positive, an
        unknown polish method, or a bound that is not ``0 < low < high``
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

    ga = cfg["ga"]
    for k in ("restarts", "population", "generations", "parents_mating", "tournament_size",
              "elitism"):
        positive("ga", k, integer=True)
    if ga["parents_mating"] > ga["population"] or ga["elitism"] > ga["population"]:
        raise BodyvibError(f"{where}: ga.parents_mating and ga.elitism must not exceed "
                           "ga.population")
    positive("ga", "mutation_probability")
    positive("ga", "polynomial_mutation_eta")
    for k in ("parent_selection", "crossover", "mutation"):
        if not isinstance(ga[k], str):
            raise BodyvibError(f"{where}: ga.{k} must be the name of a PyGAD operator, "
                               f"got {ga[k]!r}")
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
