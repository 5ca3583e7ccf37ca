"""Peak memory of `bodyvib cosim` against the simulated duration (memory must not grow with
the run's length).

Runs ``bodyvib cosim --quiet`` (class C road, 20 m/s, 1 ms step, the monolithic reference
included) in a child process for each duration, with FMUs built once beforehand, and reads
the child's peak resident set size (``ru_maxrss`` from ``os.wait4``). Prints, per duration,
the peak RSS in MB, the ratio to the shortest run and the wall time; then the growth per
simulated second from the two longest runs and the one-hour peak it extrapolates to (or,
with ``--hour``, the one-hour run measured).

Target: peak RSS of a one-hour run at 1 ms at most 300 MB and within 10 % of a one-minute
run.

    python benchmarks/bench_memory.py [--durations 60 600] [--hour] [--csv]
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def peak_rss_mb(argv, cwd):
    """Run a child; its peak RSS in MB, its wall time in s, its exit status."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode()
    proc.stderr.close()
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({proc.returncode}): {err}")
    return usage.ru_maxrss / 1024.0, time.perf_counter() - t0  # Linux: kB


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--durations", type=float, nargs="+", default=[60.0, 600.0])
    ap.add_argument("--hour", action="store_true", help="also measure a 3600 s run")
    ap.add_argument("--csv", action="store_true", help="also stream the CSV to disk")
    args = ap.parse_args(argv)
    durations = sorted(args.durations + ([3600.0] if args.hour else []))
    with tempfile.TemporaryDirectory(prefix="bench_memory_") as tmp:
        subprocess.run(
            [sys.executable, os.path.join(ROOT, "build_fmu.py"), "--dest", tmp],
            check=True,
            cwd=ROOT,
            capture_output=True,
        )
        rows = []
        for d in durations:
            cmd = [
                sys.executable,
                "-m",
                "bodyvib.cli",
                "cosim",
                "--quiet",
                "--duration",
                f"{d:g}",
                "--body",
                os.path.join(tmp, "HumanBody3DOF.fmu"),
                "--car-fmu",
                os.path.join(tmp, "QuarterCar.fmu"),
                "--json",
                os.path.join(tmp, "out.json"),
            ]
            if args.csv:
                cmd += ["--csv", os.path.join(tmp, "out.csv")]
            mb, wall = peak_rss_mb(cmd, ROOT)
            rows.append((d, mb, wall))
            print(
                f"duration {d:7g} s ({d * 1000:9.0f} steps): peak RSS {mb:7.1f} MB "
                f"(x{mb / rows[0][1]:.3f} of the {rows[0][0]:g} s run), wall {wall:6.1f} s",
                flush=True,
            )
    (d1, m1, _), (d2, m2, _) = rows[-2], rows[-1]
    slope = (m2 - m1) / (d2 - d1)
    if 3600.0 in durations:
        hour = rows[-1][1]
        print(f"one hour measured: {hour:.1f} MB")
    else:
        hour = m2 + slope * (3600.0 - d2)
        print(
            f"growth {slope * 1000:.3f} MB per 1000 s simulated; one hour extrapolated: "
            f"{hour:.1f} MB"
        )
    ok = hour <= 300.0 and hour <= 1.10 * rows[0][1]
    print(
        f"target (one hour <= 300 MB and <= 1.10 x the {rows[0][0]:g} s run): "
        f"{'met' if ok else 'NOT met'} (x{hour / rows[0][1]:.3f})"
    )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
