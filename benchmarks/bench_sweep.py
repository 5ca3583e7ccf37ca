"""A 10,000-case sweep with each engine, against one ``bodyvib cosim`` run, measured in one run.

    python benchmarks/bench_sweep.py [--cases 10000] [--workers 2] [--cosim-cases 4]
                                     [--overhead-cases N] [--repeats 1] [--batched-only]
                                     [--json FILE]

The sweep: ISO 8608 classes A-E x speeds 10, 15, 20, 25, 30 m/s x ``cases / 25``
reduced-body parameter sets (Latin hypercube, m1, k1, k2, c1, c2 within
+-20 %), 30 s at 1 ms, seed 0, quarter car. Measured side by side:

* one ``bodyvib cosim --params FILE`` process (the way a case is run today:
  two FMU builds, start-up, 30 s co-simulation): the per-case reference cost;
* ``spectral`` on a LocalCluster of ``--workers`` workers (two tasks per
  worker) and by default (all cases make one task, run in this process);
* ``batched`` on the LocalCluster, all cases (the target: 10,000 cases in at
  most 12 s on 2 workers), and serially in this process (target: 2 workers at
  least 1.85x one);
* the Dask overhead: ``batched`` on ``--overhead-cases`` cases (all cases by
  default) on a LocalCluster of one worker against the same cases serially in
  this process (same tasks, same engine; target at most 10 %, wall and CPU); the
  two tables are compared (they are equal bit for bit: a case's figures do not
  depend on its task) and the largest difference is reported, not asserted;
* ``cosim`` on ``--cosim-cases`` cases serially (FMUs built once, parameters
  set per case), extrapolated per case.

``--batched-only`` leaves out the ``bodyvib cosim`` process, the spectral and the
cosim engine: the batched runs and their targets only.

Wall times include everything a user waits for (cluster start-up, spec
expansion, writing the Parquet parts and the table); CPU times add this
process's and the cluster's worker processes' (``os.times`` and psutil: the
workers' time as collected by the fork server they are forked from), which a
busy shared machine disturbs less than wall time. The first LocalCluster of the
run starts the fork server (its imports and warm-up count in that run's CPU);
later ones reuse it. With ``--repeats`` above 1 the
medians are reported.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

from bodyvib.models import MODEL_DIR
from bodyvib.vehicle.sweep.run import run_sweep
from bodyvib.vehicle.sweep.spec import expand


def sweep_spec(cases: int) -> dict:
    """The benchmark's spec (25 road x speed cells x cases/25 bodies)."""
    return {
        "road": list("ABCDE"),
        "speed": [10, 15, 20, 25, 30],
        "seed": 0,
        "duration": 30,
        "step": 1e-3,
        "body": [
            {
                "model": "reduced-paper",
                "samples": max(1, cases // 25),
                "seed": 0,
                "vary": {p: [0.8, 1.2] for p in ("m1", "k1", "k2", "c1", "c2")},
                "name": "reduced-varied",
            }
        ],
    }


CPU = {}


def _cpu():
    """CPU seconds of this process, its finished children and its live children with
    theirs: a LocalCluster's workers fork from a server process that outlives them and
    collects their CPU time."""
    import psutil

    t = os.times()
    total = t.user + t.system + t.children_user + t.children_system
    for p in psutil.Process().children():
        try:
            c = p.cpu_times()
        except psutil.NoSuchProcess:
            continue
        total += c.user + c.system + c.children_user + c.children_system
    return total


def timed(fn, repeats, name=None):
    """Median wall time of ``fn()`` over ``repeats``; its CPU time (all processes) into CPU[name]."""
    times, cpus = [], []
    for _ in range(repeats):
        c0, t0 = _cpu(), time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
        cpus.append(_cpu() - c0)
    if name:
        CPU[name] = statistics.median(cpus)
    return statistics.median(times), out


def one_cosim_run(folder) -> float:
    """Wall time of one ``bodyvib cosim`` process with a parameter file (class C, 20 m/s, 30 s)."""
    params = os.path.join(folder, "body.json")
    with open(os.path.join(MODEL_DIR, "reduced-paper.json")) as f:
        data = json.load(f)
    data["parameters"]["k1"] *= 1.1
    with open(params, "w") as f:
        json.dump(data, f)
    t0 = time.perf_counter()
    subprocess.run(
        [
            sys.executable,
            "-m",
            "bodyvib.cli",
            "cosim",
            "--params",
            params,
            "--road",
            "C",
            "--speed",
            "20",
            "--duration",
            "30",
            "--quiet",
        ],
        check=True,
        stdout=subprocess.DEVNULL,
        cwd=folder,
    )
    return time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=10000)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--cosim-cases", type=int, default=4)
    ap.add_argument("--overhead-cases", type=int, help="cases of the 1-worker run (default: all)")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--skip-serial", action="store_true", help="no serial batched run of all cases")
    ap.add_argument("--batched-only", action="store_true", help="the batched engine's runs only")
    ap.add_argument("--json", help="write the measurements as JSON")
    a = ap.parse_args(argv)
    spec = sweep_spec(a.cases)
    n = len(expand(spec))
    small = sweep_spec(a.overhead_cases or a.cases)
    n_small = len(expand(small))
    res = {"cases": n, "workers": a.workers, "load_before": os.getloadavg()}
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "r.parquet")

        def run(s, **kw):
            return run_sweep(s, out=out, overwrite=True, **kw)

        if not a.batched_only:
            print("one bodyvib cosim run ...", file=sys.stderr, flush=True)
            res["bodyvib_cosim_s"], _ = timed(
                lambda: one_cosim_run(tmp), a.repeats, "bodyvib_cosim"
            )
            print("spectral ...", file=sys.stderr, flush=True)
            res["spectral_local_s"], df = timed(
                lambda: run(
                    spec,
                    engine="spectral",
                    workers=a.workers,
                    scheduler="local",
                    block=max(1, n // (2 * a.workers)),
                ),
                a.repeats,
                "spectral_local",
            )
            assert len(df) == n and df["error"].isna().all()
            res["spectral_default_s"], _ = timed(
                lambda: run(spec, engine="spectral"), a.repeats, "spectral_default"
            )
        if not a.skip_serial or n_small != n:
            print(f"batched, {n_small} cases, serial ...", file=sys.stderr, flush=True)
            t_serial, d1 = timed(
                lambda: run(small, scheduler="serial", workers=1), a.repeats, "small_serial"
            )
            res["batched_small_serial_s"] = t_serial
        print(f"batched, {n_small} cases, LocalCluster of 1 ...", file=sys.stderr, flush=True)
        t_dask1, d2 = timed(lambda: run(small, workers=1), a.repeats, "small_local1")
        res["overhead_cases"] = n_small
        res["batched_small_local1_s"] = t_dask1
        if "batched_small_serial_s" in res:
            res["serial_vs_dask_max_abs_diff"] = float(
                (d1["head_weighted_rms"] - d2["head_weighted_rms"]).abs().max()
            )
        print(f"batched, {n} cases, LocalCluster of {a.workers} ...", file=sys.stderr, flush=True)
        res["batched_local_s"], df = timed(
            lambda: run(spec, workers=a.workers), a.repeats, "batched_local"
        )
        assert len(df) == n and df["error"].isna().all()
        if n_small == n and "batched_small_serial_s" in res:  # the serial run of all cases
            res["batched_serial_s"] = res["batched_small_serial_s"]
            CPU["batched_serial"] = CPU["small_serial"]
        elif not a.skip_serial:
            print(f"batched, {n} cases, serial ...", file=sys.stderr, flush=True)
            res["batched_serial_s"], _ = timed(
                lambda: run(spec, scheduler="serial", workers=a.workers),
                a.repeats,
                "batched_serial",
            )
        if not a.batched_only:
            print(f"cosim engine, {a.cosim_cases} cases ...", file=sys.stderr, flush=True)
            few = dict(
                spec,
                body=[dict(spec["body"][0], samples=1)],
                road=["C"],
                speed=[10, 15, 20, 25, 30][: max(1, a.cosim_cases)],
            )
            res["cosim_cases"] = len(expand(few))
            res["cosim_serial_s"], df = timed(
                lambda: run(few, engine="cosim", scheduler="serial"), 1, "cosim"
            )
            assert df["error"].isna().all(), df["error"].tolist()
    res["load_after"] = os.getloadavg()
    res["cpu_s"] = dict(CPU)
    ref = res.get("bodyvib_cosim_s")
    rows = []
    if ref:
        rows += [
            ("bodyvib cosim (1 process)", 1, ref, "bodyvib_cosim"),
            (f"spectral, LocalCluster x{a.workers}", n, res["spectral_local_s"], "spectral_local"),
            (
                "spectral, default (1 task: in-process)",
                n,
                res["spectral_default_s"],
                "spectral_default",
            ),
        ]
    rows.append((f"batched, LocalCluster x{a.workers}", n, res["batched_local_s"], "batched_local"))
    if "batched_serial_s" in res:
        rows.append(("batched, serial", n, res["batched_serial_s"], "batched_serial"))
    rows.append(
        ("batched, LocalCluster x1", n_small, res["batched_small_local1_s"], "small_local1")
    )
    if n_small != n and "batched_small_serial_s" in res:
        rows.append(("batched, serial", n_small, res["batched_small_serial_s"], "small_serial"))
    if "cosim_serial_s" in res:
        rows.append(("cosim engine, serial", res["cosim_cases"], res["cosim_serial_s"], "cosim"))
    print(
        f"\n{'run':40s} {'cases':>6s} {'wall [s]':>9s} {'CPU [s]':>9s} {'wall/case [ms]':>15s} "
        f"{'x bodyvib cosim':>16s}"
    )
    for name, cases, wall, key in rows:
        per = wall / cases
        gain = f"{ref / per:15.0f}x" if ref else f"{'':>16s}"
        print(f"{name:40s} {cases:6d} {wall:9.2f} {CPU[key]:9.2f} {per * 1e3:15.3f} {gain}")
    print()
    if "batched_small_serial_s" in res:
        over = res["batched_small_local1_s"] / res["batched_small_serial_s"] - 1
        res["dask_overhead"] = over
        print(
            f"1 worker against serial, {n_small} batched cases: {100 * over:+.1f} % wall, "
            f"{100 * (CPU['small_local1'] / CPU['small_serial'] - 1):+.1f} % CPU (target <= 10 %)"
        )
        print(
            f"serial vs Dask, largest difference in head_weighted_rms: "
            f"{res['serial_vs_dask_max_abs_diff']:.3g} m/s2"
        )
    print(
        f"batched, {n} cases on {a.workers} workers: {res['batched_local_s']:.1f} s "
        f"(target for 10,000: <= 12 s)"
    )
    if "batched_serial_s" in res:
        print(
            f"batched speed-up of {a.workers} workers over serial: "
            f"{res['batched_serial_s'] / res['batched_local_s']:.2f}x (target >= 1.85x); "
            f"CPU {CPU['batched_local']:.1f} s against {CPU['batched_serial']:.1f} s"
        )
    if ref:
        print(
            f"spectral, {n} cases on {a.workers} workers: {res['spectral_local_s']:.2f} s "
            "(target <= 10 s)"
        )
        per_case = res["cosim_serial_s"] / res["cosim_cases"]
        print(
            f"cosim engine: {per_case:.2f} s per case; "
            f"{n} cases would take {per_case * n / 3600 / a.workers:.1f} h on {a.workers} workers"
        )
    print(
        f"load average before/after: {res['load_before'][0]:.1f} / {res['load_after'][0]:.1f} "
        f"({os.cpu_count()} cores)"
    )
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=2)


if __name__ == "__main__":
    main()
