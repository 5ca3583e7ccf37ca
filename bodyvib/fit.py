"""Refit the reduced 3-DOF model by a genetic algorithm: the paper's Eq. 3.

The objective (Balci & Gundogdu 2025, Eq. 3) is the summed squared difference
between the impulse responses of mass positions of a reference model and of
the reduced model. Precisely, for an impulse of seat displacement,
``x_seat(t) = delta(t)`` (1 m s), the position of mass ``p`` responds with
``h_p(t)`` (1/s, the impulse response of the transmissibility ``X_p/X_seat``),
and

    J = sum_p w_p  int_0^inf (h_ref,p(t) - h_red,p(t))^2 dt        [1/s]

over the pairs ``p`` of mass positions: the reduced model's head m1 with the
reference's head, its torso m2 with the reference's torso (ISO m3). By default
both, weight 1 each: the paper's "positions of the masses". The head alone
(``pairs={"head": 1}``) does not identify the head mass: the objective keeps
falling as it grows, so the head mass runs to a bound of the search, and with
a narrower bound the best fit flips to a 3 kg head on a 72 kg torso with a
15-19 Hz seat mode, whose seat force is far from the reference's (README,
"Refitting the reduced model"). This time-domain form
is the *definition* (:func:`objective_time_domain`: exact samples
``C e^{A t_k} b`` of both state spaces, trapezoid rule). By Parseval the same
number is

    J = sum_p w_p (1/pi) int_0^inf |H_ref,p(jw) - H_red,p(jw)|^2 dw
      = sum_p w_p 2 int_0^inf |H_ref,p(j 2 pi f) - H_red,p(j 2 pi f)|^2 df,

which the search uses (:class:`FitTarget`): the reduced model's analytic
transfer functions (:mod:`bodyvib.analytic`) on a fixed quadrature grid
(:func:`quadrature_grid`), the whole population in one call.

**Scale.** Multiplying every m, k and c of the reduced model by one factor
leaves every transmissibility unchanged, so the fit cannot find the absolute
scale. It searches the six ratios ``m1/M, k1/M, k2/M, ks/M, c1/M, c2/M``
(log-uniform within bounds from the configuration) with the total mass
``M = m1 + m2`` pinned to the reference's static apparent mass (75.0 kg for
``iso7962``), or to ``total_mass`` for measured data (75 kg by default). The
seat force, which is what a car feels in a two-way coupling, is then right
at low frequency.

**Measured data.** For a user's seat-to-head transmissibility
(:mod:`bodyvib.measured`) the same integral is restricted to the measured
band, by the trapezoid rule on the measured frequencies: the complex
difference when the phase is given, the difference of moduli when it is not.

The genetic algorithm is PyGAD's (``pygad.GA``): real-coded, seeded, batch
fitness (the whole population per call), a progress bar; an optional local
polish (``scipy.optimize.minimize``, L-BFGS-B in the same log-space, bounded)
starts from the GA's best. :func:`write_parameter_file` writes the result as
a parameter file of the reduced model, with its provenance, that
``load_model``, ``bodyvib frf --models`` and ``build_fmu.py --params`` read.
"""

import copy
import datetime
import logging
import math
import os
import sys
import time
from dataclasses import dataclass, field, replace
from typing import Dict, List, Mapping, Optional

import numpy as np

from . import __version__
from .analytic import head_transmissibility, torso_transmissibility
from .errors import BodyvibError
from .fileio import read_json
from .models import MODEL_DIR, load_model, save_model
from .network import Network

__all__ = [
    "REDUCED_PARAMETERS",
    "GENES",
    "DEFAULT_CONFIG_PATH",
    "POLISH_METHODS",
    "load_config",
    "parse_pairs",
    "quadrature_grid",
    "MAX_SAMPLES",
    "DEFAULT_MEASURED_TOTAL_MASS",
    "default_horizon",
    "impulse_response",
    "objective_time_domain",
    "objective_frequency_domain",
    "FitTarget",
    "model_target",
    "measured_target",
    "parameter_array",
    "genes_to_parameters",
    "parameters_to_genes",
    "FitResult",
    "fit",
    "reduced_network",
    "write_parameter_file",
    "add_command",
]

#: Parameters of the reduced model, in the order of :mod:`bodyvib.analytic`.
REDUCED_PARAMETERS = ("m1", "m2", "k1", "k2", "c1", "c2", "ks")

#: The searched quantities, each per kg of total mass M = m1 + m2 (log10 in the GA).
GENES = ("m1", "k1", "k2", "ks", "c1", "c2")

#: The shipped default configuration (bounds, GA settings, quadrature).
DEFAULT_CONFIG_PATH = os.path.join(MODEL_DIR, "fit", "default-config.json")

#: The reduced model's analytic position responses, by role.
_REDUCED_TF = {"head": head_transmissibility, "torso": torso_transmissibility}

#: Local polish methods of ``scipy.optimize.minimize`` that honour bounds.
POLISH_METHODS = ("L-BFGS-B", "TNC", "SLSQP", "Powell", "Nelder-Mead", "trust-constr")

#: Total mass (kg) pinned for measured data unless the user gives one.
DEFAULT_MEASURED_TOTAL_MASS = 75.0


# --------------------------------------------------------------------------
# configuration
# --------------------------------------------------------------------------
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
        if role not in _REDUCED_TF:
            raise BodyvibError(f"pairs: unknown role '{role}'; roles are "
                               f"{', '.join(_REDUCED_TF)} (e.g. head=1,torso=0.5)")
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


# --------------------------------------------------------------------------
# the objective: time domain (definition) and frequency domain (Parseval)
# --------------------------------------------------------------------------
def quadrature_grid(f_first_panel_hz=0.05, f_split_hz=50.0, panels=30, nodes_per_panel=6,
                    tail_nodes=16, **_ignored):
    """Nodes and weights for ``int_0^inf g(f) df`` of a smooth, decaying ``g``.

    Gauss-Legendre panels on ``[0, f_first]`` and on ``panels - 1``
    logarithmically spaced intervals up to ``f_split``; the tail
    ``[f_split, inf)`` is mapped onto ``u in (0, 1]`` by ``f = f_split/u``
    (``df = f_split du / u^2``) and integrated by Gauss-Legendre there, which
    is exact in the limit for the ``f^-6`` decay of ``|H|^2`` of a transfer
    function with relative degree 3 (the reduced model's X1/Xr).

    Parameters
    ----------
    f_first_panel_hz, f_split_hz : float
        End of the first panel and start of the mapped tail, Hz.
    panels, nodes_per_panel, tail_nodes : int
        Panels below ``f_split`` (including the first), Gauss nodes per panel,
        Gauss nodes of the tail.

    Returns
    -------
    f : ndarray
        Nodes in Hz (all finite and positive).
    w : ndarray
        Weights in Hz.

    Examples
    --------
    >>> f, w = quadrature_grid()
    >>> g = 1 / (1 + f ** 2) ** 2          # int_0^inf = pi/4
    >>> bool(abs(w @ g - np.pi / 4) < 1e-9)
    True
    """
    x, wx = np.polynomial.legendre.leggauss(int(nodes_per_panel))
    edges = np.concatenate([[0.0], np.geomspace(f_first_panel_hz, f_split_hz, int(panels))])
    a, b = edges[:-1, None], edges[1:, None]
    f = ((a + b) / 2 + (b - a) / 2 * x).ravel()
    w = ((b - a) / 2 * wx).ravel()
    xt, wt = np.polynomial.legendre.leggauss(int(tail_nodes))
    u, wu = (xt + 1) / 2, wt / 2
    f = np.concatenate([f, f_split_hz / u[::-1]])
    w = np.concatenate([w, (wu * f_split_hz / u ** 2)[::-1]])
    return f, w


def _displacement_statespace(model, point: str):
    """``(A, b, c)`` with ``h(t) = c e^{At} b`` the position impulse response."""
    from .frequency import displacement_input_statespace
    from .network import as_linear_model

    lm = as_linear_model(model)
    ss = displacement_input_statespace(lm)
    i = lm.output_index(f"{point}.x")
    d = float(np.asarray(ss.D)[i, 0])
    if d != 0.0:
        raise BodyvibError(f"{point} position of '{lm.network.name}' moves with the seat "
                           "instantly; its impulse response is not square integrable")
    return np.asarray(ss.A), np.asarray(ss.B)[:, 0], np.asarray(ss.C)[i]


def default_horizon(*models, time_constants: float = 40.0) -> float:
    """A time after which every model's impulse response has died out, s.

    ``time_constants / min |Re(pole)|``: with the default 40, the squared
    response has decayed by e^-80 relative to its size at the start.

    Parameters
    ----------
    *models : Network or LinearModel
        The models.
    time_constants : float
        How many time constants of the slowest pole.

    Returns
    -------
    float
        Horizon in s.

    Raises
    ------
    BodyvibError
        If a model is not asymptotically stable.
    """
    from .network import as_linear_model

    sigma = min(float(np.min(-np.linalg.eigvals(as_linear_model(m).A).real)) for m in models)
    if sigma <= 0:
        raise BodyvibError("a model is not asymptotically stable; its impulse response "
                           "does not decay")
    return time_constants / sigma


def impulse_response(model, t_end: float, dt: float, point: str = "head"):
    """Exact samples of a position's response to a unit impulse of seat displacement.

    ``h(t_k) = c e^{A t_k} b`` at ``t_k = k dt`` (the state space driven by
    seat displacement alone, :func:`bodyvib.frequency.displacement_input_statespace`),
    the matrix exponential from :func:`bodyvib.discretize.expm`. Exact at the
    samples for any stiffness (the ISO model's fastest pole is -1.1e8 1/s).

    Parameters
    ----------
    model : Network or LinearModel
    t_end : float
        Horizon in s.
    dt : float
        Sample spacing in s.
    point : str
        Role or mass name.

    Returns
    -------
    t : ndarray
        Times in s.
    h : ndarray
        Impulse response in 1/s (m of position per m s of seat impulse).

    Raises
    ------
    BodyvibError
        More than :data:`MAX_SAMPLES` samples, or the position moves with the
        seat instantly (not square integrable).

    Examples
    --------
    >>> t, h = impulse_response(load_model("reduced-paper"), 2.0, 1e-3)
    >>> bool(abs(h.sum() * 1e-3 - 1.0) < 1e-3)   # static gain X1/Xr(0) = 1
    True
    """
    t_parts, h_parts = [], []
    for t, h in _impulse_blocks(model, _samples(t_end, dt), dt, point):
        t_parts.append(t)
        h_parts.append(h)
    return np.concatenate(t_parts), np.concatenate(h_parts)


#: Most samples an impulse response may take (memory stays one block; time ~ 10 s).
MAX_SAMPLES = 50_000_000


def _samples(t_end: float, dt: float) -> int:
    if not (t_end > 0 and dt > 0):
        raise BodyvibError(f"impulse response needs t_end > 0 and dt > 0, got {t_end}, {dt}")
    n = int(math.ceil(t_end / dt)) + 1
    if n > MAX_SAMPLES:
        raise BodyvibError(
            f"impulse response over {t_end:g} s at {dt:g} s would take {n} samples; a model "
            "decays too slowly (a nearly undamped mode): give a shorter t_end or a larger dt"
        )
    return n


def _impulse_blocks(model, n: int, dt: float, point: str, block: int = 512):
    """Yield ``(t, h)`` of the exact impulse response in blocks of samples."""
    from .discretize import expm

    A, b, c = _displacement_statespace(model, point)
    phi = expm(A * dt)
    block = min(n, block)
    V = np.empty((A.shape[0], block))
    V[:, 0] = b
    for k in range(1, block):
        V[:, k] = phi @ V[:, k - 1]
    phi_block = np.linalg.matrix_power(phi, block)
    done = 0
    while done < n:
        m = min(block, n - done)
        yield (np.arange(done, done + m) * dt, (c @ V)[:m])
        done += m
        V = phi_block @ V


def objective_time_domain(reference, reduced, pairs: Optional[Mapping[str, float]] = None,
                          dt: Optional[float] = None, t_end: Optional[float] = None,
                          config: Optional[dict] = None) -> float:
    """The paper's Eq. 3 by its definition: integrated squared impulse-response difference.

    ``J = sum_p w_p int_0^T (h_ref,p - h_red,p)^2 dt``, trapezoid rule on exact
    samples (:func:`impulse_response`).

    Parameters
    ----------
    reference, reduced : Network
        Any two body models with the roles of ``pairs``.
    pairs : dict of str to float, optional
        Role -> weight; the configuration's ``pairs`` by default (head and torso,
        weight 1 each).
    dt : float, optional
        Sample spacing in s (configuration ``time_domain.dt_s``, 0.2 ms: 5 kHz,
        above twice every resonance of both models, so the sampled sum
        converges spectrally).
    t_end : float, optional
        Horizon in s; by default 40 time constants of the slowest pole of
        either model (:func:`default_horizon`).
    config : dict, optional
        As :func:`load_config`.

    Returns
    -------
    float
        ``J`` in 1/s.

    Raises
    ------
    BodyvibError
        A model that does not decay (unstable), or one so lightly damped that
        the horizon needs more than :data:`MAX_SAMPLES` samples.

    Examples
    --------
    >>> net = load_model("reduced-paper")
    >>> objective_time_domain(net, net)
    0.0
    """
    cfg = config or load_config()
    pairs = dict(pairs or cfg["pairs"])
    dt = float(dt or cfg["time_domain"]["dt_s"])
    if t_end is None:
        t_end = default_horizon(reference, reduced,
                                time_constants=cfg["time_domain"]["decay_time_constants"])
    n = _samples(t_end, dt)
    total = 0.0
    for role, wgt in pairs.items():
        acc = 0.0  # trapezoid rule, streamed block by block: memory stays one block
        blocks = zip(_impulse_blocks(reference, n, dt, role), _impulse_blocks(reduced, n, dt, role))
        for (t, h1), (_, h2) in blocks:
            g = (h1 - h2) ** 2
            acc += float(np.sum(g))
            if t[0] == 0.0:
                acc -= 0.5 * float(g[0])
            if t[-1] >= (n - 1) * dt * (1 - 1e-12):
                acc -= 0.5 * float(g[-1])
        total += wgt * dt * acc
    return total


def parameter_array(net: Network) -> np.ndarray:
    """The reduced model's parameters as an array in :data:`REDUCED_PARAMETERS` order."""
    missing = [k for k in REDUCED_PARAMETERS if k not in net.parameters]
    if missing:
        raise BodyvibError(f"model '{net.name}' is not the reduced 3-DOF model: it lacks "
                           f"parameter(s) {', '.join(missing)}")
    return np.array([net.parameters[k] for k in REDUCED_PARAMETERS], dtype=float)


@dataclass
class FitTarget:
    """What the reduced model is fitted to, with the vectorized objective.

    ``objective(params)`` is ``sum_p w_p * 2 * sum_i q_i D_p(f_i)`` with
    ``D = |T_target - T_reduced|^2`` (or ``(|T_target| - |T_reduced|)^2``
    when only moduli are known) on nodes ``f_i`` with weights ``q_i``.

    Attributes
    ----------
    name : str
        Short name for file names and provenance (``iso7962``, a CSV stem).
    kind : str
        ``"model"`` (a reference network) or ``"measured"`` (CSV data).
    frequency_hz, weights : ndarray
        Quadrature nodes (Hz) and weights (Hz).
    responses : dict of str to ndarray
        Role -> target response at the nodes (complex; real moduli when
        ``modulus_only``).
    pairs : dict of str to float
        Role -> weight.
    total_mass : float
        Pinned total mass of the reduced model, kg.
    modulus_only : bool
        True for measured data without phase.
    reference : Network or None
        The reference model (``kind == "model"``).
    measured : MeasuredTransmissibility or None
        The data (``kind == "measured"``).
    description : str
        One line for provenance and reports.
    """

    name: str
    kind: str
    frequency_hz: np.ndarray
    weights: np.ndarray
    responses: Dict[str, np.ndarray]
    pairs: Dict[str, float]
    total_mass: float
    modulus_only: bool = False
    reference: Optional[Network] = None
    measured: object = None
    description: str = ""

    def __post_init__(self):
        self._s = 2j * np.pi * np.asarray(self.frequency_hz, dtype=float)

    def objective(self, params) -> np.ndarray:
        """The objective for one parameter set or a whole population, in 1/s.

        Parameters
        ----------
        params : array_like, shape (..., 7)
            Reduced-model parameters in :data:`REDUCED_PARAMETERS` order (SI);
            leading axes are a population.

        Returns
        -------
        ndarray, shape (...)
            ``J`` per parameter set (``inf`` where the model is not finite).
        """
        p = np.asarray(params, dtype=float)
        cols = [p[..., i] for i in range(len(REDUCED_PARAMETERS))]
        total = 0.0
        for role, wgt in self.pairs.items():
            H = _REDUCED_TF[role](self._s, *cols)
            ref = self.responses[role]
            d = (np.abs(H) - ref) if self.modulus_only else (H - ref)
            d2 = d.real ** 2 + d.imag ** 2
            total = total + wgt * 2.0 * (d2 @ self.weights)
        total = np.asarray(total, dtype=float)
        return np.where(np.isfinite(total), total, np.inf)

    def energy(self) -> float:
        """``sum_p w_p int h_target,p^2 dt`` (1/s): the objective of a body that does not move.

        ``objective / energy`` is the relative squared error (dimensionless).
        """
        total = 0.0
        for role, wgt in self.pairs.items():
            r = np.abs(self.responses[role])
            total += wgt * 2.0 * float((r ** 2) @ self.weights)
        return total


def model_target(reference, pairs: Optional[Mapping[str, float]] = None,
                 config: Optional[dict] = None) -> FitTarget:
    """Target: a reference model's position impulse responses (by Parseval, its FRFs).

    Parameters
    ----------
    reference : str or Network
        Shipped model name or parameter file (``"iso7962"``) or a network.
    pairs : dict of str to float, optional
        Role -> weight (the configuration's ``pairs`` by default: head and
        torso, weight 1 each); each role must be a role of the reference model.
    config : dict, optional
        As :func:`load_config` (its ``quadrature`` section is used).

    Returns
    -------
    FitTarget
        Total mass pinned to the reference's static apparent mass.

    Raises
    ------
    BodyvibError
        A pair's role is not a role of the reference model.
    """
    from .frequency import transmissibility

    cfg = config or load_config()
    net = load_model(reference) if isinstance(reference, (str, os.PathLike)) else reference
    pairs = dict(pairs or cfg["pairs"])
    for role in pairs:
        if role not in net.roles:
            raise BodyvibError(
                f"reference model '{net.name}' has no role '{role}' (its roles: "
                f"{', '.join(net.roles) or 'none'}); add it to the file's 'roles' or drop it "
                "from --pairs"
            )
        if role not in _REDUCED_TF:
            raise BodyvibError(f"role '{role}' has no counterpart in the reduced model")
    f, w = quadrature_grid(**cfg["quadrature"])
    responses = {role: transmissibility(net, f, role) for role in pairs}
    name = net.name
    return FitTarget(
        name=name, kind="model", frequency_hz=f, weights=w, responses=responses, pairs=pairs,
        total_mass=net.total_mass(), reference=net,
        description=f"impulse responses of {', '.join(pairs)} position of model '{name}'",
    )


def measured_target(data, total_mass: Optional[float] = None) -> FitTarget:
    """Target: a measured seat-to-head transmissibility (band-limited Parseval form).

    ``J = 2 int_{f_1}^{f_n} |T_meas - T_red|^2 df`` by the trapezoid rule on
    the measured frequencies; ``(|T_meas| - |T_red|)^2`` when no phase is
    given.

    Parameters
    ----------
    data : str, os.PathLike or MeasuredTransmissibility
        A CSV file (:func:`bodyvib.measured.read_transmissibility_csv`) or
        data already read.
    total_mass : float, optional
        Pinned total mass m1 + m2 in kg; 75 kg (the ISO 7962 model's) by
        default. Measure or estimate the subject's seated mass on the seat
        for a correct seat force: the transmissibility does not determine it.

    Returns
    -------
    FitTarget

    Raises
    ------
    BodyvibError
        Malformed data (see :mod:`bodyvib.measured`) or a non-positive mass.
    """
    from .measured import MeasuredTransmissibility, read_transmissibility_csv

    m = data if isinstance(data, MeasuredTransmissibility) else read_transmissibility_csv(data)
    M = DEFAULT_MEASURED_TOTAL_MASS if total_mass is None else float(total_mass)
    if not (math.isfinite(M) and M > 0):
        raise BodyvibError(f"--total-mass must be a positive number of kg, got {total_mass}")
    f = m.frequency_hz
    w = np.zeros_like(f)
    df = np.diff(f)
    w[:-1] += df / 2
    w[1:] += df / 2
    resp = m.modulus if not m.has_phase else m.complex()
    stem = os.path.splitext(os.path.basename(m.source))[0] or "measured"
    what = "complex transmissibility" if m.has_phase else "transmissibility modulus (no phase)"
    return FitTarget(
        name=stem, kind="measured", frequency_hz=f, weights=w, responses={"head": resp},
        pairs={"head": 1.0}, total_mass=M, modulus_only=not m.has_phase, measured=m,
        description=f"measured seat-to-head {what} from '{m.source}', "
                    f"{f[0]:g}-{f[-1]:g} Hz, {f.size} points",
    )


def objective_frequency_domain(reference, reduced, pairs: Optional[Mapping[str, float]] = None,
                               config: Optional[dict] = None) -> float:
    """The paper's Eq. 3 by Parseval, for one reduced model (see :class:`FitTarget`).

    Parameters
    ----------
    reference : str or Network
        The reference model.
    reduced : Network
        A reduced 3-DOF model (parameters m1 m2 k1 k2 c1 c2 ks).
    pairs : dict of str to float, optional
    config : dict, optional

    Returns
    -------
    float
        ``J`` in 1/s.

    Examples
    --------
    >>> paper = load_model("reduced-paper")
    >>> round(objective_frequency_domain("iso7962", paper), 4)      # head and torso
    3.4381
    >>> round(objective_frequency_domain("iso7962", paper, {"head": 1.0}), 4)
    1.8548
    """
    return float(model_target(reference, pairs, config).objective(parameter_array(reduced)))


# --------------------------------------------------------------------------
# the search space: six ratios, total mass pinned
# --------------------------------------------------------------------------
def genes_to_parameters(genes, total_mass: float) -> np.ndarray:
    """Search coordinates to reduced-model parameters.

    Parameters
    ----------
    genes : array_like, shape (..., 6)
        ``log10`` of ``m1/M, k1/M, k2/M, ks/M, c1/M, c2/M`` (:data:`GENES`).
    total_mass : float
        ``M = m1 + m2`` in kg.

    Returns
    -------
    ndarray, shape (..., 7)
        In :data:`REDUCED_PARAMETERS` order, SI.
    """
    v = 10.0 ** np.asarray(genes, dtype=float) * total_mass
    m1, k1, k2, ks, c1, c2 = (v[..., i] for i in range(6))
    return np.stack([m1, total_mass - m1, k1, k2, c1, c2, ks], axis=-1)


def parameters_to_genes(params) -> np.ndarray:
    """Inverse of :func:`genes_to_parameters` (the total mass is ``m1 + m2``)."""
    p = np.asarray(params, dtype=float)
    m1, m2, k1, k2, c1, c2, ks = (p[..., i] for i in range(7))
    M = m1 + m2
    return np.log10(np.stack([m1, k1, k2, ks, c1, c2], axis=-1) / M[..., None])


def reduced_network(params, name: str = "reduced-refit", description: str = "",
                    provenance: Optional[dict] = None) -> Network:
    """The reduced model (paper's topology) with the given parameters.

    Parameters
    ----------
    params : array_like (7,) or dict
        In :data:`REDUCED_PARAMETERS` order, or by name.
    name, description : str
    provenance : dict, optional

    Returns
    -------
    Network
    """
    template = load_model("reduced-paper")
    if not isinstance(params, Mapping):
        params = dict(zip(REDUCED_PARAMETERS, (float(v) for v in params)))
    net = template.with_parameters(**params)
    return replace(net, name=name, description=description or template.description,
                   provenance=dict(provenance or {}))


# --------------------------------------------------------------------------
# the genetic algorithm
# --------------------------------------------------------------------------
@dataclass
class FitResult:
    """Outcome of :func:`fit`.

    Attributes
    ----------
    parameters : dict of str to float
        Fitted reduced-model parameters (SI).
    objective : float
        Final objective (frequency-domain form), 1/s.
    objective_table2 : float
        The paper's Table 2 parameters on the same objective, 1/s.
    ga_objective : float
        Best run's objective from the GA, before the polish.
    relative_error : float
        ``objective / target.energy()``.
    target : FitTarget
    seed : int
    config : dict
    polished : bool
    evaluations : int
        Objective evaluations (individual parameter sets) in the GA and polish.
    elapsed_s : float
        Wall time of the search.
    history : list of float
        Best objective after each generation.
    at_bounds : list of str
        Searched ratios that ended within 0.1 % (in log) of a bound.
    runs : list of dict
        Per GA run (``ga.restarts`` of them): its seed, the GA's best objective
        and the objective after the polish; the best run is the result.
    """

    parameters: Dict[str, float]
    objective: float
    objective_table2: float
    ga_objective: float
    relative_error: float
    target: FitTarget
    seed: int
    config: dict
    polished: bool
    evaluations: int
    elapsed_s: float
    history: List[float] = field(default_factory=list)
    at_bounds: List[str] = field(default_factory=list)
    runs: List[dict] = field(default_factory=list)


def _log_bounds(cfg):
    b = cfg["bounds_per_kg_total_mass"]
    lo = np.log10([b[g][0] for g in GENES])
    hi = np.log10([b[g][1] for g in GENES])
    return lo, hi


def fit(target: FitTarget, config: Optional[dict] = None, seed: int = 1,
        polish: Optional[bool] = None, progress: bool = False) -> FitResult:
    """Fit the reduced model to a target with PyGAD's genetic algorithm.

    Parameters
    ----------
    target : FitTarget
        From :func:`model_target` or :func:`measured_target`.
    config : dict, optional
        As :func:`load_config` (bounds, GA settings, polish).
    seed : int
        Seeds the search: ``ga.restarts`` independent GA runs, each seeded
        (``pygad.GA(random_seed=...)``) from ``numpy.random.SeedSequence(seed)``,
        each polished, the best kept. The same seed and configuration give the
        same parameters.
    polish : bool, optional
        Local polish from the GA's best (``config["polish"]["enabled"]`` by
        default).
    progress : bool
        Show a progress bar on stderr (tqdm; off when stderr is not a terminal).

    Returns
    -------
    FitResult

    Raises
    ------
    BodyvibError
        A seed that is not a non-negative integer, or GA settings PyGAD refuses
        (an unknown operator name).

    Examples
    --------
    >>> cfg = load_config(overrides={"ga": {"population": 20, "generations": 5,
    ...                                     "parents_mating": 10}})
    >>> r = fit(model_target("iso7962"), cfg, seed=1)
    >>> bool(r.objective < r.objective_table2)
    True
    """
    import pygad
    from tqdm import tqdm

    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise BodyvibError(f"seed must be a non-negative integer, got {seed!r}")
    cfg = config or load_config()
    ga_cfg = cfg["ga"]
    do_polish = cfg["polish"]["enabled"] if polish is None else bool(polish)
    lo, hi = _log_bounds(cfg)
    M = target.total_mass
    evaluations = [0]

    def objective_of_genes(genes):
        evaluations[0] += int(np.prod(np.shape(genes)[:-1]))
        return target.objective(genes_to_parameters(genes, M))

    def fitness(_ga, solutions, _idx):
        J = objective_of_genes(np.atleast_2d(solutions))
        return np.where(np.isfinite(J), -J, -1e300)

    restarts = int(ga_cfg["restarts"])
    run_seeds = [int(v) for v in np.random.SeedSequence(int(seed)).generate_state(restarts)]
    history: List[float] = []
    bar = tqdm(total=restarts * ga_cfg["generations"], desc="bodyvib fit (GA)", unit="gen",
               file=sys.stderr, disable=None if progress else True, leave=False)

    def on_generation(ga):
        best = -float(np.max(ga.last_generation_fitness))
        history.append(best)
        bar.set_postfix_str(f"J={min(history):.5g} 1/s", refresh=False)
        bar.update(1)

    t0 = time.perf_counter()
    runs = []
    try:
        for run_seed in run_seeds:
            ga = _ga(
                pygad,
                num_generations=ga_cfg["generations"],
                num_parents_mating=ga_cfg["parents_mating"],
                sol_per_pop=ga_cfg["population"],
                num_genes=len(GENES),
                fitness_func=fitness,
                fitness_batch_size=ga_cfg["population"],
                gene_space=[{"low": float(a), "high": float(b)} for a, b in zip(lo, hi)],
                parent_selection_type=ga_cfg["parent_selection"],
                K_tournament=ga_cfg["tournament_size"],
                keep_elitism=ga_cfg["elitism"],
                crossover_type=ga_cfg["crossover"],
                mutation_type=ga_cfg["mutation"],
                mutation_probability=ga_cfg["mutation_probability"],
                polynomial_mutation_eta=ga_cfg["polynomial_mutation_eta"],
                on_generation=on_generation,
                random_seed=run_seed,
                suppress_warnings=True,
            )
            ga.run()
            genes, _, _ = ga.best_solution(ga.last_generation_fitness)
            genes = np.clip(np.asarray(genes, dtype=float), lo, hi)
            ga_J = float(objective_of_genes(genes))
            J = ga_J
            if do_polish:
                genes, J = _polish(objective_of_genes, genes, lo, hi, cfg["polish"])
            runs.append({"seed": run_seed, "ga_objective_per_s": ga_J,
                         "objective_per_s": float(J), "genes": genes})
    finally:
        bar.close()
    elapsed = time.perf_counter() - t0
    best = min(runs, key=lambda r: r["objective_per_s"])
    best_genes, J, ga_J = best["genes"], best["objective_per_s"], best["ga_objective_per_s"]
    params = genes_to_parameters(best_genes, M)
    J_paper = float(target.objective(parameter_array(load_model("reduced-paper"))))
    tol = 1e-3 * (hi - lo)
    at_bounds = [f"{g}/M at {'lower' if x - a <= t else 'upper'} bound"
                 for g, x, a, b, t in zip(GENES, best_genes, lo, hi, tol)
                 if x - a <= t or b - x <= t]
    for r in runs:
        del r["genes"]
    return FitResult(
        parameters=dict(zip(REDUCED_PARAMETERS, (float(v) for v in params))),
        objective=float(J), objective_table2=J_paper, ga_objective=ga_J,
        relative_error=float(J) / target.energy(), target=target, seed=int(seed), config=cfg,
        polished=do_polish, evaluations=evaluations[0], elapsed_s=elapsed, history=history,
        at_bounds=at_bounds, runs=runs,
    )


def _ga(pygad, **settings):
    """``pygad.GA(**settings)``; settings it refuses (an unknown operator name) are a user error.

    PyGAD's own logger would print the refusal with a traceback before raising
    it; a silent logger leaves the message to the one line of the command.
    """
    logger = logging.getLogger("bodyvib.fit.pygad")
    if not logger.handlers:
        logger.addHandler(logging.NullHandler())
        logger.propagate = False
    try:
        return pygad.GA(logger=logger, **settings)
    except (TypeError, ValueError) as exc:
        raise BodyvibError(f"configuration 'ga': PyGAD refuses the settings: {exc}") from None


def _polish(objective_of_genes, x0, lo, hi, pcfg):
    """Bounded local minimization in log space from the GA's best."""
    from scipy.optimize import minimize

    step = 1e-6

    def fun(x):
        return float(objective_of_genes(x))

    def jac(x):
        # central differences, all 2n points in one vectorized call
        n = x.size
        pts = np.concatenate([x + step * np.eye(n), x - step * np.eye(n)])
        J = objective_of_genes(pts)
        return (J[:n] - J[n:]) / (2 * step)

    method = pcfg["method"]
    opts = {"maxiter": int(pcfg["max_iterations"])}
    if method == "L-BFGS-B":
        opts.update(ftol=1e-15, gtol=1e-12)
        res = minimize(fun, x0, jac=jac, method=method, bounds=list(zip(lo, hi)), options=opts)
    else:
        res = minimize(fun, x0, method=method, bounds=list(zip(lo, hi)), options=opts)
    x = np.clip(res.x, lo, hi)
    Jx, J0 = fun(x), fun(x0)
    return (x, Jx) if Jx <= J0 else (np.asarray(x0), J0)


# --------------------------------------------------------------------------
# the parameter file
# --------------------------------------------------------------------------
def write_parameter_file(result: FitResult, path, command: str = "") -> Network:
    """Write the fitted model as a reduced-model parameter file with its provenance.

    The file is a normal bodyvib model (same topology as ``reduced-paper``),
    so :func:`bodyvib.models.load_model`, ``bodyvib frf --models FILE`` and
    ``python build_fmu.py --params FILE`` read it. Written atomically.

    Parameters
    ----------
    result : FitResult
    path : str or os.PathLike
    command : str
        The command line that made it (recorded in the provenance).

    Returns
    -------
    Network
        The model as written.
    """
    import pygad

    t = result.target
    name = f"reduced-refit-{t.name}"
    prov = {
        "source": "GA refit of the reduced 3-DOF model of Balci & Gundogdu (2025), Fig. 2, by "
                  "'bodyvib fit' (bodyvib.fit)",
        "command": command,
        "date": datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat(),
        "bodyvib_version": __version__,
        "target": t.description,
        "reference_model": t.reference.name if t.reference is not None else None,
        "measured_data": t.measured.source if t.measured is not None else None,
        "objective": {
            "definition": "paper Eq. 3: J = sum_p w_p int_0^inf (h_ref,p(t) - h_red,p(t))^2 dt, "
                          "h = position response to a unit impulse of seat displacement [1/s]; "
                          "evaluated by Parseval, 2 int_0^inf |H_ref - H_red|^2 df"
                          + (" (measured band only, trapezoid on the data)"
                             if t.kind == "measured" else "")
                          + (" on moduli only (no phase)" if t.modulus_only else ""),
            "pairs": dict(t.pairs),
            "value_per_s": result.objective,
            "relative_to_target_energy": result.relative_error,
            "table2_value_per_s": result.objective_table2,
            "ga_value_before_polish_per_s": result.ga_objective,
        },
        "scale_pinning": {
            "total_mass_kg": t.total_mass,
            "how": ("m1 + m2 pinned to the reference model's static apparent mass"
                    if t.kind == "model" else
                    "m1 + m2 pinned to --total-mass (75 kg by default)")
                   + "; every transmissibility is invariant to scaling all m, k, c by one "
                     "factor, so the fit searched only the six ratios m1/M, k1/M, k2/M, ks/M, "
                     "c1/M, c2/M",
        },
        "algorithm": {
            "library": f"pygad {pygad.__version__} (pygad.GA), real-coded, batch fitness",
            "seed": result.seed,
            "ga": dict(result.config["ga"]),
            "bounds_per_kg_total_mass": dict(result.config["bounds_per_kg_total_mass"]),
            "search_space": "log10 of the six ratios, uniform within the bounds",
            "polish": (dict(result.config["polish"], enabled=True) if result.polished
                       else {"enabled": False}),
            "quadrature": dict(result.config["quadrature"]),
            "runs": [dict(r) for r in result.runs],
            "evaluations": result.evaluations,
            "wall_time_s": round(result.elapsed_s, 3),
        },
        "at_bounds": list(result.at_bounds),
    }
    if t.kind == "model":
        net = reduced_network(result.parameters)
        prov["objective"]["time_domain_value_per_s"] = objective_time_domain(
            t.reference, net, t.pairs, config=result.config)
    description = (
        f"Reduced 3-DOF seated human-body model (topology of Balci & Gundogdu 2025, Fig. 2: "
        f"seat --ks-- platform --(k2 || c2)-- torso m2 --(k1 || c1)-- head m1), parameters "
        f"refitted by a genetic algorithm to {t.description}; total mass pinned to "
        f"{t.total_mass:g} kg."
    )
    net = reduced_network(result.parameters, name=name, description=description, provenance=prov)
    save_model(net, path)
    return net


# --------------------------------------------------------------------------
# command line
# --------------------------------------------------------------------------
def _command_line(args) -> str:
    parts = ["bodyvib fit"]
    if args.measured:
        parts += ["--measured", args.measured]
        if args.total_mass is not None:
            parts += ["--total-mass", f"{args.total_mass:g}"]
    else:
        parts += ["--reference", args.reference]
    parts += ["--seed", str(args.seed), "--out", args.out]
    if args.config:
        parts += ["--config", args.config]
    if args.pairs:
        parts += ["--pairs", args.pairs]
    if args.polish is not None:
        parts += ["--polish" if args.polish else "--no-polish"]
    return " ".join(parts)


def _run(args):
    cfg = load_config(args.config)
    if args.measured:
        if args.pairs:
            raise BodyvibError("--pairs applies to a reference model; measured data are "
                               "seat-to-head only")
        target = measured_target(args.measured, args.total_mass)
    else:
        if args.total_mass is not None:
            raise BodyvibError("--total-mass applies to --measured data; with a reference "
                               "model the total mass is its static apparent mass")
        pairs = parse_pairs(args.pairs) if args.pairs else None
        target = model_target(args.reference, pairs, cfg)
    log = (lambda *a: None) if args.quiet else print
    log(f"fitting the reduced model to {target.description}; total mass pinned to "
        f"{target.total_mass:g} kg; seed {args.seed}")
    result = fit(target, cfg, seed=args.seed, polish=args.polish, progress=not args.quiet)
    net = write_parameter_file(result, args.out, command=_command_line(args))
    log(f"objective J: Table 2 {result.objective_table2:.6g} 1/s, refit "
        f"{result.objective:.6g} 1/s ({result.objective / result.objective_table2:.1%} of "
        f"Table 2; GA {result.ga_objective:.6g} before polish), {result.evaluations} "
        f"evaluations in {result.elapsed_s:.1f} s")
    log("parameters: " + ", ".join(f"{k} {v:.5g}" for k, v in result.parameters.items()))
    if result.at_bounds:
        log("at a bound of the search: " + "; ".join(result.at_bounds))
    log(f"wrote {args.out}")
    if args.report:
        from .fit_report import write_report

        files = write_report(args.report, result, net)
        log("wrote " + ", ".join(files))
    return 0


def add_command(subparsers):
    """Register ``bodyvib fit``."""
    p = subparsers.add_parser(
        "fit",
        help="refit the reduced model by a genetic algorithm (paper Eq. 3)",
        description="Refit the reduced 3-DOF model's parameters by a genetic algorithm "
        "(PyGAD) to the head and torso impulse responses of a reference model (the paper's "
        "Eq. 3; --pairs chooses) or to "
        "a measured seat-to-head transmissibility, and write a parameter file with its "
        "provenance that build_fmu.py --params bakes into the FMU.",
    )
    src = p.add_mutually_exclusive_group()
    src.add_argument("--reference", default="iso7962", metavar="MODEL",
                     help="reference model: shipped name or parameter file (default iso7962)")
    src.add_argument("--measured", metavar="FILE.csv",
                     help="measured transmissibility: CSV with header frequency_hz,modulus"
                          "[,phase_deg]")
    p.add_argument("--total-mass", type=float, metavar="KG",
                   help="with --measured: total mass m1 + m2 to pin, kg (default 75)")
    p.add_argument("--seed", type=int, default=1, help="GA seed (default 1)")
    p.add_argument("--out", default="params/refit.json", metavar="FILE.json",
                   help="parameter file to write (default params/refit.json)")
    p.add_argument("--config", metavar="FILE.json",
                   help="settings overriding bodyvib/data/fit/default-config.json")
    p.add_argument("--pairs", metavar="ROLE=W,...",
                   help="position pairs and weights, e.g. head=1,torso=0.5 (default "
                        "head=1,torso=1, from the configuration)")
    p.add_argument("--report", metavar="DIR",
                   help="write a comparison with the paper's Table 2 (table, JSON, plots)")
    p.add_argument("--polish", dest="polish", action="store_true", default=None,
                   help="local polish after the GA (default: per the configuration, on)")
    p.add_argument("--no-polish", dest="polish", action="store_false",
                   help="skip the local polish")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no messages")
    p.set_defaults(func=_run)
    return p
