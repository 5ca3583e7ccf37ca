"""What a Dask worker costs before it computes, and what a kept cluster saves.

    python benchmarks/bench_cluster.py [--cases 16] [--duration 30]

Measured, wall clock and CPU seconds of this process's children (the LocalCluster's
worker processes and the server they fork from; psutil), on one-worker LocalClusters
started as ``bodyvib sweep`` starts them (:func:`bodyvib.vehicle.sweep.cluster.open_cluster`):

* **start**: from asking for the LocalCluster to a connected client with its
  worker. The worker forks from a server process that has imported distributed
  and the engines and loaded the compiled loop (:mod:`bodyvib.vehicle.sweep.warmed`);
  the first cluster of a process starts that server, later ones reuse it;
* **first sweep**: ``--cases`` batched cases sent to that fresh worker through
  its scheduler's address (``run_sweep(..., scheduler=ADDRESS)``);
* **second sweep**: the same cases again on the same worker: the price of the
  cases alone. The difference is what the worker's first task costs beyond its
  cases;
* the same on a plain ``distributed.LocalCluster`` (each worker a fresh Python
  process that imports everything with its first task), for comparison.
"""

import argparse
import logging
import os
import sys
import time
from contextlib import contextmanager

from bodyvib.vehicle.sweep.cluster import open_cluster
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


def children_cpu() -> float:
    """CPU seconds of this process's live children (workers, the fork server), recursively."""
    import psutil

    total = 0.0
    for p in psutil.Process().children(recursive=True):
        try:
            total += sum(p.cpu_times()[:2])
        except psutil.NoSuchProcess:
            pass
    return total


@contextmanager
def plain_cluster():
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        silence_logs=logging.CRITICAL + 1,
    )
    client = Client(cluster)
    try:
        yield cluster.scheduler_address
    finally:
        client.close()
        cluster.close()


@contextmanager
def sweep_cluster():
    with open_cluster(workers=1) as cl:
        yield cl.client.scheduler.address


def one(kind, sp: dict, block: int):
    cpu0, t0 = children_cpu(), time.perf_counter()
    with kind() as address:
        start = (time.perf_counter() - t0, children_cpu() - cpu0)
        runs = []
        for _ in range(2):
            cpu0, t0 = children_cpu(), time.perf_counter()
            run_sweep(sp, scheduler=address, block=block)
            runs.append((time.perf_counter() - t0, children_cpu() - cpu0))
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
    kinds = (
        ("plain LocalCluster", plain_cluster),
        ("sweep's, first", sweep_cluster),
        ("sweep's, next", sweep_cluster),
    )
    for name, kind in kinds:
        (sw, sc), ((w1, c1), (w2, c2)) = one(kind, sp, args.cases)
        print(
            f"  {name:18s} {sw:5.2f} s {sc:4.2f} CPU "
            f"{w1:6.2f} s {c1:5.2f} CPU {w2:6.2f} s {c2:5.2f} CPU {w1 - w2:6.2f} s {c1 - c2:5.2f} CPU"
        )
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
