"""The search of the refit: seeded searches (a genetic algorithm by default), each polished.

The search methods are :mod:`bodyvib.fit.methods` (the genetic algorithm, and
CMA-ES and differential evolution to compare it with); an optional local
polish (:func:`polish`: ``scipy.optimize.minimize``, L-BFGS-B in the same
log-space, bounded) starts from each search's best. The objective is
:mod:`bodyvib.fit.objective`, the genes :mod:`bodyvib.fit.space`, the result
:class:`bodyvib.fit.result.FitResult`.

BLAS runs on one thread during the search (``threadpoolctl``): the objective's
products are small (a population by 196 quadrature nodes), and OpenBLAS's
threads only cost there; the polish, which evaluates one to twelve points at a
time, is about ten times faster so (``benchmarks/bench_fit_methods.py``).
"""

import functools
import sys
import time
from typing import List, Optional

import numpy as np

from ..models import load_model
from ..process import extras, interrupts
from ..runtime.errors import BodyvibError
from .config import FitConfig, load_config, log_bounds
from .methods import METHODS, search
from .objective import FitTarget, parameter_array
from .result import FitResult
from .space import GENES, REDUCED_PARAMETERS, genes_to_parameters

__all__ = [
    "fit",
    "polish",
]


def fit(
    target: FitTarget,
    config: Optional[FitConfig] = None,
    seed: int = 1,
    polish: Optional[bool] = None,
    progress: bool = False,
    method: Optional[str] = None,
) -> FitResult:
    """Fit the reduced model to a target by a seeded search (the genetic algorithm by default).

    Parameters
    ----------
    target : FitTarget
        From :func:`~bodyvib.fit.objective.model_target` or :func:`~bodyvib.fit.objective.measured_target`.
    config : FitConfig, optional
        From :func:`~bodyvib.fit.config.load_config` (bounds, method and its settings, restarts, polish).
    seed : int
        Seeds the search: ``restarts`` independent searches (per target kind:
        one for a reference model, eight for measured data), each seeded from
        ``numpy.random.SeedSequence(seed)``, each polished, the best kept. The
        same seed and configuration give the same parameters.
    polish : bool, optional
        Local polish from each search's best (``config.polish.enabled``
        by default).
    progress : bool
        Show a progress bar on stderr (tqdm; off when stderr is not a terminal).
    method : str, optional
        ``"ga"``, ``"cmaes"`` or ``"de"`` (:data:`bodyvib.fit.methods.METHODS`);
        ``config.method`` by default.

    Returns
    -------
    FitResult

    Raises
    ------
    BodyvibError
        A seed that is not a non-negative integer, or an unknown method.
    bodyvib.process.extras.MissingExtraError
        The fit extra is not installed.

    Examples
    --------
    >>> from bodyvib.fit.objective import model_target
    >>> cfg = load_config(overrides={"ga": {"population": 20, "generations": 5}})
    >>> r = fit(model_target("iso7962"), cfg, seed=1)
    >>> bool(r.objective < r.objective_table2)
    True
    """
    extras.require("the fit", "fit")
    from threadpoolctl import threadpool_limits

    cfg = config or load_config()
    method = _checked(seed, cfg.method if method is None else method)
    settings = cfg.settings(method)
    do_polish = cfg.polish.enabled if polish is None else bool(polish)
    lo, hi = log_bounds(cfg)
    objective_of_genes = _GeneObjective(target)
    restarts = int(getattr(cfg.restarts, target.kind))
    run_seeds = [int(v) for v in np.random.SeedSequence(int(seed)).generate_state(restarts)]
    generations = getattr(settings, "generations", None)
    bar = _Progress(method, restarts * generations if generations is not None else None, progress)
    if do_polish:
        import scipy.optimize  # noqa: F401  (imported before the clock: start-up, not search)
    t0 = time.perf_counter()
    try:
        with threadpool_limits(1, user_api="blas"):
            run = functools.partial(
                _search_run,
                method,
                objective_of_genes,
                (lo, hi),
                settings,
                on_generation=bar.on_generation,
                pcfg=cfg.polish if do_polish else None,
            )
            runs = [run(run_seed) for run_seed in run_seeds]
    finally:
        bar.close()
    elapsed = time.perf_counter() - t0
    best_genes, found = _best(runs, target)
    return FitResult(
        **found,
        target=target,
        seed=int(seed),
        config=cfg,
        polished=do_polish,
        evaluations=objective_of_genes.evaluations,
        elapsed_s=elapsed,
        history=bar.history,
        at_bounds=_at_bounds(best_genes, lo, hi),
        runs=runs,
        method=method,
    )


def _best(runs, target):
    """The best run's genes, and its fields of :class:`FitResult` (the runs lose their genes)."""
    best = min(runs, key=lambda r: r["objective_per_s"])
    best_genes, J = best["genes"], best["objective_per_s"]
    params = genes_to_parameters(best_genes, target.total_mass)
    for r in runs:
        del r["genes"]
    return best_genes, {
        "parameters": dict(zip(REDUCED_PARAMETERS, (float(v) for v in params))),
        "objective": float(J),
        "objective_table2": float(target.objective(parameter_array(load_model("reduced-paper")))),
        "ga_objective": best["search_objective_per_s"],
        "relative_error": float(J) / target.energy(),
    }


def _checked(seed, method):
    """The search method, once it and the seed are known to be valid."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise BodyvibError(f"seed must be a non-negative integer, got {seed!r}")
    if method not in METHODS:
        raise BodyvibError(f"unknown search method '{method}'; methods are {', '.join(METHODS)}")
    return method


class _GeneObjective:
    """The target's objective of genes (rows), counting the models it evaluates."""

    def __init__(self, target):
        self.target, self.evaluations = target, 0

    def __call__(self, genes):
        interrupts.check()  # Ctrl-C: every GA generation and polish step passes here
        self.evaluations += int(np.prod(np.shape(genes)[:-1]))
        return self.target.objective(genes_to_parameters(genes, self.target.total_mass))


class _Progress:
    """The search's progress bar and the best objective of every generation."""

    def __init__(self, method, total, progress):
        from tqdm import tqdm

        self.history: List[float] = []
        self._bar = tqdm(
            total=total,
            desc=f"bodyvib fit ({method})",
            unit="gen",
            file=sys.stderr,
            disable=None if progress else True,
            leave=False,
        )

    def on_generation(self, best):
        self.history.append(best)
        self._bar.set_postfix_str(f"J={min(self.history):.5g} 1/s", refresh=False)
        self._bar.update(1)

    def close(self):
        self._bar.close()


def _search_run(method, objective_of_genes, bounds, settings, run_seed, on_generation, pcfg):
    """One seeded search, polished when ``pcfg`` (the polish settings) is given: its record."""
    lo, hi = bounds
    found = search(
        method, objective_of_genes, lo, hi, settings, run_seed, on_generation=on_generation
    )
    genes, J = found.genes, found.objective
    if pcfg is not None:
        genes, J = _polish(objective_of_genes, genes, lo, hi, pcfg)
    return {
        "seed": run_seed,
        "search_objective_per_s": found.objective,
        "objective_per_s": float(J),
        "evaluations": found.evaluations,
        "generations": found.generations,
        "stopped": found.stopped,
        "genes": genes,
    }


def _at_bounds(genes, lo, hi):
    """The genes within 0.1 % of their range of a bound, in words."""
    tol = 1e-3 * (hi - lo)
    return [
        f"{g}/M at {'lower' if x - a <= t else 'upper'} bound"
        for g, x, a, b, t in zip(GENES, genes, lo, hi, tol)
        if x - a <= t or b - x <= t
    ]


def polish(objective_of_genes, x0, lo, hi, pcfg):
    """Bounded local minimization in log space from a search's best.

    Parameters
    ----------
    objective_of_genes : callable
        Vectorized objective of genes (shape ``(..., 6)``).
    x0 : ndarray, shape (6,)
        Start.
    lo, hi : ndarray, shape (6,)
        Bounds of the genes.
    pcfg : bodyvib.fit.config.PolishSettings
        The configuration's ``polish`` section (``method``, ``max_iterations``).

    Returns
    -------
    genes : ndarray, shape (6,)
    objective : float
        Never worse than at ``x0``.
    """
    return _polish(objective_of_genes, x0, lo, hi, pcfg)


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

    method = pcfg.method
    opts = {"maxiter": int(pcfg.max_iterations)}
    if method == "L-BFGS-B":
        opts.update(ftol=1e-15, gtol=1e-12)
        res = minimize(fun, x0, jac=jac, method=method, bounds=list(zip(lo, hi)), options=opts)
    else:
        res = minimize(fun, x0, method=method, bounds=list(zip(lo, hi)), options=opts)
    x = np.clip(res.x, lo, hi)
    Jx, J0 = fun(x), fun(x0)
    return (x, Jx) if Jx <= J0 else (np.asarray(x0), J0)
