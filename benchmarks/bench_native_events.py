"""The native car's step with its tire contact and stops against the linear car's, in one run.

    python benchmarks/bench_native_events.py [--steps 20000] [--rounds 21] [--processes 5]
                                             [--no-callgrind]

Builds the native QuarterCar (FMI 2.0, linux64) from the car's model, with its contact
and stops (:mod:`bodyvib.fmu.native_regimes`), and the same car linearized
(:func:`bodyvib.runtime.network.linearized`), compiles ``benchmarks/native_events_host.c``
with the FMUs' own flags and runs it in ``--processes`` fresh processes. Each process:

* ``--rounds`` rounds (the first a warm-up), each ``--steps`` steps of the nonlinear car
  then of the linear car (set the road's displacement and velocity, doStep, get two
  outputs) on a 1 mm sine road where nothing switches: thread-CPU ns per step of both and
  their ratio (target at most 1.3);
* the nonlinear car over the 80 mm full-cosine bump 1 m long at 20 m/s, each step timed
  alone: the median of the steps in which an event was located (a flag changed) against
  the median of the others, and the number of event steps per pass.

Then, unless ``--no-callgrind``, the instructions per step of each car's loop on the same
road (``valgrind --tool=callgrind``, 10,000 steps each loop): independent of the machine's
load, the steadiest ratio. Printed: medians over the processes, the range of the ratios,
the instruction counts and their ratio, and the load average.
"""

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

HOST = Path(__file__).resolve().parent / "native_events_host.c"


def binary(fmu: Path, folder: Path) -> tuple:
    """(shared library, GUID) of an FMI 2.0 FMU."""
    from fmpy import read_model_description

    with zipfile.ZipFile(fmu) as z:
        z.extractall(folder)
    md = read_model_description(str(fmu))
    return folder / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so", md.guid


def instructions(run: list, loop: str, steps: int) -> float:
    """Instructions per step inside the host's function ``loop`` (callgrind)."""
    out = subprocess.run(
        ["valgrind", "--tool=callgrind", f"--toggle-collect={loop}",
         "--callgrind-out-file=/dev/null", *run],
        capture_output=True, text=True, check=True,
    ).stderr  # fmt: skip
    return int(re.search(r"Collected : (\d+)", out).group(1)) / steps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20_000)
    ap.add_argument("--rounds", type=int, default=21)
    ap.add_argument("--processes", type=int, default=5)
    ap.add_argument("--no-callgrind", action="store_true", help="skip the instruction counts")
    args = ap.parse_args()
    from bodyvib.fmu.native import COMMON_FLAGS, build_native_fmu
    from bodyvib.runtime.network import linearized
    from bodyvib.vehicle.quarter_car import load_car

    with tempfile.TemporaryDirectory(prefix="bench_events_") as tmp:
        tmp = Path(tmp)
        print("building the nonlinear and the linear QuarterCar ...", file=sys.stderr)
        car = load_car()
        paths = [
            build_native_fmu(net, "car", "QuarterCar", "bench", tmp / sub, platforms=["linux64"])
            for net, sub in ((car, "nl"), (linearized(car), "lin"))
        ]
        (nl, nl_token), (lin, lin_token) = (binary(p, tmp / f"x{i}") for i, p in enumerate(paths))
        exe = tmp / "host"
        flags = [f for f in COMMON_FLAGS if f.startswith(("-std", "-O", "-f"))]
        # -fno-ipa-icf: the two cars' loops are the same code; kept apart, each is counted alone
        subprocess.run(
            ["gcc", *flags, "-fno-ipa-icf", str(HOST), "-o", str(exe), "-ldl", "-lm"], check=True
        )
        load0 = os.getloadavg()[0]
        rows, events = [], []
        for _ in range(args.processes):
            out = subprocess.run(
                [str(exe), str(nl), nl_token, str(lin), lin_token, str(args.steps),
                 str(args.rounds), "1000"],
                capture_output=True, text=True, check=True,
            ).stdout  # fmt: skip
            for line in out.splitlines():
                key, *vals = line.split()
                if key == "round":
                    rows.append(tuple(map(float, vals)))
                elif key == "event":
                    events.append(tuple(map(float, vals)))
        load1 = os.getloadavg()[0]
        counts = None
        if not args.no_callgrind and shutil.which("valgrind"):
            run = [str(exe), str(nl), nl_token, str(lin), lin_token, "10000", "2", "10"]
            counts = [instructions(run, loop, 10_000) for loop in ("run_nl", "run_lin")]
    nl_ns = statistics.median(r[0] for r in rows)
    lin_ns = statistics.median(r[1] for r in rows)
    ratios = [r[0] / r[1] for r in rows]
    ev_ns = statistics.median(e[0] for e in events)
    plain_ns = statistics.median(e[1] for e in events)
    print(f"load average {load0:.2f} (start) {load1:.2f} (end), {os.cpu_count()} cores")
    print(f"nothing switches: nonlinear {nl_ns:.1f} ns/step, linear {lin_ns:.1f} ns/step")
    print(
        f"  ratio nonlinear / linear: median {statistics.median(ratios):.3f} "
        f"(rounds {min(ratios):.3f} .. {max(ratios):.3f}; target <= 1.3)"
    )
    if counts:
        print(
            f"  instructions a step (set, doStep, get; callgrind): nonlinear {counts[0]:.0f}, "
            f"linear {counts[1]:.0f}, ratio {counts[0] / counts[1]:.3f} (target <= 1.3)"
        )
    print(
        f"located event: {ev_ns / 1e3:.1f} us per event step against {plain_ns:.1f} ns per "
        f"plain step ({ev_ns / plain_ns:.0f}x), {int(events[0][2])} event steps per bump"
    )


if __name__ == "__main__":
    main()
