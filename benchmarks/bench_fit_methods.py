"""The refit's search methods side by side: success rate, evaluations to J*, wall time.

    python benchmarks/bench_fit_methods.py [--seeds 10] [--methods ga,ga-genes,cmaes,de]

On the default objective (``bodyvib fit --reference iso7962``: the paper's
Eq. 3, head and torso), each method runs with the shipped configuration and
no polish, once per seed 1..N; seeds are interleaved method by method, so the
machine's load falls on every method alike. Printed per method, over the
seeds: how many reach J*(1 + 1e-6) with J* = 1.4807819 1/s (the best known
value), the median and worst number of objective evaluations until they first
do, the median evaluations and generations run in all, the median wall time
of the search, and the worst relative excess over J*.

``ga-genes`` is the same genetic algorithm searching the genes themselves
instead of the aligned coordinates (``bodyvib.fit.methods.SearchSpace``): it
shows what the coordinates do. A last table times the default fit (GA and the
L-BFGS-B polish) with BLAS limited to one thread, as the command runs it,
against the BLAS default, side by side.
"""

import argparse
import statistics
import sys
import time
from dataclasses import replace

import numpy as np
from threadpoolctl import threadpool_limits

from bodyvib.fit.config import load_config, log_bounds
from bodyvib.fit.methods import search
from bodyvib.fit.objective import model_target
from bodyvib.fit.search import polish
from bodyvib.fit.space import genes_to_parameters

#: Best known objective of the default fit, 1/s (L-BFGS-B from every method's best agrees).
J_STAR = 1.4807819
#: Success: within this relative excess over J*.
TOLERANCE = 1e-6


def run(method, settings, seed, target, lo, hi):
    """One search; returns (result, evaluations until J*(1 + tol) or None, wall time)."""
    state = {"n": 0, "hit": None}
    M = target.total_mass

    def objective(genes):
        J = target.objective(genes_to_parameters(genes, M))
        if state["hit"] is None:
            ok = np.flatnonzero(J <= J_STAR * (1 + TOLERANCE))
            if ok.size:
                state["hit"] = state["n"] + int(ok[0]) + 1
        state["n"] += len(genes)
        return J

    t0 = time.perf_counter()
    r = search(method, objective, lo, hi, settings, seed)
    return r, state["hit"], time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--methods", default="ga,ga-genes,cmaes,de")
    ap.add_argument("--repeats", type=int, default=5, help="repeats of the polish timing")
    args = ap.parse_args(argv)
    cfg = load_config()
    target = model_target("iso7962", config=cfg)
    lo, hi = log_bounds(cfg)
    settings = {
        "ga": cfg.ga,
        "ga-genes": replace(cfg.ga, coordinates="genes"),
        "cmaes": cfg.cmaes,
        "de": cfg.de,
    }
    methods = args.methods.split(",")
    rows = {m: [] for m in methods}
    with threadpool_limits(1, user_api="blas"):
        for seed in range(1, args.seeds + 1):
            for m in methods:
                rows[m].append(run(m.split("-")[0], settings[m], seed, target, lo, hi))
                print(".", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    print(
        f"objective: paper Eq. 3 against iso7962 (head + torso), J* = {J_STAR} 1/s; "
        f"success: J <= J*(1 + {TOLERANCE:g}), no polish; seeds 1..{args.seeds}"
    )
    head = (
        f"{'method':<10} {'success':>8} {'evals to J* med':>16} {'max':>7} "
        f"{'evals med':>10} {'gens med':>9} {'wall s med':>11} {'worst J/J*-1':>13}"
    )
    print(head)
    for m, res in rows.items():
        hits = [h for _, h, _ in res if h is not None]
        worst = max(r.objective / J_STAR - 1 for r, _, _ in res)
        print(
            f"{m:<10} {len(hits):>5}/{len(res):<2} "
            f"{(statistics.median(hits) if hits else float('nan')):>16.0f} "
            f"{(max(hits) if hits else float('nan')):>7.0f} "
            f"{statistics.median(r.evaluations for r, _, _ in res):>10.0f} "
            f"{statistics.median(r.generations for r, _, _ in res):>9.0f} "
            f"{statistics.median(t for _, _, t in res):>11.3f} {worst:>13.1e}"
        )

    # the polish from the GA's best, BLAS on one thread against its default, interleaved
    best = rows[methods[0]][0][0].genes + 0.01

    def objective(genes):
        return target.objective(genes_to_parameters(genes, target.total_mass))

    times = {"1 thread": [], "BLAS default": []}
    for _ in range(args.repeats):
        for key, limit in (("1 thread", 1), ("BLAS default", None)):
            with threadpool_limits(limit, user_api="blas"):
                t0 = time.perf_counter()
                polish(objective, best, lo, hi, cfg.polish)
                times[key].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(
        f"L-BFGS-B polish from 0.01 decades off the optimum, median of {args.repeats}: "
        f"BLAS 1 thread {med['1 thread'] * 1e3:.0f} ms, BLAS default "
        f"{med['BLAS default'] * 1e3:.0f} ms (ratio {med['BLAS default'] / med['1 thread']:.1f})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
