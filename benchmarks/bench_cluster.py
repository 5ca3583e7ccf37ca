"""What a Dask worker costs before it computes, and what a kept cluster saves.

    python benchmarks/bench_cluster.py [--cases 16] [--duration 30]

Measured, wall clock and the worker process's CPU seconds (psutil), on one-worker
LocalClusters started as ``bodyvib sweep`` starts them:

* **start**: from asking for the LocalCluster to a connected client with its
  worker (the worker imports Python, numpy, dask and distributed);
* **first sweep**: ``--cases`` batched cases sent to that fresh worker through
  its scheduler's address (``run_sweep(..., scheduler=ADDRESS)``): besides the
  cases it pays for unpickling the spec, importing the engines and the road
  synthesis (scipy.signal), importing numba and loading the compiled loop;
* **second sweep**: the same cases again on the same, now warm, worker: the
  price of the cases alone. The difference is what the worker's first task
  costs beyond its cases, which a cluster kept between sweeps pays once;
* the same on a LocalCluster whose worker preloads
  :mod:`bodyvib.vehicle.sweep.preload` (``dask worker --preload``): the warm-up
  moves into the start, and the first sweep costs what the second does.
"""

import argparse
import logging
import os
import sys
import time

from bodyvib.vehicle.sweep.run import run_sweep


def spec(cases: int, duration: float) -> dict:
    return {
        "road": "C",
        "speed": [10, 20],
        "seed": list(range(max(1, cases // 2))),
        "duration": duration,
        "step": 1e-3,
        "body": "reduced-paper",
    }


def worker_cpu(client) -> float:
    import psutil

    pids = client.run(os.getpid)
    return sum(sum(psutil.Process(p).cpu_times()[:2]) for p in pids.values())


def one(preload: bool, sp: dict, block: int):
    from dask.distributed import Client, LocalCluster

    t0 = time.perf_counter()
    cluster = LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        silence_logs=logging.CRITICAL + 1,
        preload=["bodyvib.vehicle.sweep.preload"] if preload else None,
    )
    client = Client(cluster)
    client.wait_for_workers(1)
    start = (time.perf_counter() - t0, worker_cpu(client))
    runs = []
    try:
        for _ in range(2):
            cpu0, t0 = worker_cpu(client), time.perf_counter()
            run_sweep(sp, scheduler=cluster.scheduler_address, block=block)
            runs.append((time.perf_counter() - t0, worker_cpu(client) - cpu0))
    finally:
        client.close()
        cluster.close()
    return start, runs


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--cases", type=int, default=16, help="cases per sweep (default 16)")
    p.add_argument("--duration", type=float, default=30.0, help="seconds per case (default 30)")
    args = p.parse_args(argv)
    sp = spec(args.cases, args.duration)
    print(f"load: {os.getloadavg()[0]:.2f} (1 min) on {os.cpu_count()} cores")
    print(f"one worker; sweeps of {args.cases} reduced-body cases of {args.duration:g} s, one task")
    print(
        f"  {'worker':18s} {'start':>15s} {'first sweep':>17s} {'second sweep':>17s} {'first - second':>17s}"
    )
    for preload in (False, True):
        (sw, sc), ((w1, c1), (w2, c2)) = one(preload, sp, args.cases)
        print(
            f"  {'preloaded' if preload else 'plain':18s} {sw:5.2f} s {sc:4.2f} CPU "
            f"{w1:6.2f} s {c1:5.2f} CPU {w2:6.2f} s {c2:5.2f} CPU {w1 - w2:6.2f} s {c1 - c2:5.2f} CPU"
        )
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
