"""The batched sweep engine's cost per case-step against a minimal batched exact step.

    python benchmarks/bench_batched.py [--cases 64] [--duration 30] [--repeats 3]

For the reduced and the ISO 7962 body on the quarter car (ISO 8608 class C, speeds
10-30 m/s, ``--cases`` cases sharing 5 roads, 1 ms steps), measured side by side in one
process, interleaved over ``--repeats`` rounds (medians):

* the engine: :func:`bodyvib.vehicle.sweep.engines.run_engine` ("batched") on all the
  cases, everything a task does: road synthesis, model assembly and exact discretization,
  the compiled time loop, the streaming Wk weighting and the ISO 2631-1 figures. Each
  stage's share of the engine's CPU time is measured by timing the engine's own
  functions while it runs (road: the road samples; models: each body on its car as a
  linear model; matrices: the exact step; compiled loop, and of it the minimal step's
  time; other: the rest);
* the minimal step: a numba loop of ``x <- Phi x + g_z z + g_v v`` and the outputs
  ``C x + d_z z + d_v v`` per case and sample, on the very matrices and road samples the
  engine built (captured from its call of the compiled loop), by the compiled loop's own
  step function (the same lanes and vector loops), nothing else. The outputs are the
  head, the seat, the forces and any watched rows: a car whose seat gives its x and y
  (the full car) adds those two rows for the engine's weighting, and the floor leaves
  them out.

The ratio engine / minimal is the engine's cost over its arithmetic floor (target <= 2).

The cases above run the quarter car linearized (``"linear": true``). Then the same cases
at 10-18 m/s on the quarter car with its tire contact and stops (the engine watches the
switching functions; no case of class C at these speeds switches, so none is run again
with events: checked) against the same spec linear, interleaved round by round: the ratio nonlinear /
linear is what watching for switchings costs a sweep where nothing switches.
The load average and the process CPU time are printed beside the wall times: on a
shared machine CPU time is the steadier guide. The first round compiles (numba cache)
and is not counted.
"""

import argparse
import os
import statistics
import sys
import time
from contextlib import contextmanager

import numpy as np

from bodyvib.vehicle.sweep import engines, kernel
from bodyvib.vehicle.sweep.spec import expand

#: The bodies measured on the quarter car, and on the nonlinear car against the linear one
BODIES = ("reduced-paper", "iso7962")
#: (body, car, linear) of each measurement: both bodies on the quarter car, the reduced
#: body on the full car (four road points on two tracks) linearized: with its contacts
#: most of these cases lift a wheel and leave the batched loop for the event solver
SETUPS = (
    ("reduced-paper", "quarter-car", False),
    ("iso7962", "quarter-car", False),
    ("reduced-paper", "full-car", True),
)


def spec(body: str, cases: int, duration: float, car: str = "quarter-car") -> dict:
    """``cases`` cases on 5 roads (speeds 10-30 m/s), the body's parameters varied."""
    per = max(1, cases // 5)
    return {
        "car": car,
        "road": "C",
        "speed": [10, 15, 20, 25, 30],
        "seed": 0,
        "duration": duration,
        "step": 1e-3,
        "linear": True,  # the linear car (the engine's floor); linear_ratio: the nonlinear
        "body": [
            {
                "model": body,
                "samples": per,
                "seed": 0,
                "vary": _vary(body),
            }
        ],
    }


def _vary(body: str) -> dict:
    """Three of the body's parameters within +-10 % (Latin hypercube of the spec)."""
    from bodyvib.models import load_model

    names = list(load_model(body).parameters)[:3]
    return {p: [0.9, 1.1] for p in names}


class Stages:
    """CPU time spent in the engine's stages while it runs (patched in, then restored).

    CPU time, not wall time: on a shared machine the other users' work stretches
    wall times by up to two times from one call to the next.
    """

    def __init__(self):
        self.seconds = {"road": 0.0, "models": 0.0, "matrices": 0.0, "compiled loop": 0.0}
        self.captured = None
        self.axes = False

    def _timed(self, stage, fn, capture=False):
        def wrapper(*a, **k):
            t0 = time.process_time()
            try:
                return fn(*a, **k)
            finally:
                self.seconds[stage] += time.process_time() - t0
                if capture:  # the packed matrices and roads of the (one) group
                    self.captured = a[:3]
                    # the seat's x and y rows (M's last two, weighted in the same pass)
                    self.axes = (a[6] if len(a) > 6 else k.get("axes")) is not None

        return wrapper

    @contextmanager
    def patched(self):
        saved = (
            kernel.run,
            engines.case_road_input,
            engines.case_wheel_inputs,
            engines.Discretization.matrices,
            engines._seated,
        )
        kernel.run = self._timed("compiled loop", saved[0], capture=True)
        engines.case_road_input = self._timed("road", saved[1])
        engines.case_wheel_inputs = self._timed("road", saved[2])  # a car's several wheels
        engines.Discretization.matrices = self._timed("matrices", saved[3])
        engines._seated = self._timed("models", saved[4])  # each body on its car, assembled
        try:
            yield self
        finally:
            (
                kernel.run,
                engines.case_road_input,
                engines.case_wheel_inputs,
                engines.Discretization.matrices,
                engines._seated,
            ) = saved


_minimal = None


def minimal_kernel():
    """The floor: the exact step and two outputs of every case, cases side by side in lanes.

    The engine's compiled loop's own step (:mod:`bodyvib.vehicle.sweep.kernel`), the
    same layout and vector loops over the lanes, and nothing else: no weighting, no
    figures, only the sum of squares of the two outputs (so that the compiler keeps
    them). A car driven at several road points (the full car's four wheels) has one
    state, each point's road entering through its own input columns:
    ``x <- Phi x + sum_p (g_z z + g_v v)_p``.
    """
    global _minimal
    if _minimal is None:
        from numba import njit

        step = kernel._functions()[0]

        @njit(cache=True, nogil=True, boundscheck=False)
        def run(M, gz, gv, road, z, v):  # pragma: no cover (compiled)
            chunks, m, n, L = M.shape
            P = gz.shape[1]
            x = np.empty((n, L))
            out = np.empty((m, L))
            zk = np.empty((P, L))
            vk = np.empty((P, L))
            y = np.zeros((2, L))
            for ch in range(chunks):
                x[:] = 0.0
                for k in range(z.shape[0]):
                    step(M, gz, gv, road, z, v, ch, k, x, out, zk, vk)
                    for i in range(L):
                        y[0, i] += out[n, i] * out[n, i]
                        y[1, i] += out[n + 1, i] * out[n + 1, i]
            return y

        _minimal = run
    return _minimal


_one_by_one = None


def case_by_case_kernel():
    """The exact step one case at a time, its state in registers (for comparison only):
    ``(one road point, several)``."""
    global _one_by_one
    if _one_by_one is None:
        from numba import njit

        @njit(cache=True, nogil=True, boundscheck=False)
        def run(M, gz, gv, road, z, v):  # pragma: no cover (compiled)
            chunks, m, n, L = M.shape
            out = np.empty(m)
            x = np.empty(n)
            y = np.zeros((2, chunks, L))
            for ch in range(chunks):
                for i in range(L):
                    x[:] = 0.0
                    ri = road[ch, 0, i]
                    for k in range(z.shape[0]):
                        zk = z[k, ri]
                        vk = v[k, ri]
                        for r in range(m):
                            acc = 0.0
                            for q in range(n):
                                acc += M[ch, r, q, i] * x[q]
                            out[r] = acc + (gz[ch, 0, r, i] * zk + gv[ch, 0, r, i] * vk)
                        for q in range(n):
                            x[q] = out[q]
                        y[0, ch, i] += out[n] * out[n]
                        y[1, ch, i] += out[n + 1] * out[n + 1]
            return y

        @njit(cache=True, nogil=True, boundscheck=False)
        def run_points(M, gz, gv, road, z, v):  # pragma: no cover (compiled)
            chunks, m, n, L = M.shape
            P = gz.shape[1]
            out = np.empty(m)
            x = np.empty(n)
            zk = np.empty(P)
            vk = np.empty(P)
            y = np.zeros((2, chunks, L))
            for ch in range(chunks):
                for i in range(L):
                    x[:] = 0.0
                    for k in range(z.shape[0]):
                        for p in range(P):
                            zk[p] = z[k, road[ch, p, i]]
                            vk[p] = v[k, road[ch, p, i]]
                        for r in range(m):
                            acc = 0.0
                            for q in range(n):
                                acc += M[ch, r, q, i] * x[q]
                            for p in range(P):
                                acc = acc + (gz[ch, p, r, i] * zk[p] + gv[ch, p, r, i] * vk[p])
                            out[r] = acc
                        for q in range(n):
                            x[q] = out[q]
                        y[0, ch, i] += out[n] * out[n]
                        y[1, ch, i] += out[n + 1] * out[n + 1]
            return y

        _one_by_one = (run, run_points)
    return _one_by_one


def one_round(cases, stages: Stages):
    t0, c0 = time.perf_counter(), time.process_time()
    with stages.patched():
        rows = engines.run_engine("batched", cases)
    eng = (time.perf_counter() - t0, time.process_time() - c0)
    if any(r.get("error") for r in rows):
        raise SystemExit(f"a case failed: {[r['error'] for r in rows if r.get('error')][:1]}")
    packed, z, v = stages.captured
    z, v = np.ascontiguousarray(z.T), np.ascontiguousarray(v.T)  # the engine's layout
    # the floor steps the state and the outputs before the seat's x and y
    m = packed.M.shape[1] - (2 if stages.axes else 0)
    M = np.ascontiguousarray(packed.M[:, :m])
    gz, gv = (np.ascontiguousarray(g[:, :, :m]) for g in (packed.gz, packed.gv))
    run = minimal_kernel()
    t0, c0 = time.perf_counter(), time.process_time()
    run(M, gz, gv, packed.road, z, v)
    low = (time.perf_counter() - t0, time.process_time() - c0)
    one = case_by_case_kernel()[packed.gz.shape[1] > 1]
    c0 = time.process_time()
    one(M, gz, gv, packed.road, z, v)
    return eng, low, time.process_time() - c0, packed.M.shape, packed.gz.shape[1]


def linear_ratio(body: str, cases: int, duration: float, repeats: int) -> None:
    """Print the engine's time on the nonlinear quarter car over the linear one's."""
    # 10-18 m/s: class C lifts the wheel at 30 m/s (and nearly at 25): here nothing switches
    slow = {"speed": [10, 12, 14, 16, 18]}
    runs = {
        lin: expand({**spec(body, cases, duration), **slow, "linear": lin}) for lin in (False, True)
    }
    times = {False: [], True: []}
    for r in range(repeats + 1):  # the first round compiles: not counted
        for lin, cs in runs.items():
            t0, c0 = time.perf_counter(), time.process_time()
            rows = engines.run_engine("batched", cs)
            if r:
                times[lin].append((time.perf_counter() - t0, time.process_time() - c0))
            ways = {row["stepping"] for row in rows}
            if ways != {"linear" if lin else "batched"}:
                raise SystemExit(f"{body}: cases stepped {sorted(ways)}; expected none to switch")
    (nw, nc), (lw, lc) = (
        tuple(statistics.median(x[i] for x in times[lin]) for i in (0, 1)) for lin in (False, True)
    )
    print(
        f"{body}, contact and stops watched (nothing switched) / linear car: "
        f"{nw / lw:.3f} wall, {nc / lc:.3f} CPU ({nw:.2f} s / {lw:.2f} s wall)"
    )


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--cases", type=int, default=64, help="cases per body (default 64)")
    p.add_argument("--duration", type=float, default=30.0, help="seconds per case (default 30)")
    p.add_argument("--repeats", type=int, default=3, help="rounds after a warm-up (default 3)")
    args = p.parse_args(argv)
    print(f"load: {os.getloadavg()[0]:.2f} (1 min) on {os.cpu_count()} cores")
    for body, car, linear in SETUPS:
        cases = expand(
            {**spec(body, args.cases, args.duration, car), **({"linear": True} if linear else {})}
        )
        steps = len(cases) * cases[0].steps
        one_round(cases[:2], Stages())  # compile (or load the numba cache)
        eng, low, shares, single = [], [], [], []
        for _ in range(args.repeats):
            st = Stages()
            e, m, s1, shape, points = one_round(cases, st)
            eng.append(e)
            low.append(m)
            single.append(s1)
            shares.append({k: s / e[1] for k, s in st.seconds.items()})
        ew, ec = (statistics.median(x[i] for x in eng) for i in (0, 1))
        mw, mc = (statistics.median(x[i] for x in low) for i in (0, 1))
        print(
            f"{body} on the {car}{' (linearized)' if linear else ''}: {len(cases)} cases x {cases[0].steps} steps, {shape[2]} "
            f"states, {shape[3]} lanes, {points} road points, medians of {args.repeats}"
        )
        print(
            f"  engine  {ew * 1e9 / steps:7.1f} ns per case-step wall, {ec * 1e9 / steps:7.1f} CPU"
            f"  ({ew:.2f} s)"
        )
        print(
            f"  minimal {mw * 1e9 / steps:7.1f} ns per case-step wall, {mc * 1e9 / steps:7.1f} CPU"
            f"  ({mw:.2f} s)"
        )
        print(
            f"  (the step case by case, state in registers: "
            f"{statistics.median(single) * 1e9 / steps:.1f} ns CPU)"
        )
        print(f"  ratio engine / minimal: {ew / mw:.2f} wall, {ec / mc:.2f} CPU (target <= 2)")
        rw, rc = ([e[i] / m[i] for e, m in zip(eng, low)] for i in (0, 1))
        print(
            f"    range over the rounds: {min(rw):.2f}-{max(rw):.2f} wall, "
            f"{min(rc):.2f}-{max(rc):.2f} CPU"
        )
        rest = 1.0
        for k in shares[0]:
            share = statistics.median(s[k] for s in shares)
            rest -= share
            print(f"    {k:14s} {100 * share:5.1f} %")
            if k == "compiled loop":  # the step's part of it: the minimal loop's time
                print(f"      {'of it, step':12s} {100 * mc / ec:5.1f} %")
                print(f"      {'Wk + figures':12s} {100 * (share - mc / ec):5.1f} %")
        print(f"    {'other':14s} {100 * rest:5.1f} %  (step rows, grouping, figures, rows)")
    for body in BODIES:
        linear_ratio(body, args.cases, args.duration, args.repeats)
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
