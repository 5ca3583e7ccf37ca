"""The refit's search methods: the GA reaches the best known J by itself, CMA-ES and DE too."""

from importlib.metadata import version

import numpy as np
import pytest

from bodyvib.fit.config import load_config, log_bounds
from bodyvib.fit.methods import METHODS, SearchSpace, describe, search
from bodyvib.fit.objective import model_target
from bodyvib.fit.search import fit
from bodyvib.fit.space import genes_to_parameters
from bodyvib.runtime.errors import BodyvibError

#: Best known value of the default objective (paper Eq. 3, head + torso, against iso7962), 1/s:
#: L-BFGS-B from the best of every method, and from 59 of 60 random starts, ends there.
J_STAR = 1.4807819
#: "Reaches J*": within this relative excess (the issue's criterion; J* itself is rounded
#: to 8 digits, 3e-8 relative, far inside it).
TOL = 1e-6


@pytest.fixture(scope="module")
def problem():
    cfg = load_config()
    target = model_target("iso7962", config=cfg)
    lo, hi = log_bounds(cfg)
    return cfg, target, lo, hi


def objective(target):
    return lambda g: target.objective(genes_to_parameters(g, target.total_mass))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_ga_alone_reaches_the_best_known_objective(problem, seed):
    """No polish: the genetic algorithm itself gets within 1e-6 of J* (10 of 10 seeds in
    benchmarks/bench_fit_methods.py; three here to keep the suite short)."""
    cfg, target, lo, hi = problem
    r = search("ga", objective(target), lo, hi, cfg.ga, seed)
    assert r.objective <= J_STAR * (1 + TOL)
    assert np.all(r.genes >= lo) and np.all(r.genes <= hi)
    assert r.evaluations == cfg.ga.population * (r.generations + 1)
    assert r.history == sorted(r.history, reverse=True)  # elitism: the best never worsens


@pytest.mark.parametrize("method", ["cmaes", "de"])
def test_comparators_reach_the_best_known_objective(problem, method):
    cfg, target, lo, hi = problem
    r = search(method, objective(target), lo, hi, cfg.settings(method), seed=1)
    assert r.objective <= J_STAR * (1 + TOL)
    lib = {"cmaes": "cma", "de": "scipy"}[method]
    assert f"{lib} {version(lib)}" in describe(method)  # the provenance names the library


def test_fit_with_no_polish_records_the_method_and_is_reproducible(problem):
    cfg, target, _, _ = problem
    a = fit(target, cfg, seed=2, polish=False)
    b = fit(target, cfg, seed=2, polish=False)
    assert a.method == "ga" and a.parameters == b.parameters and a.history == b.history
    assert a.objective == a.ga_objective <= J_STAR * (1 + TOL)


def test_search_space_maps_aligned_coordinates_onto_the_genes_box():
    lo, hi = np.array([-1.7, 1, 1, 2, -1, -1.0]), np.array([-0.4, 5, 5, 6, 3, 3.0])
    s = SearchSpace(lo, hi)
    rng = np.random.default_rng(0)
    g = lo + rng.random((50, 6)) * (hi - lo)
    z = s.coordinates(g)
    np.testing.assert_allclose(s.genes(z), g, atol=1e-12)
    # z is (log m1/M, log k1/m1, ..., log c1/m1, ...): differences of genes
    np.testing.assert_allclose(z[:, 1], g[:, 1] - g[:, 0], atol=1e-12)
    np.testing.assert_allclose(z[:, 4], g[:, 4] - g[:, 0], atol=1e-12)
    # the z box encloses the genes' box; any z maps inside the bounds
    assert np.all(z >= s.zlo - 1e-12) and np.all(z <= s.zhi + 1e-12)
    wild = s.zlo + rng.random((200, 6)) * (s.zhi - s.zlo)
    assert np.all(s.genes(wild) >= lo) and np.all(s.genes(wild) <= hi)
    plain = SearchSpace(lo, hi, aligned=False)
    np.testing.assert_array_equal(plain.genes(g), g)


def test_unknown_method_is_refused(problem):
    cfg, target, lo, hi = problem
    assert METHODS == ("ga", "cmaes", "de")
    with pytest.raises(BodyvibError, match="unknown search method 'pso'"):
        search("pso", objective(target), lo, hi, cfg.ga, 1)
