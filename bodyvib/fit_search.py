"""The search of the refit: a seeded genetic algorithm, then an optional local polish.

The genetic algorithm is PyGAD's (``pygad.GA``): real-coded, seeded, batch
fitness (the whole population per call), a progress bar; an optional local
polish (``scipy.optimize.minimize``, L-BFGS-B in the same log-space, bounded)
starts from the GA's best. The objective is :mod:`bodyvib.fit_objective`, the
genes :mod:`bodyvib.fit_space`, the result :class:`bodyvib.fit_result.FitResult`.
"""

import logging
import sys
import time
from typing import List, Optional

import numpy as np

from .fit_config import load_config
from .fit_objective import FitTarget, parameter_array
from .fit_result import FitResult
from .fit_space import GENES, REDUCED_PARAMETERS, genes_to_parameters
from .models import load_model
from .runtime.errors import BodyvibError

__all__ = [
    "fit",
]


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
    >>> from bodyvib.fit_objective import model_target
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
