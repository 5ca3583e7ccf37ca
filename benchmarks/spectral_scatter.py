"""How far one 30 s time run is from the spectral engine's expectation, over many seeds.

    python benchmarks/spectral_scatter.py [--seeds 40] [--duration 30]

For the shipped bodies on the quarter car, ISO 8608 class C at 10, 20 and 30
m/s, ``--seeds`` random roads each: the batched engine's head Wk r.m.s. of each
run against the spectral engine's expected value for the same case. Prints,
per body and speed, the mean, standard deviation and range of
``batched / spectral - 1`` in per cent.
"""

import argparse

import numpy as np

from bodyvib.vehicle.sweep.run import run_sweep


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=40)
    ap.add_argument("--duration", type=float, default=30.0)
    a = ap.parse_args(argv)
    spec = {
        "road": "C",
        "speed": [10, 20, 30],
        "seed": f"0..{a.seeds - 1}",
        "duration": a.duration,
        "body": ["reduced-paper", "iso7962"],
    }
    time_runs = run_sweep(spec, scheduler="serial")
    expected = run_sweep(spec, engine="spectral", scheduler="serial")
    dev = 100 * (time_runs["head_weighted_rms"] / expected["head_weighted_rms"] - 1)
    df = time_runs.assign(dev=dev)
    print(
        f"head Wk r.m.s., {a.duration:g} s runs against the spectral expectation "
        f"({a.seeds} seeds per row), per cent"
    )
    print(f"{'body':15s} {'speed':>6s} {'mean':>7s} {'std':>6s} {'min':>7s} {'max':>7s}")
    for (body, speed), g in df.groupby(["body", "speed"]):
        print(
            f"{body:15s} {speed:6.0f} {g.dev.mean():7.2f} {g.dev.std():6.2f} "
            f"{g.dev.min():7.2f} {g.dev.max():7.2f}"
        )
    print(
        f"{'all':15s} {'':6s} {dev.mean():7.2f} {dev.std():6.2f} {dev.min():7.2f} "
        f"{dev.max():7.2f}   ({len(dev)} runs)"
    )
    return np.asarray(dev)


if __name__ == "__main__":
    main()
