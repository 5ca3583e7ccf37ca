"""Native (C) FMUs against pythonfmu FMUs: step cost in a C host and in bodyvib's master.

    python benchmarks/bench_native.py [--native-steps 1000000] [--python-steps 20000]
                                      [--duration 2] [--repeats 5]

Builds the FMI 2.0 FMUs of both kinds into a temporary folder, compiles
tests/c_host/native_host.c and measures, side by side in one run:

* C host loop (one step = set the two seat inputs, doStep, get the five body outputs;
  inputs precomputed): ns per step of HumanBody3DOF (5 states) and HumanBodyISO7962
  (12 states), native and pythonfmu in the same host program. The host repeats its loop
  7 times; the median wall-clock time and the median thread CPU time per step are
  reported (on a shared machine the CPU time is the steadier figure). The pythonfmu FMU
  needs LD_PRELOAD of libpython, PYTHONHOME and PYTHONPATH with numpy (see
  tests/test_fmu_c_host.py); the native FMU runs with an empty environment.
* the same loop with a new step size at every step (native only): what a step-size change
  costs (the matrix exponential of the augmented matrix and the output rows);
* bodyvib's master (bodyvib.vehicle.cosim.cosimulate, fmpy FMU2Slave): microseconds per
  macro-step of the body on the quarter car over an ISO 8608 class C road, native body +
  native car against pythonfmu body + pythonfmu car; median of the repeats.

Targets: at most 100 ns per 5-state step in a C host, at least 300 times faster
than the pythonfmu FMU in the same host.
"""

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import sysconfig
import tempfile
import time
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bodyvib.runtime.contract import BODY_OUTPUTS  # noqa: E402
from bodyvib.vehicle.fmus import build_fmus  # noqa: E402

HOST = ROOT / "tests" / "c_host" / "native_host.c"
BODY_OUT = list(BODY_OUTPUTS)  # the body interface of the FMU contract


def compile_host(folder: Path) -> str:
    import fmpy

    exe = str(folder / "native_host")
    headers = os.path.join(os.path.dirname(fmpy.__file__), "c-code")
    subprocess.run(
        ["gcc", "-std=c99", "-O2", "-I", headers, str(HOST), "-o", exe, "-ldl", "-lm", "-lpthread"],
        check=True,
    )
    return exe


def python_env() -> dict:
    """What a C host needs to run a pythonfmu FMU (nothing else, not even PATH)."""
    import numpy

    lib = os.path.join(
        sysconfig.get_config_var("LIBDIR") or "", sysconfig.get_config_var("LDLIBRARY") or ""
    )
    if not (sysconfig.get_config_var("Py_ENABLE_SHARED") and os.path.isfile(lib)):
        raise SystemExit(
            f"{sys.executable} has no shared libpython: a C host cannot run pythonfmu FMUs with it"
        )
    env = {
        "LD_PRELOAD": lib,
        "PYTHONHOME": sys.base_prefix
        if sys.base_prefix == sys.base_exec_prefix
        else f"{sys.base_prefix}:{sys.base_exec_prefix}",
        "PYTHONPATH": os.path.dirname(os.path.dirname(numpy.__file__)),
    }
    return env


def c_host_step(exe, fmu, folder: Path, steps: int, env: dict, mode: str = "bench"):
    """(median wall ns, median CPU ns) per step of the host's bench loop."""
    from fmpy import read_model_description

    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outs = [n for n in BODY_OUT if n in vr]
    with zipfile.ZipFile(fmu) as z:
        z.extractall(folder)
    binary = folder / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
    res = (folder / "resources").as_uri()
    out = subprocess.run(
        [
            exe,
            "--resources",
            res,
            mode,
            str(binary),
            md.guid,
            f"{vr['seat_displacement']},{vr['seat_velocity']}",
            ",".join(str(vr[n]) for n in outs),
            "0.001",
            str(steps),
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=1800,
    )
    if out.returncode != 0:
        raise SystemExit(f"C host failed on {fmu}: {out.stderr[-500:]}")
    wall, cpu = [], []
    for line in out.stdout.splitlines():
        if line.startswith("ns_per_step"):
            f = line.split()
            wall.append(float(f[1]))
            cpu.append(float(f[3]))
    return statistics.median(wall), statistics.median(cpu), len(outs)


def master_step(body, car, duration, repeats):
    """Median microseconds per macro-step of bodyvib.vehicle.cosim.cosimulate."""
    import numpy as np

    from bodyvib.vehicle.cosim import cosimulate, open_fmu
    from bodyvib.vehicle.road.synthetic import make_road, road_input

    h = 1e-3
    t = np.arange(int(round(duration / h)) + 1) * h
    z, v = road_input(make_road("C", 20.0, duration), 20.0, t)
    times = []
    for _ in range(repeats):
        with open_fmu(car, "car") as c, open_fmu(body, "body") as b:
            t0 = time.perf_counter()
            cosimulate(c, b, z, v, h)
            times.append((time.perf_counter() - t0) / (t.size - 1))
    return statistics.median(times) * 1e6


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument(
        "--native-steps",
        type=int,
        default=1_000_000,
        help="steps per loop for the native FMUs (default 1e6)",
    )
    p.add_argument(
        "--python-steps",
        type=int,
        default=20_000,
        help="steps per loop for the pythonfmu FMUs (default 2e4)",
    )
    p.add_argument(
        "--duration", type=float, default=2.0, help="simulated seconds per master run (default 2)"
    )
    p.add_argument("--repeats", type=int, default=5, help="master runs per kind (default 5)")
    args = p.parse_args(argv)
    if shutil.which("gcc") is None:
        raise SystemExit("gcc not found")
    with tempfile.TemporaryDirectory(prefix="bodyvib-bench-native-") as tmp:
        tmp = Path(tmp)
        names = ["HumanBody3DOF", "HumanBodyISO7962", "QuarterCar"]
        print("building FMUs ...", file=sys.stderr, flush=True)
        native = build_fmus(tmp / "native", names=names, native=True, fmi=(2,))
        python = build_fmus(tmp / "python", names=names)
        exe = compile_host(tmp)
        print("one step in a C host (set 2 inputs, doStep, get outputs), medians of 7 loops:")
        print(
            f"  {'FMU':18s} {'states':>6s} {'native wall':>12s} {'native CPU':>11s} "
            f"{'pythonfmu wall':>15s} {'pythonfmu CPU':>14s} {'ratio (CPU)':>12s}"
        )
        for name, states in (("HumanBody3DOF", 5), ("HumanBodyISO7962", 12)):
            nw, nc, _ = c_host_step(exe, native[name], tmp / f"n-{name}", args.native_steps, {})
            pw, pc, _ = c_host_step(
                exe, python[name], tmp / f"p-{name}", args.python_steps, python_env()
            )
            print(
                f"  {name:18s} {states:6d} {nw:9.1f} ns {nc:8.1f} ns {pw / 1e3:12.2f} us "
                f"{pc / 1e3:11.2f} us {pc / nc:11.0f}x"
            )
            if states == 5:
                five = (nw, nc, pc / nc, pw / nw)
        print("a new step size at every step (native, each step rediscretizes), median CPU:")
        for name, states in (("HumanBody3DOF", 5), ("HumanBodyISO7962", 12)):
            _, vc, _ = c_host_step(
                exe, native[name], tmp / f"v-{name}", 20_000, {}, mode="bench-vary"
            )
            print(f"  {name:18s} {states:6d} {vc / 1e3:9.2f} us per step")
        print(
            f"targets: <= 100 ns per 5-state step: wall {five[0]:.1f} ns, CPU {five[1]:.1f} ns; "
            f">= 300x faster than pythonfmu in the same host: {five[2]:.0f}x (CPU), "
            f"{five[3]:.0f}x (wall)"
        )
        print(
            f"bodyvib master (bodyvib.vehicle.cosim, fmpy), class C road, 1 ms, {args.duration:g} s, "
            f"median of {args.repeats}:"
        )
        mn = master_step(native["HumanBody3DOF"], native["QuarterCar"], args.duration, args.repeats)
        mp = master_step(python["HumanBody3DOF"], python["QuarterCar"], args.duration, args.repeats)
        print(f"  native body + car    {mn:8.2f} us/macro-step")
        print(f"  pythonfmu body + car {mp:8.2f} us/macro-step")
        print(f"  ratio pythonfmu / native: {mp / mn:.1f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
