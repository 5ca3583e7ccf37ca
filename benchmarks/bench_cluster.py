"""How long a sweep's Dask worker takes to be ready, and what a kept cluster saves.

    python benchmarks/bench_cluster.py [--repeat 3] [--cases 16] [--duration 30]

Each repeat runs in a fresh Python process that has imported the sweep's module
(:mod:`bodyvib.vehicle.sweep.run`, as ``bodyvib sweep`` has) and not distributed.
It measures, wall clock and CPU seconds (this process; its children: the worker
processes and the server they fork from, psutil), on one-worker LocalClusters
started as ``bodyvib sweep`` starts them
(:func:`bodyvib.vehicle.sweep.cluster.open_cluster`):

* **start**: from asking for the LocalCluster to a connected client with its
  worker. The worker forks from a server process that imports distributed and
  the engines and loads the compiled loop (:mod:`bodyvib.vehicle.sweep.warmed`);
  the first cluster of a process starts that server, later ones reuse it. As
  ``run_sweep`` does, this process imports what it makes the table with (pandas)
  while the server warms up; with the plain cluster, in its first sweep;
* **first sweep**: ``--cases`` batched cases sent to that fresh worker through
  its scheduler's address (``run_sweep(..., scheduler=ADDRESS)``);
* **second sweep**: the same cases again on the same worker: the price of the
  cases alone. The difference is what the worker's first task costs beyond its
  cases;
* **ready**: start plus that difference: how long a fresh worker takes before it
  computes as fast as a warm one;
* the same on a plain ``distributed.LocalCluster`` (each worker a fresh Python
  process that imports everything with its first task), for comparison.

Each row prints the median of the repeats and, in brackets, their range.
"""

import argparse
import json
import logging
import os
import statistics
import subprocess
import sys
import time
from contextlib import contextmanager

from bodyvib.vehicle.sweep.cluster import open_cluster
from bodyvib.vehicle.sweep.run import run_sweep

KINDS = ("plain LocalCluster", "sweep's, first", "sweep's, next")


def spec(cases: int, duration: float) -> dict:
    return {
        "road": "C",
        "speed": [10, 20],
        "seed": list(range(max(1, cases // 2))),
        "duration": duration,
        "step": 1e-3,
        "body": "reduced-paper",
    }


def cpu_times() -> tuple:
    """CPU seconds of this process and of its live children (recursively)."""
    import psutil

    me = psutil.Process()
    children = 0.0
    for p in me.children(recursive=True):
        try:
            children += sum(p.cpu_times()[:2])
        except psutil.NoSuchProcess:
            pass
    return sum(me.cpu_times()[:2]), children


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


def table_imports() -> None:
    """What ``run_sweep`` imports while a LocalCluster's workers start (for its table)."""
    import pandas  # noqa: F401
    import pyarrow.parquet  # noqa: F401


@contextmanager
def sweep_cluster():
    with open_cluster(workers=1, meanwhile=table_imports) as cl:
        yield cl.client.scheduler.address


def timed(fn) -> dict:
    """Wall, this process's and its children's CPU seconds of ``fn()``."""
    (own0, kids0), t0 = cpu_times(), time.perf_counter()
    fn()
    own, kids = cpu_times()
    return {"wall": time.perf_counter() - t0, "cpu": own - own0, "workers_cpu": kids - kids0}


def one(kind, sp: dict, block: int) -> dict:
    """Start a cluster of ``kind``, run the sweep twice on it."""
    (own0, kids0), t0 = cpu_times(), time.perf_counter()
    with kind() as address:
        own, kids = cpu_times()
        start = {"wall": time.perf_counter() - t0, "cpu": own - own0, "workers_cpu": kids - kids0}
        first, second = (
            timed(lambda: run_sweep(sp, scheduler=address, block=block)) for _ in range(2)
        )
    return {"start": start, "first": first, "second": second}


def measure(which: str, sp: dict, block: int) -> dict:
    """One repeat, in this (fresh) process: the plain cluster, or the sweep's two."""
    if which == "plain":
        return {KINDS[0]: one(plain_cluster, sp, block)}
    return {KINDS[1]: one(sweep_cluster, sp, block), KINDS[2]: one(sweep_cluster, sp, block)}


def in_fresh_process(which: str, args) -> dict:
    cmd = [sys.executable, os.path.abspath(__file__), "--measure", which]
    cmd += ["--cases", str(args.cases), "--duration", str(args.duration)]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def summary(values) -> str:
    return f"{statistics.median(values):5.2f} [{min(values):4.2f}-{max(values):4.2f}]"


def report(runs: list) -> None:
    print(f"  {'(s, median [range])':19s} {'start':>17s} {'ready':>17s} {'first - second':>17s}")
    for name in KINDS:
        rows = [r[name] for r in runs if name in r]
        if not rows:
            continue
        for label, key in (("wall", "wall"), ("CPU, workers", "workers_cpu"), ("CPU, here", "cpu")):
            start = [r["start"][key] for r in rows]
            extra = [r["first"][key] - r["second"][key] for r in rows]
            ready = [s + e for s, e in zip(start, extra)]
            head = name if key == "wall" else f"  {label}"
            print(f"  {head:19s} {summary(start)} {summary(ready)} {summary(extra)}")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--repeat", type=int, default=3, help="fresh processes per row (default 3)")
    p.add_argument("--cases", type=int, default=16, help="cases per sweep (default 16)")
    p.add_argument("--duration", type=float, default=30.0, help="seconds per case (default 30)")
    p.add_argument("--measure", choices=("plain", "sweep"), help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    sp = spec(args.cases, args.duration)
    if args.measure:  # one repeat, asked for by the command below
        print(json.dumps(measure(args.measure, sp, args.cases)))
        return 0
    print(f"load: {os.getloadavg()[0]:.2f} (1 min) on {os.cpu_count()} cores")
    print(
        f"one worker; sweeps of {args.cases} reduced-body cases of {args.duration:g} s, one "
        f"task; {args.repeat} fresh processes"
    )
    runs = []
    for _ in range(args.repeat):
        runs.append(in_fresh_process("sweep", args))
        runs.append(in_fresh_process("plain", args))
    report(runs)
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
