"""Search methods of the refit: a genetic algorithm (default), CMA-ES, differential evolution.

Every method minimizes the same vectorized objective over the same bounded
search space (:class:`SearchSpace`) and returns a :class:`SearchResult`; the
genetic algorithm is the paper's method, CMA-ES (the ``cma`` package) and
differential evolution (``scipy.optimize.differential_evolution``) are there
to compare it with (``bodyvib fit --method``, ``benchmarks/bench_fit_methods.py``).

**Coordinates.** The fit's genes are ``log10`` of ``m1/M, k1/M, k2/M, ks/M,
c1/M, c2/M`` (:data:`bodyvib.fit.space.GENES`), bounded by the configuration. The
methods search a linear change of them,

    z = (log m1/M, log k1/m1, log k2/M, log ks/M, log c1/m1, log c2/M),

the head's mass fraction, the square of its natural frequency ``k1/m1`` and
its damping rate ``c1/m1``. In the genes the objective's valley runs along
``m1, k1, c1`` together (a heavier head on a stiffer, more damped neck: the
head's frequency and damping ratio barely change); per-gene operators, which
is what a genetic algorithm's crossover and mutation are, crawl along such a
diagonal valley. In ``z`` it runs along one axis. The box of ``z`` encloses
the genes' box; a point outside the genes' box is clipped onto it
(:meth:`SearchSpace.genes`), so every evaluated model is within the
configured bounds.

**The genetic algorithm** (:func:`ga_search`, DEAP's operators): a
real-coded generational GA with elitism, tournament selection
(``deap.tools.selTournament``), simulated binary crossover
(``deap.tools.cxSimulatedBinaryBounded``, a small distribution index keeps
children spread as far as their parents are) and a local Gaussian mutation
whose step in each coordinate is the population's current spread in it, so
the mutation explores while the population is spread and refines as it
converges. It stops when the best objective has improved by less than a
relative ``ftol`` over ``stall_generations`` generations, or after
``generations``.
"""

import functools
import math
import random
from dataclasses import dataclass, field
from typing import Callable, List, Optional

import numpy as np

from ..runtime.errors import BodyvibError

__all__ = [
    "METHODS",
    "COORDINATES",
    "SearchSpace",
    "SearchResult",
    "CountedObjective",
    "search",
    "describe",
    "ga_search",
    "cmaes_search",
    "de_search",
    "nsga2_front",
]

#: Search methods of ``bodyvib fit --method``, the default first.
METHODS = ("ga", "cmaes", "de")

#: Coordinates a method can search (``coordinates`` of its settings; :class:`SearchSpace`).
COORDINATES = ("aligned", "genes")


class SearchSpace:
    """The bounded search coordinates ``z`` and their map to the fit's genes.

    Parameters
    ----------
    lo, hi : array_like, shape (6,)
        Bounds of the genes (``log10`` of ``m1/M, k1/M, k2/M, ks/M, c1/M,
        c2/M``).
    aligned : bool
        Search the aligned coordinates ``z`` (module docstring); False: the
        genes themselves (``z`` = genes).

    Attributes
    ----------
    lo, hi : ndarray
        The genes' bounds.
    zlo, zhi : ndarray
        The box of ``z`` that encloses them.

    Examples
    --------
    >>> s = SearchSpace([-1.7, 1, 1, 2, -1, -1], [-0.4, 5, 5, 6, 3, 3])
    >>> g = np.array([-0.6, 3.5, 2.9, 4.0, 0.9, 1.6])
    >>> bool(np.allclose(s.genes(s.coordinates(g)), g))
    True
    """

    def __init__(self, lo, hi, aligned: bool = True):
        self.lo = np.asarray(lo, dtype=float)
        self.hi = np.asarray(hi, dtype=float)
        self.aligned = bool(aligned)
        # z = T x: subtract log(m1/M) from log(k1/M) and log(c1/M)
        self._T = np.eye(len(self.lo))
        if not self.aligned:
            self._Tinv, self.zlo, self.zhi = self._T, self.lo, self.hi
            return
        self._T[1, 0] = self._T[4, 0] = -1.0
        self._Tinv = np.linalg.inv(self._T)
        lo_, hi_ = self.lo, self.hi
        self.zlo = np.array([lo_[0], lo_[1] - hi_[0], lo_[2], lo_[3], lo_[4] - hi_[0], lo_[5]])
        self.zhi = np.array([hi_[0], hi_[1] - lo_[0], hi_[2], hi_[3], hi_[4] - lo_[0], hi_[5]])

    def genes(self, z) -> np.ndarray:
        """Genes of search points, clipped onto the genes' bounds (shape ``(..., 6)``)."""
        return np.clip(np.asarray(z, dtype=float) @ self._Tinv.T, self.lo, self.hi)

    def coordinates(self, genes) -> np.ndarray:
        """Search coordinates of genes (shape ``(..., 6)``)."""
        return np.asarray(genes, dtype=float) @ self._T.T


@dataclass
class SearchResult:
    """Outcome of one search.

    Attributes
    ----------
    genes : ndarray, shape (6,)
        Best genes found (within the bounds).
    objective : float
        Their objective, 1/s.
    evaluations : int
        Objective evaluations (parameter sets).
    generations : int
        Generations (iterations) run.
    history : list of float
        Best objective after each generation.
    stopped : str
        Why it stopped.
    """

    genes: np.ndarray
    objective: float
    evaluations: int
    generations: int
    history: List[float] = field(default_factory=list)
    stopped: str = ""


class CountedObjective:
    """The objective on a space's search coordinates, counting evaluations and keeping the best.

    What every search method minimizes: :func:`search` wraps the objective once.

    Parameters
    ----------
    objective : callable
        ``objective(genes)`` with ``genes`` of shape ``(n, 6)`` returns ``n``
        objective values (``inf`` or NaN where a model is not finite).
    space : SearchSpace
    """

    def __init__(self, objective, space):
        self.objective, self.space = objective, space
        self.evaluations = 0
        self.best_J, self.best_genes = math.inf, None

    def __call__(self, z) -> np.ndarray:
        g = self.space.genes(np.atleast_2d(z))
        J = np.asarray(self.objective(g), dtype=float).reshape(len(g))
        J = np.where(np.isfinite(J), J, np.inf)
        self.evaluations += len(g)
        i = int(np.argmin(J))
        if J[i] < self.best_J:
            self.best_J, self.best_genes = float(J[i]), g[i].copy()
        return J

    def result(self, generations, history, stopped):
        return SearchResult(
            genes=self.best_genes,
            objective=self.best_J,
            evaluations=self.evaluations,
            generations=generations,
            history=history,
            stopped=stopped,
        )


def _stalled(history, ftol, stall):
    """Best improved by less than ``ftol`` (relative) over the last ``stall`` generations."""
    return len(history) > stall and history[-stall - 1] - history[-1] <= ftol * abs(history[-1])


def _end_generation(best: float, history: list, on_generation, settings=None) -> Optional[str]:
    """Record and report a generation's best objective; why to stop, if the search stalled.

    Every method ends a generation so; ``settings`` (``ftol``, ``stall_generations``)
    None for a method with its own stopping rule.
    """
    history.append(best)
    if on_generation is not None:
        on_generation(best)
    if settings is not None and _stalled(
        history, float(settings.ftol), int(settings.stall_generations)
    ):
        return (
            f"best improved by less than {settings.ftol:g} (relative) in "
            f"{settings.stall_generations} generations"
        )
    return None


def ga_search(
    f: CountedObjective,
    settings,
    seed: int,
    on_generation: Optional[Callable[[float], None]] = None,
) -> SearchResult:
    """Minimize ``f`` by the real-coded genetic algorithm (DEAP's operators).

    Each generation: ``population`` parents are drawn by tournaments of
    ``tournament_size``; consecutive pairs are crossed by bounded simulated
    binary crossover (distribution index ``crossover_eta``, each gene with
    probability 1/2); each child is mutated with probability
    ``mutation_probability`` by a Gaussian step of ``mutation_scale`` times
    the population's standard deviation in each coordinate, clipped to the
    box; the ``elitism`` best parents survive unchanged next to the best
    ``population - elitism`` children.

    Parameters
    ----------
    f : CountedObjective
        The objective on the search space's coordinates.
    settings : bodyvib.fit.config.GaSettings
        ``population``, ``generations``, ``tournament_size``, ``elitism``,
        ``crossover_eta``, ``mutation_probability``, ``mutation_scale``,
        ``ftol``, ``stall_generations`` (the configuration's ``ga`` section).
    seed : int
        Seeds the initial population and every operator. DEAP draws from
        Python's ``random`` module; its state is restored afterwards.
    on_generation : callable, optional
        Called with the best objective after each generation (progress).

    Returns
    -------
    SearchResult
    """
    from deap import tools

    Individual = _individual_type()
    space = f.space
    n, elite = int(settings.population), int(settings.elitism)
    low, up = list(space.zlo), list(space.zhi)
    eta = float(settings.crossover_eta)
    p_mut, scale = float(settings.mutation_probability), float(settings.mutation_scale)
    rng = np.random.default_rng(seed)
    tournament = int(settings.tournament_size)

    def breed(pop):
        """``n`` children of one population: tournaments, SBX, the local mutation."""
        parents = tools.selTournament(pop, n + n % 2, tournsize=tournament)
        children = [Individual(p) for p in parents]
        for a, b in zip(children[::2], children[1::2]):
            tools.cxSimulatedBinaryBounded(a, b, eta, low, up)
        C = np.array(children[:n])
        spread = np.array(pop).std(axis=0)
        mutate = rng.random(len(C)) < p_mut
        C[mutate] += scale * spread * rng.standard_normal((int(mutate.sum()), len(low)))
        return np.clip(C, space.zlo, space.zhi)

    saved = random.getstate()
    random.seed(seed)
    try:
        X = space.zlo + rng.random((n, len(low))) * (space.zhi - space.zlo)
        pop = _individuals(X, f(X))
        history, stopped, gen = [], f"{settings.generations} generations", 0
        for gen in range(1, int(settings.generations) + 1):  # noqa: B007 (read after the loop)
            C = breed(pop)
            pop = tools.selBest(pop, elite) + tools.selBest(_individuals(C, f(C)), n - elite)
            stall = _end_generation(f.best_J, history, on_generation, settings)
            if stall:
                stopped = stall
                break
    finally:
        random.setstate(saved)
    return f.result(gen, history, stopped)


# Not a cache of results: a class made once per process (the functools idiom), on first
# use so that importing this module does not import DEAP.
@functools.cache
def _individual_type():
    """DEAP's individual: a list of coordinates with a minimized ``fitness`` (made once)."""
    from deap import base

    class Fitness(base.Fitness):
        weights = (-1.0,)

    class Individual(list):
        __slots__ = ("fitness",)

        def __init__(self, values=(), J=None):
            super().__init__(values)
            self.fitness = Fitness() if J is None else Fitness((J,))

    return Individual


def _individuals(X, J):
    Individual = _individual_type()
    return [Individual(x, float(j)) for x, j in zip(X, J)]


def cmaes_search(
    f: CountedObjective,
    settings,
    seed: int,
    on_generation: Optional[Callable[[float], None]] = None,
) -> SearchResult:
    """Minimize ``f`` by CMA-ES (``cma.CMAEvolutionStrategy``), a comparator.

    It searches the box scaled to ``[0, 1]^6`` (``cma``'s bound handling),
    from the centre of the box moved by up to 0.05 at random (``seed``),
    with step ``sigma0``; from uniform random starts it ended in a worse basin
    in 4 of 10 seeds.

    Parameters
    ----------
    f, seed, on_generation
        As :func:`ga_search`.
    settings : bodyvib.fit.config.CmaesSettings
        ``sigma0`` (in the unit box), ``population`` (0: CMA-ES's default,
        ``4 + 3 ln 6 = 9``), ``max_evaluations``, ``ftol`` and
        ``stall_generations`` (it stops as :func:`ga_search` does, or on
        ``cma``'s own criteria).

    A box of one coordinate, which ``cma`` cannot search (its bound handling needs two
    or more: ``not yet initialized (dimension needed)``), is searched by
    :func:`_scalar_search` instead.

    Returns
    -------
    SearchResult
    """
    import cma

    space = f.space
    span = space.zhi - space.zlo
    if len(span) == 1:
        return _scalar_search(f, space, settings, on_generation)
    rng = np.random.default_rng(seed)
    x0 = 0.5 + 0.1 * (rng.random(len(span)) - 0.5)
    opts = {
        "bounds": [0.0, 1.0],
        "seed": int(seed) + 1,
        "verbose": -9,
        "maxfevals": int(settings.max_evaluations),
        "tolfun": 0.0,
        "tolx": 1e-14,
        "tolflatfitness": 10,
    }
    if int(settings.population) > 0:
        opts["popsize"] = int(settings.population)
    es = cma.CMAEvolutionStrategy(x0, float(settings.sigma0), opts)
    history, gen, stopped = [], 0, ""
    while not es.stop():
        U = np.array(es.ask())
        es.tell(list(U), list(f(space.zlo + U * span)))
        gen += 1
        stopped = _end_generation(f.best_J, history, on_generation, settings) or ""
        if stopped:
            break
    return f.result(gen, history, stopped or "cma: " + ", ".join(es.stop()))


def _scalar_search(
    f: CountedObjective, space: SearchSpace, settings, on_generation
) -> SearchResult:
    """Minimize over one coordinate: the best of an even grid, refined by bounded Brent.

    The grid has ``population`` points (CMA-ES's default of 9 for 0; at least 3) spread
    over the box, ends included, so a function with several minima is searched over the
    whole box as CMA-ES's first generation would; Brent's method
    (``scipy.optimize.minimize_scalar``, ``method="bounded"``) then refines the best
    point between its two neighbours, within the rest of ``max_evaluations``, to
    ``1e-12`` of the box. Two generations: the grid, the refinement.
    """
    from scipy.optimize import minimize_scalar

    lo, hi = float(space.zlo[0]), float(space.zhi[0])
    budget = int(settings.max_evaluations)
    n = max(3, min(int(settings.population) or 9, budget))
    z = np.linspace(lo, hi, n)
    J = f(z[:, None])
    history: List[float] = []
    _end_generation(f.best_J, history, on_generation)
    i = int(np.argmin(J))
    stopped = f"one coordinate: the best of {n} even points"
    if budget > n:
        res = minimize_scalar(
            lambda x: float(f(np.array([[x]]))[0]),
            bounds=(z[max(i - 1, 0)], z[min(i + 1, n - 1)]),
            method="bounded",
            options={"xatol": 1e-12 * (hi - lo), "maxiter": budget - n},
        )
        _end_generation(f.best_J, history, on_generation)
        stopped += f", refined by bounded Brent (scipy: {res.message})"
    return f.result(len(history), history, stopped)


def de_search(
    f: CountedObjective,
    settings,
    seed: int,
    on_generation: Optional[Callable[[float], None]] = None,
) -> SearchResult:
    """Minimize ``objective`` by differential evolution (scipy), a comparator.

    ``scipy.optimize.differential_evolution`` with ``vectorized=True`` (the
    whole population per call), ``updating="deferred"``, no polish of its own.

    Parameters
    ----------
    f, seed, on_generation
        As :func:`ga_search`.
    settings : bodyvib.fit.config.DeSettings
        ``population_per_gene`` (scipy's ``popsize``), ``generations``
        (``maxiter``), ``tol``, ``strategy``, ``mutation`` ([low, high]
        dithering), ``recombination``.

    Returns
    -------
    SearchResult
    """
    from scipy.optimize import differential_evolution

    space = f.space
    history = []

    def callback(*_args, **_kwargs):
        _end_generation(f.best_J, history, on_generation)

    res = differential_evolution(
        lambda zt: f(zt.T),
        list(zip(space.zlo, space.zhi)),
        vectorized=True,
        updating="deferred",
        seed=int(seed),
        polish=False,
        tol=float(settings.tol),
        popsize=int(settings.population_per_gene),
        maxiter=int(settings.generations),
        strategy=settings.strategy,
        mutation=tuple(settings.mutation),
        recombination=float(settings.recombination),
        callback=callback,
    )
    return f.result(int(res.nit), history, f"scipy: {res.message}")


_SEARCH = {"ga": ga_search, "cmaes": cmaes_search, "de": de_search}


def search(
    method: str,
    objective: Callable,
    lo,
    hi,
    settings,
    seed: int,
    on_generation: Optional[Callable[[float], None]] = None,
) -> SearchResult:
    """Minimize ``objective`` over the genes' box by one of :data:`METHODS`.

    Parameters
    ----------
    method : str
        ``"ga"``, ``"cmaes"`` or ``"de"``.
    objective : callable
        Vectorized over genes of shape ``(n, 6)``.
    lo, hi : array_like, shape (6,)
        Bounds of the genes.
    settings : GaSettings, CmaesSettings or DeSettings
        The method's section of the configuration.
    seed : int
        Non-negative; the same seed gives the same search.
    on_generation : callable, optional
        Called with the best objective after each generation.

    Returns
    -------
    SearchResult

    Raises
    ------
    BodyvibError
        An unknown method.

    Examples
    --------
    >>> sphere = lambda g: ((g - 0.5) ** 2).sum(axis=-1)
    >>> from bodyvib.fit.config import GaSettings
    >>> s = GaSettings(population=30, generations=300, tournament_size=3, elitism=2,
    ...                crossover_eta=2.0, mutation_probability=0.6, mutation_scale=1.0,
    ...                ftol=1e-12, stall_generations=20, coordinates="aligned")
    >>> r = search("ga", sphere, [-1] * 6, [2] * 6, s, seed=1)
    >>> bool(r.objective < 1e-10)
    True
    """
    if method not in _SEARCH:
        raise BodyvibError(f"unknown search method '{method}'; methods are {', '.join(METHODS)}")
    space = SearchSpace(lo, hi, aligned=settings.coordinates == "aligned")
    return _SEARCH[method](CountedObjective(objective, space), settings, int(seed), on_generation)


def nsga2_front(
    evaluate: Callable,
    bounds: tuple,
    objectives: int,
    settings,
    seed: int,
    constraints: int = 0,
    sampling: Optional[np.ndarray] = None,
    callback: Optional[Callable] = None,
) -> tuple:
    """NSGA-II (pymoo) over a box: the one set-up of the refit's front and the design search.

    Simulated binary crossover with probability 0.9, polynomial mutation, duplicates
    eliminated; one vectorized evaluation per generation.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(X)`` of the rows of a population: the objectives ``F`` (rows), or
        ``(F, G)`` with the inequality constraints ``G`` (feasible where ``G <= 0``)
        when ``constraints`` is not zero.
    bounds : (int, lower, upper)
        The number of coordinates and their bounds (floats or arrays).
    objectives : int
        Number of objectives.
    settings : bodyvib.fit.config.ParetoSettings
        ``population``, ``generations`` and the distribution indices of the crossover
        and the mutation (``crossover_eta``, ``mutation_eta``).
    seed : int
    constraints : int
        Number of inequality constraints.
    sampling : ndarray, optional
        The first population (rows); pymoo's uniform random sampling by default.
    callback : callable, optional
        Called with the algorithm after each generation.

    Returns
    -------
    X, F : ndarray or None
        The final non-dominated designs and their objectives, as pymoo returns them
        (``None`` when no design is feasible).

    Examples
    --------
    >>> from bodyvib.fit.config import ParetoSettings
    >>> X, F = nsga2_front(lambda x: np.column_stack([x[:, 0], 1 - x[:, 0]]), (1, 0.0, 1.0),
    ...                    2, ParetoSettings(8, 3, crossover_eta=10.0, mutation_eta=20.0), seed=1)
    >>> bool(np.allclose(F.sum(axis=1), 1.0))
    True
    """
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.problem import Problem
    from pymoo.operators.crossover.sbx import SBX
    from pymoo.operators.mutation.pm import PM
    from pymoo.optimize import minimize

    n_var, lower, upper = bounds

    class Trade(Problem):
        def __init__(self):
            super().__init__(
                n_var=n_var, n_obj=objectives, n_ieq_constr=constraints, xl=lower, xu=upper
            )

        def _evaluate(self, x, out, *args, **kwargs):
            if constraints:
                out["F"], out["G"] = evaluate(x)
            else:
                out["F"] = evaluate(x)

    options = {} if sampling is None else {"sampling": sampling}
    algorithm = NSGA2(
        pop_size=settings.population,
        crossover=SBX(prob=0.9, eta=settings.crossover_eta),
        mutation=PM(eta=settings.mutation_eta),
        eliminate_duplicates=True,
        **options,
    )
    run = {} if callback is None else {"callback": callback}
    termination = ("n_gen", settings.generations)
    res = minimize(Trade(), algorithm, termination, seed=seed, verbose=False, **run)
    return res.X, res.F


def describe(method: str) -> str:
    """One line naming a method's library and version, for provenance.

    Parameters
    ----------
    method : str
        One of :data:`METHODS`.

    Returns
    -------
    str
    """
    from importlib.metadata import version

    if method == "ga":
        return (
            f"deap {version('deap')} (tools.selTournament, tools.cxSimulatedBinaryBounded, "
            "tools.selBest) with bodyvib.fit.methods' Gaussian mutation scaled by the "
            "population's spread: a real-coded generational GA with elitism"
        )
    if method == "cmaes":
        return f"cma {version('cma')} (cma.CMAEvolutionStrategy, ask/tell, bounds [0, 1]^6)"
    if method == "de":
        return (
            f"scipy {version('scipy')} (scipy.optimize.differential_evolution, vectorized, "
            "deferred updating, no polish of its own)"
        )
    raise BodyvibError(f"unknown search method '{method}'; methods are {', '.join(METHODS)}")
