"""A native FMU's step against a plain C loop of the same arithmetic, in one C host.

    python benchmarks/bench_native_step.py [--steps 1000000] [--repeats 7] [--processes 5]
                                           [--no-callgrind] [--realtime] [--fmus DIR]
                                           [--only FMU ...]

Builds the native FMUs (FMI 2.0 and 3.0: HumanBody3DOF, HumanBodyISO7962, QuarterCar,
FullCar, Road; ``--only`` some of them) unless ``--fmus`` names a folder of them
(``bodyvib build --native``), compiles ``benchmarks/native_step_host.c`` with the FMUs' own flags (``-O2 -flto``), once per model
with the model's sizes and the pattern of its inputs' step matrix as constants (the FMU is
compiled for its model's sizes and pattern too), and, per FMU, in ``--processes`` fresh
host processes:

* times, interleaved over ``--repeats`` rounds, ``--steps`` FMU steps (set the inputs,
  doStep, get the outputs of :data:`SIGNALS`: two and two, the full car's eight road inputs
  and four seat outputs; inputs precomputed), the same number of steps of a plain C loop
  on the same matrices: ``x <- Sc [x | s]``, ``s <- Ms s``, the outputs ``Y [x | s]``,
  summed as the FMU sums (two accumulators a row, Ms over the entries its pattern allows),
  with the matrices of :class:`bodyvib.runtime.engine.FmuCore` (the same exact
  discretization the FMU computes at initialization), and the same calls into functions
  that do nothing. The plain loop does the same arithmetic as the FMU's step: for a model
  with nonlinear elements (QuarterCar's tire contact and bump stop, FullCar's four tire
  contacts and four stops) that includes the switching functions and their sign test,
  so the floor evaluates them as the FMU does, in the simplest correct C: each function at
  the step's end as one dot product of a row precomputed from the step matrix
  (``P = G M``, times the function's sign in the regime at rest) with ``[x | s]`` at the
  step's start (a stop's rebound side: its compression side's negated), plus its constant;
  then the FMU's test, ``4 min(g0, g1) >= max(gm, g1)`` over the function's last three
  values, combined without a branch, and the three values moved on. The steps where that
  test fails (a function near zero, where the FMU tests in full) are counted and printed;
  on the benchmark's road there are none. For Road the plain loop evaluates the FMU's
  own table (its ``sources/bodyvib_model.c``, compiled into the host) at ``speed * t``,
  the position reduced as the FMU reduces it. Printed: the best round of each and their ratio (the
  step's own cost: on a virtual machine another thread may share the physical core, and
  that only adds time), medians of wall-clock and thread-CPU ns per step with the range of
  the processes' ratios, and the largest relative difference of the outputs (the same
  step);
* times ``--steps`` FMU steps one by one with the time-stamp counter, after a warm-up, the
  counter's own cost subtracted, memory locked (``mlockall``), each followed by a plain
  step timed the same way: median, 99th, 99.9th and 99.99th percentile and the worst step
  of both, the steps slower than 3x their median, and what the host's core and thread went
  through meanwhile (interrupts from ``/proc/interrupts``, involuntary context switches).
  The durations are counted in a histogram of counter ticks (a few cache lines, where a
  list of 1e6 durations would take the timed steps through a new memory page every 512
  steps), and each step's inputs are copied to the host's stack before its clock starts. The
  plain steps' tail is the machine's own for arithmetic of that size: where it is as long
  as the FMU's, the slow steps are the machine's, not the FMU's. A third region in the
  same loop times nothing (two reads of the counter): how often the machine alone makes
  a region of no work as slow as an FMU step's outlier;
* counts what a step does besides arithmetic: malloc/calloc/realloc/free calls while
  stepping (the host interposes them), system calls (``strace -c`` of 1e3 against 1e5
  steps: equal totals mean none per step), and the lock functions the binary imports
  (``nm -D``: none means it cannot lock);
* counts instructions per step with ``valgrind --tool=callgrind`` (FMU and plain loop,
  each over its own loop only): independent of the machine's load, the steadiest ratio.

``--realtime`` runs the host at real-time priority (SCHED_FIFO) pinned to the last core,
so that other processes do not take its time slices; what remains in the worst case is the
machine's (interrupts, a virtual machine's host).

Targets: FMU / plain at most 1.3; 99.99th percentile at most 3x the median on a quiet core.
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np

HOST = Path(__file__).resolve().parent / "native_step_host.c"
FMUS = ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar", "FullCar", "Road")
#: (inputs set, outputs read) per FMU: what a co-simulation exchanges at every step
SIGNALS = {
    "HumanBody3DOF": (["seat_displacement", "seat_velocity"], ["head_acceleration", "seat_force"]),
    "HumanBodyISO7962": (
        ["seat_displacement", "seat_velocity"],
        ["head_acceleration", "seat_force"],
    ),
    "QuarterCar": (["road_displacement", "road_velocity"], ["seat_displacement", "seat_velocity"]),
    # the four corners' road pairs in; the seat's vertical motion (what the occupant takes)
    # and its horizontal accelerations (what the comfort figures take) out
    "FullCar": (
        [
            f"road_{q}_{corner}"
            for corner in ("front_left", "front_right", "rear_left", "rear_right")
            for q in ("displacement", "velocity")
        ],
        ["seat_displacement", "seat_velocity", "seat_acceleration_x", "seat_acceleration_y"],
    ),
    "Road": ([], ["road_displacement", "road_velocity"]),
}
H = 1e-3
LOCKS = re.compile(r"pthread|mtx_|futex|sem_|lock", re.I)


def build(dest: Path, names) -> dict:
    from bodyvib.vehicle.fmus import build_fmus

    print("building the native FMUs ...", file=sys.stderr, flush=True)
    return build_fmus(dest, names=list(names), native=True, fmi=(2, 3), platforms=["linux64"])


def find(folder: Path, names) -> dict:
    found = {}
    for name in names:
        for key, path in (
            (name, folder / f"{name}.fmu"),
            (f"fmi3/{name}", folder / "fmi3" / f"{name}.fmu"),
        ):
            if not path.is_file():
                raise SystemExit(f"{path} not found: build it with bodyvib build --native")
            found[key] = path
    return found


def host_flags() -> list:
    """The FMUs' own code-generation flags (language, optimization, link-time optimization)."""
    from bodyvib.fmu.native import COMMON_FLAGS

    return [f for f in COMMON_FLAGS if f.startswith(("-std", "-O", "-f"))]


def compile_host(
    exe: Path, road_sources: Path = None, sizes: tuple = None, pattern: tuple = None
) -> Path:
    """Compile the host with the FMUs' flags; ``sizes`` (n, ni, nset, nget, negated: 0/1 per
    switching function) makes the plain loop's sizes constants, as the FMU's are, and
    ``pattern`` (0/1 per entry of ``Ms``, row by row) the entries of ``Ms`` it multiplies, as
    the FMU's are; ``road_sources`` compiles a road's table in."""
    cmd = ["gcc", *host_flags(), str(HOST), "-o", str(exe), "-ldl", "-lm"]
    if sizes is not None:
        *dims, negated = sizes
        cmd[1:1] = [f"-DPLAIN_{k}={v}" for k, v in zip(("N", "NI", "NSET", "NGET"), dims)]
        cmd[1:1] = [f"-DPLAIN_NSW={len(negated)}"]
        if negated:
            cmd[1:1] = ["-DPLAIN_NEGATED=" + ",".join(str(int(b)) for b in negated)]
    if pattern is not None:
        cmd[1:1] = ["-DPLAIN_MS_PATTERN=" + ",".join(str(int(b)) for b in pattern)]
    if road_sources is not None:
        cmd[1:1] = [
            "-DBV_ROAD_TABLE",
            "-I",
            str(road_sources),
            str(road_sources / "bodyvib_model.c"),
        ]
    subprocess.run(cmd, check=True)
    return exe


def plain_matrices(name: str, set_idx, get_idx, path: Path) -> tuple:
    """Write what the plain loop multiplies: the FMU's step matrices from the model and, for
    a model with nonlinear elements, its switching functions at the step's end from its
    start, ``P = G M`` (``G`` on ``[x | s]``, ``M`` the step matrix) and ``q = g0``, each
    times its sign at rest (+1 in force, -1 not; at rest the linear model's regime, with no
    affine column); returns the sizes (n, ni, nset, nget, negated: per function, 1 where its
    row is the previous one's negated, a stop's rebound side) and where ``Ms`` can be
    non-zero (0/1 per entry): on its diagonal and where ``R`` or ``R^2`` is, as the FMU's
    compiled step knows it."""
    from bodyvib.runtime.engine import FmuCore
    from bodyvib.vehicle.fmus import FMUS as PROJECT_FMUS
    from bodyvib.vehicle.fmus import load_fmu_model

    core = FmuCore(PROJECT_FMUS[name][0], load_fmu_model(name), name)
    n, ni = core._n, core._ni
    M = core._step_matrix(H)
    Y = core._Y[[i - ni for i in get_idx]]
    P, q, negated = np.zeros((0, n + ni)), np.zeros(0), ()
    if core._stepper is not None:
        pw = core._stepper.model
        sign = np.where(pw.initial, 1.0, -1.0)
        P, q = sign[:, None] * (core._Gz @ M), sign * pw.g0
        negated = tuple(side == "rebound" for _, side in pw.switches)
    with open(path, "w") as f:
        f.write(f"{n} {ni} {len(set_idx)} {len(get_idx)}\n")
        f.write(" ".join(str(i) for i in set_idx) + "\n")
        for block in (M[:n], M[n:, n:], Y):
            f.write(" ".join(repr(float(v)) for v in block.ravel()) + "\n")
        f.write(f"{len(q)}\n" + " ".join(str(int(b)) for b in negated) + "\n")
        for block in (P, q):
            f.write(" ".join(repr(float(v)) for v in block.ravel()) + "\n")
    R = core._R
    pattern = (np.eye(ni) + (R != 0) + ((R != 0).astype(int) @ (R != 0).astype(int))) != 0
    return (n, ni, len(set_idx), len(get_idx), negated), tuple(pattern.ravel())


def unpack(fmu: Path, folder: Path):
    """(binary, token, value references by name, start values by name) of an FMU."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu))
    with zipfile.ZipFile(fmu) as z:
        z.extractall(folder)
    ident = md.coSimulation.modelIdentifier
    plat = "linux64" if md.fmiVersion.startswith("2") else "x86_64-linux"
    vr = {v.name: v.valueReference for v in md.modelVariables}
    start = {v.name: v.start for v in md.modelVariables}
    return folder / "binaries" / plat / f"{ident}.so", md.guid, vr, start


def run(cmd, **kw) -> str:
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=1800, **kw)
    if out.returncode != 0:
        raise SystemExit(f"{cmd[0]} failed: {out.stderr[-800:]}")
    return out.stdout + out.stderr


def measure(exe, fmi, binary, token, sv, gv, data, steps, repeats, prefix=()) -> dict:
    args = [str(fmi), str(binary), token, sv, gv, repr(H)]
    text = run([*prefix, str(exe), "time", *args, str(steps), str(repeats), data])
    rounds = np.array(
        [list(map(float, ln.split()[1:])) for ln in text.splitlines() if ln.startswith("round")]
    )
    res = dict(zip(("fmu", "plain", "fmu_cpu", "plain_cpu", "calls"), np.median(rounds, axis=0)))
    res["calls_best"] = rounds[:, 4].min()
    res["ratio"] = float(np.median(rounds[:, 0] / rounds[:, 1]))
    res["fmu_best"], res["plain_best"] = rounds[:, 0].min(), rounds[:, 1].min()
    res["ratio_cpu"] = float(np.median(rounds[:, 2] / rounds[:, 3]))
    for ln in text.splitlines():
        key, *vals = ln.split()
        if key in ("latency", "latency_plain", "latency_empty"):
            pre = {"latency": "", "latency_plain": "plain_", "latency_empty": "empty_"}[key]
            names = ("p50", "p99", "p999", "p9999", "max", "outliers")
            res.update({pre + n: float(v) for n, v in zip(names, vals)})
        elif key in ("interrupts", "switches"):
            res[key] = tuple(map(int, vals))
        elif key == "latency_clock":
            res[key], res["resolution"] = map(float, vals)
        elif key in ("allocations", "check", "locked", "stolen", "unclear"):
            res[key] = float(vals[0])
    return res


def measure_processes(count: int, args: tuple) -> dict:
    """:func:`measure` in ``count`` fresh host processes: medians of the timings and
    percentiles over the processes, the range of their wall ratios, the largest worst step,
    and the counts (allocations, interrupts, ...) of the first."""
    runs = [measure(*args) for _ in range(count)]
    res = dict(runs[0])
    medians = ("fmu", "plain", "fmu_cpu", "plain_cpu", "ratio", "ratio_cpu")
    medians += ("p50", "p99", "p999", "p9999", "outliers")
    for key in medians + tuple(
        pre + k for pre in ("plain_", "empty_") for k in ("p50", "p99", "p999", "p9999", "outliers")
    ):
        res[key] = float(np.median([r[key] for r in runs]))
    res["max"] = max(r["max"] for r in runs)
    res["plain_max"] = max(r["plain_max"] for r in runs)
    res["allocations"] = max(r["allocations"] for r in runs)
    res["check"] = max(r["check"] for r in runs)
    res["unclear"] = max(r.get("unclear", 0.0) for r in runs)
    res["ratio_range"] = (min(r["ratio"] for r in runs), max(r["ratio"] for r in runs))
    res["fmu_best"] = min(r["fmu_best"] for r in runs)
    res["plain_best"] = min(r["plain_best"] for r in runs)
    res["calls_best"] = min(r["calls_best"] for r in runs)
    return res


def instructions(exe, mode, fmi, binary, token, sv, gv, data, steps=100_000) -> float:
    """Instructions per step inside the loop of ``mode`` (callgrind)."""
    loop = "fmu_loop" if mode == "fmu" else "plain_loop"
    text = run(
        [
            "valgrind",
            "--tool=callgrind",
            f"--toggle-collect={loop}*",
            "--callgrind-out-file=/dev/null",
            str(exe),
            mode,
            str(fmi),
            str(binary),
            token,
            sv,
            gv,
            repr(H),
            str(steps),
            "1",
            data,
        ]
    )
    m = re.search(r"Collected : (\d+)", text)
    return int(m.group(1)) / steps


def syscalls(exe, args, folder: Path) -> tuple:
    """Total system calls of a run of 1e3 and of 1e5 FMU steps (strace -c)."""
    totals = []
    for steps in (1000, 100_000):
        log = folder / f"strace-{steps}.txt"
        run(
            [
                "strace",
                "-f",
                "-c",
                "-o",
                str(log),
                str(exe),
                "fmu",
                *args[:6],
                str(steps),
                "1",
                args[6],
            ]
        )
        last = log.read_text().strip().splitlines()[-1].split()  # % s us/call calls [errors] total
        totals.append(int(last[3]) if last[-1] == "total" else -1)
    return tuple(totals)


def print_worst(rows, steps: int, processes: int) -> None:
    """The distribution of single steps, FMU and plain loop, and what the slow ones met."""
    r0 = rows[0][2]
    print(
        f"single steps ({steps} after a warm-up in each of {processes} processes, each FMU step "
        "followed by a plain step, both timed; percentiles: medians over the processes, max: the "
        f"worst of all; "
        f"time-stamp counter in steps of {r0['resolution']:.1f} ns, its own "
        f"{r0['latency_clock']:.1f} ns subtracted; memory locked: {r0['locked'] == 1}), ns:"
    )
    print(
        f"  {'FMU':17s} {'FMI':>3s} | {'p50':>5s} {'p99':>5s} {'p99.9':>6s} {'p99.99':>7s} "
        f"{'max':>9s} {'p99.99/p50':>10s} {'>3x p50':>7s} | {'plain p50':>9s} {'p99.99':>7s} "
        f"{'p99.99/p50':>10s} {'>3x p50':>7s} | {'nothing p99.99':>14s} {'>3x FMU p50':>11s} | "
        f"{'interrupts':>10s} {'(timer)':>7s} "
        f"{'preempted':>9s} {'stolen ms':>9s}"
    )
    for name, fmi, r in rows:
        irq, timer = r["interrupts"]
        print(
            f"  {name:17s} {fmi:3d} | {r['p50']:5.1f} {r['p99']:5.1f} {r['p999']:6.1f} "
            f"{r['p9999']:7.1f} {r['max']:9.0f} {r['p9999'] / r['p50']:10.1f} "
            f"{r['outliers']:7.0f} | {r['plain_p50']:9.1f} {r['plain_p9999']:7.1f} "
            f"{r['plain_p9999'] / r['plain_p50']:10.1f} {r['plain_outliers']:7.0f} | "
            f"{r['empty_p9999']:14.1f} {r['empty_outliers']:11.0f} | "
            f"{irq:10d} {timer:7d} {r['switches'][1]:9d} {r['stolen']:9.0f}"
        )
    print(
        "  >3x p50: steps slower than 3 times their median; plain: the plain loop's steps, "
        "timed in the same loop (the machine's own tail for arithmetic of that size); "
        "nothing: two reads of the counter with no work between, in the same loop after each "
        "plain step (>3x FMU p50: as slow as an FMU step's outlier with no work at all); "
        "interrupts: taken by the host's core during those steps (/proc/interrupts; timer: "
        "the local timer's); preempted: involuntary context switches of the host's thread; "
        "stolen: the core's time the virtual machine's host took meanwhile (/proc/stat, 10 ms "
        "ticks)"
    )


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--steps", type=int, default=1_000_000, help="steps per loop (default 1e6)")
    p.add_argument("--repeats", type=int, default=7, help="interleaved rounds (default 7)")
    p.add_argument(
        "--processes",
        type=int,
        default=5,
        help="host processes per FMU (default 5): a process's timing can sit apart from the "
        "next one's by a third on a virtual machine; the median over processes is steady",
    )
    p.add_argument("--fmus", type=Path, help="folder of built native FMUs (default: build them)")
    p.add_argument(
        "--only",
        nargs="+",
        choices=FMUS,
        default=list(FMUS),
        metavar="FMU",
        help=f"the FMUs to measure (default all: {', '.join(FMUS)})",
    )
    p.add_argument("--no-callgrind", action="store_true", help="skip the instruction counts")
    p.add_argument(
        "--realtime",
        action="store_true",
        help="run the host at real-time priority on the last core (chrt -f 50, taskset; needs "
        "root): other processes no longer take its time slices",
    )
    args = p.parse_args(argv)
    if shutil.which("gcc") is None:
        raise SystemExit("gcc not found")
    callgrind = not args.no_callgrind and shutil.which("valgrind") is not None
    with tempfile.TemporaryDirectory(prefix="bodyvib-bench-step-") as tmp:
        tmp = Path(tmp)
        names = [n for n in FMUS if n in args.only]
        fmus = find(args.fmus, names) if args.fmus else build(tmp / "fmus", names)
        prefix = ()
        if args.realtime:
            prefix = ("chrt", "-f", "50", "taskset", "-c", str((os.cpu_count() or 1) - 1))
        print(
            f"load: {os.getloadavg()[0]:.2f} (1 min) on {os.cpu_count()} cores; {args.steps} steps "
            f"a loop, {args.repeats} interleaved rounds in each of {args.processes} processes "
            "(medians; range: of the processes' ratios); one step = set the inputs + doStep + get "
            "the outputs (2 and 2; FullCar: 8 and 4), ns"
        )
        print(
            f"  {'FMU':17s} {'FMI':>3s} | {'best':>5s} {'plain':>5s} {'ratio':>5s} {'extra':>5s} "
            f"{'calls':>5s} | "
            f"{'loop: FMU':>9s} {'plain':>6s} {'ratio':>5s} "
            f"{'range':>9s} {'CPU':>5s} | "
            f"{'instr: FMU':>10s} {'plain':>5s} {'ratio':>5s} | {'allocs':>6s} {'rel diff':>8s}"
        )
        notes, worst = [], []
        for name in names:
            sets, gets = SIGNALS[name]
            for fmi in (2, 3):
                key = name if fmi == 2 else f"fmi3/{name}"
                folder = tmp / key.replace("/", "-")
                binary, token, vr, start = unpack(fmus[key], folder)
                sv = ",".join(str(vr[s]) for s in sets) or "-"
                gv = ",".join(str(vr[g]) for g in gets)
                if name == "Road":
                    host = tmp / "road-host"
                    if not host.exists():
                        compile_host(host, folder / "sources")
                    data = f"road:{float(start['speed'])!r}"
                else:
                    data = str(folder / "plain.txt")
                    sizes, pattern = plain_matrices(
                        name, [vr[s] for s in sets], [vr[g] for g in gets], data
                    )
                    host = tmp / f"host-{name}"  # the model's sizes and Ms pattern
                    if not host.exists():
                        compile_host(host, sizes=sizes, pattern=pattern)
                r = measure_processes(
                    args.processes,
                    (host, fmi, binary, token, sv, gv, data, args.steps, args.repeats, prefix),
                )
                ir = ir_plain = float("nan")
                if callgrind:
                    ir = instructions(host, "fmu", fmi, binary, token, sv, gv, data)
                    ir_plain = instructions(host, "plain", fmi, binary, token, sv, gv, data)
                low, high = r["ratio_range"]
                best = r["fmu_best"] / r["plain_best"]
                print(
                    f"  {name:17s} {fmi:3d} | {r['fmu_best']:5.1f} {r['plain_best']:5.1f} "
                    f"{best:5.2f} {r['fmu_best'] - r['plain_best']:5.1f} {r['calls_best']:5.1f} | "
                    f"{r['fmu']:9.1f} {r['plain']:6.1f} {r['ratio']:5.2f} "
                    f"{f'{low:.2f}-{high:.2f}':>9s} {r['ratio_cpu']:5.2f} | {ir:10.0f} "
                    f"{ir_plain:5.0f} {ir / ir_plain:5.2f} | {r['allocations']:6.0f} "
                    f"{r['check']:8.1e}"
                )
                worst.append((name, fmi, r))
                if r["unclear"]:
                    notes.append(
                        f"{name} (FMI {fmi}.0): the plain loop's sign test failed in "
                        f"{r['unclear']:.0f} steps (a switching function near zero): there the "
                        "FMU did more than the floor"
                    )
                if fmi == 2 and shutil.which("strace"):
                    few, many = syscalls(
                        host, [str(fmi), str(binary), token, sv, gv, repr(H), data], folder
                    )
                    notes.append(
                        f"{name}: system calls, 1e3 steps {few}, 1e5 steps {many}"
                        + (" (none per step)" if few == many else " (STEPS MAKE SYSTEM CALLS)")
                    )
                if fmi == 2:
                    syms = run(["nm", "-D", "--undefined-only", str(binary)]).split()
                    locks = sorted({s for s in syms if LOCKS.search(s)})
                    notes.append(f"{name}: lock functions imported: {', '.join(locks) or 'none'}")
        print(
            "  best: the fastest round of 1e6 steps of each over all processes, wall, and their "
            "ratio (the step's own cost: another thread on the same physical core, which a "
            "virtual machine's host may run there, only adds time); extra: best FMU - best "
            "plain; calls: the best round of the same calls from the same host code into "
            "functions that do nothing (an extra below it: what the FMU adds to its arithmetic "
            "is less than its calls alone cost); loop: medians of whole "
            "loops, wall, the range of the processes' ratios, and thread CPU (ratio FMU / "
            "plain); instr: callgrind, per step; rel diff: FMU against plain outputs, over "
            "their largest"
        )
        print_worst(worst, args.steps, args.processes)
        for note in notes:
            print("  " + note)
        print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
