"""Speed of the GA refit: the default fit's wall time and the vectorized objective.

    python benchmarks/bench_fit.py [--repeats 5] [--population 60]

Measured side by side in one run, interleaved repeat by repeat, medians printed:

* the default fit (``fit(model_target("iso7962"), seed=1)``: one seeded run of
  the genetic algorithm, 40 per generation until it stalls, then the polish),
  wall time; and the command a
  user runs (``bodyvib fit --reference iso7962 --seed 1``) in a fresh process,
  imports included;
* evaluations of the objective per second for one GA population:
  - vectorized: the whole population in one call (what the GA does);
  - per-individual loop: the same analytic objective called once per individual;
  - per-individual state space: build each individual's network, its state
    space and its frequency response on the same grid (what a fit without the
    analytic transfer functions would do);
  - time-domain definition: exact impulse responses and the trapezoid rule, per
    individual (why the search uses the Parseval form).
Ratios are of medians.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

from bodyvib.fit.config import load_config
from bodyvib.fit.objective import model_target, objective_time_domain, parameter_array
from bodyvib.fit.search import fit
from bodyvib.fit.space import GENES, genes_to_parameters, parameters_to_genes, reduced_network
from bodyvib.frequency.response import frequency_response
from bodyvib.models import load_model
from bodyvib.runtime.network import linear_model

REFIT = os.path.join(
    os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "params", "refit-iso7962.json"
)


def population(n, seed=0):
    """A mid-run GA population: log-normal, 0.3 decades around the shipped refit's
    ratios, within the bounds (uniform draws over the whole box include nearly
    undamped models whose time-domain horizon runs to hours)."""
    cfg = load_config()
    b = cfg.bounds_per_kg_total_mass
    lo, hi = np.log10([b[g][0] for g in GENES]), np.log10([b[g][1] for g in GENES])
    centre = parameters_to_genes(parameter_array(load_model(REFIT)))
    genes = centre + 0.3 * np.random.default_rng(seed).standard_normal((n, len(GENES)))
    return genes_to_parameters(np.clip(genes, lo, hi), 75.0)


def timed(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--population", type=int, default=60)
    args = ap.parse_args(argv)

    target = model_target("iso7962")
    P = population(args.population)
    f, roles = target.frequency_hz, list(target.pairs)
    n_state_space = min(args.population, 20)
    n_time = min(args.population, 10)

    def vectorized():
        target.objective(P)

    def loop():
        for p in P:
            target.objective(p)

    def state_space():
        for p in P[:n_state_space]:
            lm = linear_model(reduced_network(p))
            J = 0.0
            for role in roles:
                H = frequency_response(lm, f, f"{role}.x")
                J += 2 * (np.abs(H - target.responses[role]) ** 2) @ target.weights
        return J

    def time_domain():
        for p in P[:n_time]:
            objective_time_domain(target.reference, reduced_network(p), target.pairs)

    def default_fit():
        fit(model_target("iso7962"), seed=1)

    tmp = tempfile.TemporaryDirectory(prefix="bodyvib-bench-fit-")
    out = os.path.join(tmp.name, "refit.json")

    def cli():
        subprocess.run(
            [sys.executable, "-m", "bodyvib.cli", *"fit --reference iso7962 --seed 1".split()]
            + ["--out", out, "--quiet"],
            check=True,
        )

    vectorized(), loop(), state_space(), time_domain()  # warm up
    times = {k: [] for k in ("vectorized", "loop", "state_space", "time_domain", "fit", "cli")}
    for _ in range(args.repeats):
        times["vectorized"].append(statistics.median(timed(vectorized) for _ in range(20)))
        times["loop"].append(timed(loop))
        times["state_space"].append(timed(state_space))
        times["time_domain"].append(timed(time_domain))
        times["fit"].append(timed(default_fit))
        times["cli"].append(timed(cli))
    tmp.cleanup()
    med = {k: statistics.median(v) for k, v in times.items()}
    # each evaluation: its row label and how many individuals one timed call evaluates
    evaluations = {
        "vectorized": ("vectorized population (one call)", args.population),
        "loop": ("per-individual loop, analytic TFs", args.population),
        "state_space": ("per-individual state space + FRF", n_state_space),
        "time_domain": ("per-individual time-domain definition", n_time),
    }
    rate = {k: n / med[k] for k, (_, n) in evaluations.items()}
    print(
        f"objective: {len(roles)} pairs ({', '.join(roles)}), {f.size} quadrature nodes; "
        f"population {args.population}; medians of {args.repeats} interleaved repeats"
    )
    print(f"{'evaluation':<44} {'evals/s':>12} {'vectorized / this':>18}")
    for k, (label, _) in evaluations.items():
        print(f"{label:<44} {rate[k]:12.0f} {rate['vectorized'] / rate[k]:18.1f}")
    print(
        f"default fit (GA, 40 per generation, + polish), wall time: {med['fit']:.2f} s "
        f"(min {min(times['fit']):.2f}, max {max(times['fit']):.2f})"
    )
    print(f"'bodyvib fit --reference iso7962 --seed 1' in a fresh process: {med['cli']:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
