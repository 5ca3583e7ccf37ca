"""Speed of ``bodyvib design``: a two-objective design over four parameters, three roads.

    python benchmarks/bench_design.py [--population 40] [--generations 40] [--no-verify]

The quarter car with a seat cushion (``quarter-car-cushion``) under the reduced body:
suspension ``ks, cs`` and cushion ``kc, cc`` tuned (log-scaled bounds) for the head's
Wk-weighted r.m.s. against the dynamic tire load ratio, the 3-sigma suspension travel
within a 70 mm rattle space, over three operating points (class B at 30 m/s, C at
20 m/s, D at 10 m/s). NSGA-II evaluates every candidate by one Lyapunov solve
(:mod:`bodyvib.vehicle.design.stationary`); the three chosen designs are then
verified by 30 s time-domain runs at each operating point. Prints the wall times,
evaluations per second and the load average (the machine may be shared); the target
is under 60 s in all on 2 cores.
"""

import argparse
import os
import time

from bodyvib.vehicle.design import design, parse_spec
from bodyvib.vehicle.design.report import format_summary

SPEC = {
    "car": "quarter-car-cushion",
    "body": "reduced-paper",
    "parameters": {
        "ks": {"min": 8000, "max": 60000, "scale": "log"},
        "cs": {"min": 200, "max": 8000, "scale": "log"},
        "kc": {"min": 10000, "max": 200000, "scale": "log"},
        "cc": {"min": 100, "max": 3000, "scale": "log"},
    },
    "operating_points": [
        {"road": "B", "speed": 30},
        {"road": "C", "speed": 20},
        {"road": "D", "speed": 10},
    ],
    "objectives": ["head_wk_rms", "tire_load_ratio"],
    "constraints": {"travel_ratio": 1.0},
    "rattle_space": 0.07,
}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--population", type=int, default=40)
    p.add_argument("--generations", type=int, default=40)
    p.add_argument("--no-verify", action="store_true")
    a = p.parse_args()
    spec = parse_spec(
        {**SPEC, "search": {"population": a.population, "generations": a.generations, "seed": 1}}
    )
    load = os.getloadavg()
    t0 = time.perf_counter()
    r = design(spec, verify=not a.no_verify)
    wall = time.perf_counter() - t0
    print(format_summary(r))
    print(
        f"\nsearch {r.elapsed_s:.1f} s ({r.evaluations / r.elapsed_s:.0f} evaluations/s), "
        f"verification {r.verify_s:.1f} s, total {wall:.1f} s (target < 60 s); "
        f"load average before {load[0]:.2f}, after {os.getloadavg()[0]:.2f} "
        f"on {os.cpu_count()} cores"
    )


if __name__ == "__main__":
    main()
