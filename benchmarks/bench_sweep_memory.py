"""Peak memory of a sweep's client and scheduler for 10k, 100k and 1M spectral cases.

    python benchmarks/bench_sweep_memory.py [--cases 10000 100000 1000000] [--workers 2]

A real cluster is started for each size: ``dask scheduler`` and ``--workers``
``dask worker`` processes (one thread each) on 127.0.0.1; the client is one
``bodyvib sweep --engine spectral --scheduler-file ... --out ...`` process.
Peak resident memory: the client's from ``wait4`` (its ``ru_maxrss``), the
scheduler's and the workers' from ``VmHWM`` in ``/proc`` before they are
stopped. The spec: ISO 8608 classes A-E x 20 speeds x seeds 0..S x 100
reduced-body parameter sets (Latin hypercube, five parameters within +-20 %),
S chosen for the case count (the spectral figures do not depend on the seed:
the sizes measure the client's bookkeeping, not the engine).
"""

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time


def spec(cases: int) -> dict:
    seeds = max(1, cases // (5 * 20 * 100))
    return {
        "road": list("ABCDE"),
        "speed": list(range(5, 45, 2)),
        "seed": f"0..{seeds - 1}",
        "duration": 30,
        "body": [
            {
                "model": "reduced-paper",
                "samples": 100,
                "seed": 0,
                "vary": {p: [0.8, 1.2] for p in ("m1", "k1", "k2", "c1", "c2")},
                "name": "reduced-varied",
            }
        ],
    }


def _hwm(pid: int) -> float:
    """Peak resident memory of a process, MB (0 if gone)."""
    try:
        for line in open(f"/proc/{pid}/status"):
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0


def _tree(pid: int):
    """A process and its descendants (the worker processes under ``dask worker``)."""
    out = [pid]
    try:
        for t in os.listdir(f"/proc/{pid}/task"):
            kids = open(f"/proc/{pid}/task/{t}/children").read().split()
            for k in kids:
                out += _tree(int(k))
    except OSError:
        pass
    return out


def measure(cases: int, workers: int, folder: str) -> dict:
    env = {**os.environ, "DASK_TEMPORARY_DIRECTORY": folder}
    sf = os.path.join(folder, "scheduler.json")
    sched = subprocess.Popen(
        [sys.executable, "-m", *"dask scheduler --host 127.0.0.1 --port 0".split()]
        + ["--no-dashboard", "--scheduler-file", sf],
        env=env,
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    procs = [sched]
    try:
        while not os.path.exists(sf):
            time.sleep(0.1)
        time.sleep(0.3)
        address = json.load(open(sf))["address"]
        for i in range(workers):
            procs.append(
                subprocess.Popen(
                    [sys.executable, "-m", "dask", "worker", address, "--nthreads", "1"]
                    + ["--no-dashboard", "--local-directory", os.path.join(folder, f"w{i}")],
                    env=env,
                    start_new_session=True,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )
            )
        spec_file = os.path.join(folder, "spec.json")
        with open(spec_file, "w") as f:
            json.dump(spec(cases), f)
        out = os.path.join(folder, "r.parquet")
        t0 = time.perf_counter()
        client = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "bodyvib.cli",
                "sweep",
                spec_file,
                "--engine",
                "spectral",
                "--scheduler-file",
                sf,
                "--out",
                out,
                "--overwrite",
                "--quiet",
            ],
            env=env,
        )
        worker_peak = 0.0
        while True:  # the client's own rusage; the workers sampled while they live
            pid, status, usage = os.wait4(client.pid, os.WNOHANG)
            if pid:
                client.returncode = os.waitstatus_to_exitcode(status)
                break
            for p in procs[1:]:
                worker_peak = max([worker_peak] + [_hwm(q) for q in _tree(p.pid)[1:]])
            time.sleep(0.5)
        wall = time.perf_counter() - t0
        sched_peak = _hwm(sched.pid)
        import pyarrow.parquet as pq

        rows = pq.ParquetFile(out).metadata.num_rows
    finally:
        for p in procs:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            p.wait()
    return {
        "cases": cases,
        "rows": rows,
        "wall_s": wall,
        "returncode": client.returncode,
        "client_peak_mb": usage.ru_maxrss / 1024,
        "scheduler_peak_mb": sched_peak,
        "worker_peak_mb": worker_peak,
        "file_mb": os.path.getsize(out) / 1e6 if os.path.exists(out) else 0,
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args(argv)
    print(
        f"{'cases':>9s} {'rows':>9s} {'wall [s]':>9s} {'client [MB]':>12s} "
        f"{'scheduler [MB]':>15s} {'worker [MB]':>12s} {'file [MB]':>10s}   load {os.getloadavg()[0]:.1f}"
    )
    for n in a.cases:
        folder = tempfile.mkdtemp(prefix="bodyvib-bench-mem-")
        try:
            r = measure(n, a.workers, folder)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        print(
            f"{r['cases']:9d} {r['rows']:9d} {r['wall_s']:9.1f} {r['client_peak_mb']:12.0f} "
            f"{r['scheduler_peak_mb']:15.0f} {r['worker_peak_mb']:12.0f} {r['file_mb']:10.1f}"
            f"   load {os.getloadavg()[0]:.1f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
