"""Cost of one co-simulation macro-step against the bare FMI calls it makes.

    python benchmarks/bench_cosim.py [--steps 5000] [--repeats 7] [--body HumanBody3DOF]

One macro-step of :func:`bodyvib.vehicle.cosim.cosimulate` makes eight fmpy calls:
car ``setReal`` (road, seat force and its rate), ``getReal`` (five outputs),
``doStep``, ``getReal`` (seat motion); body ``setReal``, ``doStep``,
``setReal``, ``getReal`` (four outputs). Measured side by side in one run,
interleaved repeat by repeat, on fresh instances of the same FMUs:

* master: ``cosimulate`` over a class C road at 20 m/s with a 1 ms step
  (extrapolation, recording, progress off);
* bare FMI calls: the same eight calls per step with precomputed arguments, no
  master bookkeeping (no extrapolation, no recording).

Prints the median time per macro-step of each, their ratio (target: at most
1.3) and the master's real-time factor (simulated time / wall time).
"""

import argparse
import statistics
import sys
import tempfile
import time

import numpy as np

from bodyvib.runtime import contract
from bodyvib.vehicle.cosim import BODY_INPUTS, BODY_OUTPUTS, CAR_OUTPUTS, cosimulate, open_fmu
from bodyvib.vehicle.fmus import build_project_fmu
from bodyvib.vehicle.road.synthetic import make_road, road_input


def bare_calls(car, body, z, v, steps, h):
    """The master's FMI calls, nothing else. Returns seconds per macro-step."""
    cf, bf = car.fmu, body.fmu
    car_in = [car.vr[k] for k in contract.CAR_INPUTS]  # with seat_force_rate
    car_out = [car.vr[k] for k in CAR_OUTPUTS]
    car_motion = car_out[:2]
    body_in = [body.vr[k] for k in BODY_INPUTS]
    body_out = [body.vr[k] for k in BODY_OUTPUTS[3:] + BODY_OUTPUTS[:3]]  # as the master
    args = [[float(z[k]), float(v[k]), 0.0, 0.0] for k in range(steps)]
    seat = [0.0, 0.0]
    c_set, c_get, c_step = cf.setReal, cf.getReal, cf.doStep
    b_set, b_get, b_step = bf.setReal, bf.getReal, bf.doStep
    t0 = time.perf_counter()
    for k in range(steps):
        t = k * h
        c_set(car_in, args[k])
        c_get(car_out)
        c_step(t, h)
        c_get(car_motion)
        b_set(body_in, seat)
        b_step(t, h)
        b_set(body_in, seat)
        b_get(body_out)
    return (time.perf_counter() - t0) / steps


def master(car, body, z, v, steps, h):
    """The master over the same number of macro-steps. Returns seconds per macro-step."""
    t0 = time.perf_counter()
    cosimulate(car, body, z[: steps + 1], v[: steps + 1], h)
    return (time.perf_counter() - t0) / steps


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=5000, help="macro-steps per repeat")
    ap.add_argument("--repeats", type=int, default=7, help="repeats (medians reported)")
    ap.add_argument(
        "--body",
        default="HumanBody3DOF",
        choices=["HumanBody3DOF", "HumanBodyISO7962"],
        help="body FMU",
    )
    a = ap.parse_args(argv)
    h, V = 1e-3, 20.0
    with tempfile.TemporaryDirectory() as d:
        car_path = str(build_project_fmu("QuarterCar", d))
        body_path = str(build_project_fmu(a.body, d))
        T = (a.steps + 1) * h
        t = np.arange(a.steps + 1) * h
        z, v = road_input(make_road("C", V, T), V, t)
        times = {"master": [], "bare FMI calls": []}
        for _ in range(a.repeats):
            for name, fn in (("master", master), ("bare FMI calls", bare_calls)):
                with open_fmu(car_path, "car") as car, open_fmu(body_path, "body") as body:
                    times[name].append(fn(car, body, z, v, a.steps, h))
    med = {k: statistics.median(x) for k, x in times.items()}
    print(
        f"{a.body} on QuarterCar, class C road at {V:g} m/s, step {h:g} s, "
        f"{a.steps} macro-steps x {a.repeats} repeats (medians)"
    )
    for k, m in med.items():
        print(f"  {k:<16} {1e6 * m:8.1f} us per macro-step")
    ratio = med["master"] / med["bare FMI calls"]
    print(
        f"  ratio master / bare FMI calls: {ratio:.3f} (target <= 1.3: "
        f"{'met' if ratio <= 1.3 else 'NOT met'})"
    )
    print(
        f"  real-time factor of the master: {h / med['master']:.1f} "
        "(simulated seconds per wall-clock second)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
