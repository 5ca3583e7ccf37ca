"""The 1000-case grid end to end: one ``bodyvib sweep`` command on a LocalCluster, timed.

    python benchmarks/bench_grid.py [--workers 2] [--repeats 1]

The grid: ISO 8608 classes A-E x speeds 10-30 m/s x seeds 0-19 x the reduced and the
ISO 7962 body on the quarter car, 30 s at 1 ms (1000 cases), run as a user runs it::

    bodyvib sweep --grid road=A,B,C,D,E speed=10,15,20,25,30 seed=0,...,19 \\
        body=reduced-paper,iso7962 --workers 2 --out grid.parquet --quiet

in a fresh process: its wall time includes the interpreter's start, the imports, the
LocalCluster's start, the sweep and writing the table (target: at most 12 s on 2 idle
cores). The CPU seconds of the command and its workers (the command's own from
``getrusage``, its descendants' sampled with psutil every 0.1 s: a few tenths of a
second may escape) and the load average are printed beside it: on a shared machine the CPU seconds over
the cores are the steadier guide to the wall time of an idle one.
"""

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

TARGET_S = 12.0


def grid_command(out: str, workers: int) -> list:
    """The ``bodyvib sweep`` command line of the grid."""
    return [
        sys.executable,
        "-m",
        "bodyvib.cli",
        "sweep",
        "--grid",
        "road=A,B,C,D,E",
        "speed=10,15,20,25,30",
        "seed=" + ",".join(str(s) for s in range(20)),
        "body=reduced-paper,iso7962",
        "--workers",
        str(workers),
        "--out",
        out,
        "--quiet",
    ]


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


class TreeCpu:
    """CPU seconds of a process's descendants, sampled every 0.1 s until it ends.

    The command's workers fork from a server process that nobody waits for when the
    command exits, so their time never reaches this process's children times: each
    descendant's own last sampled time counts.
    """

    def __init__(self, pid: int):
        import psutil

        self.root = psutil.Process(pid)
        self.seen = {}

    def sample(self) -> None:
        import psutil

        try:
            procs = self.root.children(recursive=True)
        except psutil.NoSuchProcess:
            return
        for p in procs:
            try:
                c = p.cpu_times()
            except psutil.NoSuchProcess:
                continue
            self.seen[p.pid] = c.user + c.system

    def total(self) -> float:
        return sum(self.seen.values())


def one_run(workers: int):
    """Wall and CPU seconds of one grid command (its workers included)."""
    with tempfile.TemporaryDirectory() as tmp:
        c0, t0 = _children_cpu(), time.perf_counter()
        proc = subprocess.Popen(grid_command(os.path.join(tmp, "grid.parquet"), workers))
        tree = TreeCpu(proc.pid)
        while proc.poll() is None:
            tree.sample()
            time.sleep(0.1)
        wall = time.perf_counter() - t0
        if proc.returncode:
            raise SystemExit(f"the sweep failed (exit status {proc.returncode})")
        # the command itself (waited for) and its descendants as last seen
        return wall, _children_cpu() - c0 + tree.total()


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--workers", type=int, default=2, help="LocalCluster workers (default 2)")
    p.add_argument("--repeats", type=int, default=1, help="runs, medians reported (default 1)")
    args = p.parse_args(argv)
    load = os.getloadavg()[0]
    runs = [one_run(args.workers) for _ in range(args.repeats)]
    wall = statistics.median(r[0] for r in runs)
    cpu = statistics.median(r[1] for r in runs)
    print(
        f"load: {load:.2f} before, {os.getloadavg()[0]:.2f} after (1 min) on {os.cpu_count()} cores"
    )
    print(
        f"1000-case grid on {args.workers} workers, end to end: {wall:.1f} s wall "
        f"(target <= {TARGET_S:g} s), {cpu:.1f} s CPU (command and workers; "
        f"{cpu / args.workers:.1f} s over {args.workers} cores)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
