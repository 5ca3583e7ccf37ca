"""Cost of one communication step of HumanBody3DOF.fmu through fmpy, against plain numpy.

    python benchmarks/bench_fmu_step.py [--steps 2000] [--repeats 15]

One step = set the two seat inputs, doStep, get the four outputs. Measured side
by side in one run, interleaved repeat by repeat:

* fmpy FMU2Slave: ``setReal``, ``doStep``, ``getReal`` (fmpy's convenience
  methods, which build ctypes arrays on every call);
* fmpy raw: the same FMI functions as loaded by fmpy, with preallocated ctypes
  arrays (what a master that cares about speed does);
* plain numpy: the same exact update in the caller's process, ``x = Phi x +
  Gamma0 u + Gamma1 du``, ``y = C x + D u``, inputs from and outputs to Python
  floats (the baseline of the target);
* lean numpy: the same with the matrices combined once and arrays preallocated
  (the floor of any Python implementation), for scale;
* FMU core alone: the slave's run-time core called directly, without FMI: the
  rest of the FMU's time is the FMI crossing (ctypes, pythonfmu's C++ wrapper).

Prints the median time per step of each and the ratios (medians). Target: the
FMU step at most 2x the numpy update.
"""

import argparse
import contextlib
import statistics
import sys
import tempfile
import time

import numpy as np

from bodyvib.models import load_model
from bodyvib.runtime.contract import BODY_OUTPUTS
from bodyvib.runtime.discretize import Discretization
from bodyvib.vehicle.cosim import open_fmu
from bodyvib.vehicle.fmus import build_project_fmu

OUT = list(BODY_OUTPUTS[:4])  # as the master reads them (not seat_force_rate)
SIG = ["head.a", "head.x", "torso.x", "seat_force"]


def seat(n, h):
    t = np.arange(n + 1) * h
    return (
        t,
        0.01 * np.sin(2 * np.pi * 4.4 * t),
        0.01 * 2 * np.pi * 4.4 * np.cos(2 * np.pi * 4.4 * t),
    )


def run_fmpy(fmu, vr, t, xr, vs, h):
    vin = [vr["seat_displacement"], vr["seat_velocity"]]
    vout = [vr[n] for n in OUT]
    set_real, do_step, get_real = fmu.setReal, fmu.doStep, fmu.getReal
    t0 = time.perf_counter()
    for k in range(t.size - 1):
        set_real(vin, [xr[k], vs[k]])
        do_step(t[k], h)
        y = get_real(vout)
    return (time.perf_counter() - t0) / (t.size - 1), y


def run_raw(fmu, vr, t, xr, vs, h):
    from fmpy.fmi2 import fmi2Real, fmi2True, fmi2ValueReference

    vin = (fmi2ValueReference * 2)(vr["seat_displacement"], vr["seat_velocity"])
    vout = (fmi2ValueReference * 4)(*[vr[n] for n in OUT])
    uin = (fmi2Real * 2)()
    yout = (fmi2Real * 4)()
    comp = fmu.component
    set_real, do_step, get_real = fmu.fmi2SetReal, fmu.fmi2DoStep, fmu.fmi2GetReal
    xr, vs, t = xr.tolist(), vs.tolist(), t.tolist()
    t0 = time.perf_counter()
    for k in range(len(t) - 1):
        uin[0] = xr[k]
        uin[1] = vs[k]
        set_real(comp, vin, 2, uin)
        do_step(comp, t[k], h, fmi2True)
        get_real(comp, vout, 4, yout)
        y = yout[:]
    return (time.perf_counter() - t0) / (len(t) - 1), y


def run_numpy(mats, C, D, t, xr, vs, h):
    Phi, G0, G1 = mats
    x = np.zeros(Phi.shape[0])
    xr, vs = xr.tolist(), vs.tolist()
    t0 = time.perf_counter()
    for k in range(len(t) - 1):
        u = np.array([xr[k], vs[k]])
        du = np.array([vs[k], 0.0])
        y = (C @ x + D @ u).tolist()
        x = Phi @ x + G0 @ u + G1 @ du
    return (time.perf_counter() - t0) / (len(t) - 1), y


def run_numpy_lean(mats, C, D, t, xr, vs, h):
    """The same update with the matrices combined once and arrays preallocated."""
    Phi, G0, G1 = mats
    n = Phi.shape[0]
    M = np.hstack([Phi, G0 + G1 @ np.array([[0.0, 1.0], [0.0, 0.0]])])  # x+ = M [x | u]
    Y = np.hstack([C, D])  # y  = Y [x | u]
    z = np.zeros(n + 2)
    xn = np.empty(n)
    y = np.empty(Y.shape[0])
    xr, vs = xr.tolist(), vs.tolist()
    t0 = time.perf_counter()
    for k in range(len(t) - 1):
        z[n] = xr[k]
        z[n + 1] = vs[k]
        out = np.dot(Y, z, out=y).tolist()
        np.dot(M, z, out=xn)
        z[:n] = xn
    return (time.perf_counter() - t0) / (len(t) - 1), out


def run_core(t, xr, vs, h):
    """The FMU's run-time core called directly (no FMI, no ctypes): the slave's own share."""
    from bodyvib.runtime.engine import FmuCore

    core = FmuCore("body", load_model("reduced-paper"))
    core.initialize()
    xr, vs, t = xr.tolist(), vs.tolist(), t.tolist()
    set_real, do_step, get_real = core.set_real, core.do_step, core.get_real
    names = [v.name for v in core.variables]
    vin = [names.index(n) for n in ("seat_displacement", "seat_velocity")]
    vout = [names.index(n) for n in OUT]
    t0 = time.perf_counter()
    for k in range(len(t) - 1):
        set_real(vin, [xr[k], vs[k]])
        do_step(t[k], h)
        y = get_real(vout)
    return (time.perf_counter() - t0) / (len(t) - 1), y


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--steps", type=int, default=2000, help="steps per repeat (default 2000)")
    p.add_argument("--repeats", type=int, default=15, help="repeats (default 15)")
    p.add_argument("--step-size", type=float, default=1e-3, help="communication step, s")
    args = p.parse_args(argv)

    h = args.step_size
    with tempfile.TemporaryDirectory() as tmp, contextlib.ExitStack() as stack:
        path = str(build_project_fmu("HumanBody3DOF", tmp))
        slave_a = stack.enter_context(open_fmu(path, "body", "convenience"))
        slave_b = stack.enter_context(open_fmu(path, "body", "raw"))
        fmu_a, fmu_b, vr = slave_a.fmu, slave_b.fmu, slave_a.vr
        lm = Discretization(load_model("reduced-paper"))
        idx = [lm.model.output_index(s) for s in SIG]
        mats = lm.matrices(h)
        C, D = lm.model.C[idx], lm.model.D[idx]
        t, xr, vs = seat(args.steps, h)
        times = {
            "fmpy FMU2Slave": [],
            "fmpy raw": [],
            "plain numpy": [],
            "lean numpy": [],
            "FMU core alone": [],
        }
        for r in range(args.repeats):
            t_r = t + r * t[-1]  # FMU time keeps increasing
            times["fmpy FMU2Slave"].append(run_fmpy(fmu_a, vr, t_r, xr, vs, h)[0])
            times["fmpy raw"].append(run_raw(fmu_b, vr, t_r, xr, vs, h)[0])
            times["plain numpy"].append(run_numpy(mats, C, D, t, xr, vs, h)[0])
            times["lean numpy"].append(run_numpy_lean(mats, C, D, t, xr, vs, h)[0])
            times["FMU core alone"].append(run_core(t, xr, vs, h)[0])

    med = {k: statistics.median(v) for k, v in times.items()}
    print(
        f"one communication step (set 2 inputs, doStep, get 4 outputs), HumanBody3DOF, "
        f"h = {h:g} s; median of {args.repeats} repeats x {args.steps} steps"
    )
    for k, v in med.items():
        print(f"  {k:16s} {v * 1e6:8.2f} us/step")
    base = med["plain numpy"]
    print(
        f"ratio fmpy FMU2Slave / plain numpy: {med['fmpy FMU2Slave'] / base:.2f}x   (target <= 2x)"
    )
    print(f"ratio fmpy raw / plain numpy:       {med['fmpy raw'] / base:.2f}x")
    lean = med["lean numpy"]
    print(f"ratio fmpy FMU2Slave / lean numpy:  {med['fmpy FMU2Slave'] / lean:.2f}x")
    print(f"ratio fmpy raw / lean numpy:        {med['fmpy raw'] / lean:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
