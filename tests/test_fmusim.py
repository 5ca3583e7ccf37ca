"""The native FMUs in fmusim, the simulator of the Modelica Reference FMUs: a host that is
neither fmpy nor the project's own, with its own input interpolation, event handling and
solvers (forward Euler, SUNDIALS CVode), against fmpy's co-simulation of the same FMU.

- The QuarterCar in model exchange (FMI 2.0 and 3.0) over the 80 mm bump at 20 m/s, with
  fmusim's forward Euler: the road is an input CSV, the seat force a zero column. fmusim
  interpolates a continuous input linearly between the CSV's rows and sets it at the start
  of each Euler step, so the co-simulation is given the same road: the samples at the 1 ms
  communication points with the chord slope as road velocity (the FMU's in-step road is
  then the same straight line between the samples). What is left is Euler's own error:
  first order, so it halves with the step, and Richardson's extrapolation of the two runs
  removes it to second order. The wheel leaves the road and lands again, each change within
  one communication step of the co-simulation's.
- The QuarterCar in model exchange with CVode (BDF; fmusim gives it ``rtol`` and
  ``atol = rtol * nominal``, nominals 1): the car alone, thrown so that it lifts off and hits
  the bump stop, no input moving. The global error is a modest multiple of ``rtol`` times
  each output's peak and falls with ``rtol``; lift-off and landing are located by CVode's
  root finding on the FMU's event indicators, within the output step before the
  co-simulation's flag changes.
- FullCar.fmu in co-simulation on a two-track bump (left and right tracks apart, rear wheels
  a wheelbase behind): fmusim sets each input from the CSV at each communication point as
  fmpy does, so the outputs agree to rounding; in model exchange with Euler as the
  QuarterCar.

fmusim's CVode is not driven by a moving road here: fmusim sets continuous inputs only when
CVode evaluates the event indicators and at output points, never in the right-hand side,
and bounds none of CVode's steps, so a car at rest steps over the bump unseen (measured: no
lift-off, every output 100 % off).

The project does not build fmusim. The tests run when ``fmusim`` is on ``PATH`` or the
``FMUSIM`` environment variable names it, and skip with that reason otherwise.
"""

import os
import shutil
import subprocess

import numpy as np
import pytest
from fmpy import simulate_fmu
from test_regimes import BUMP, SPEED, H

FMUSIM = os.environ.get("FMUSIM") or shutil.which("fmusim")

pytestmark = [
    pytest.mark.integration,
    pytest.mark.skipif(
        FMUSIM is None,
        reason="no fmusim: put fmusim on PATH or set FMUSIM (the C fmusim of "
        "modelica/Reference-FMUs, up to release v0.0.39: its release archives or its sources)",
    ),
]

CAR_OUT = ("seat_displacement", "suspension_deflection", "tire_force", "stop_force")
T_END = 1.0
#: the Euler steps (fmusim's output interval is its Euler step): h and h / 2
EULER_H = 1e-5


def _bump(t, h=BUMP[0], length=BUMP[1], at=BUMP[2]):
    """A 1 - cos bump of height h and length ``length`` starting ``at`` metres on, at SPEED."""
    s = SPEED * np.asarray(t) - at
    return np.where((s >= 0) & (s <= length), 0.5 * h * (1 - np.cos(2 * np.pi * s / length)), 0.0)


def _road_samples(tracks):
    """The road at the communication points (one column per track) and the chord slopes:
    the co-simulation's in-step road is then the linear interpolation fmusim makes."""
    t = np.arange(0.0, T_END + 1.5 * H, H)
    z = np.column_stack([f(t) for f in tracks])
    v = np.vstack([np.diff(z, axis=0) / H, np.zeros((1, z.shape[1]))])
    return t[:-1], z[:-1], v[:-1]


def _write_input(path, names, t, z, v, fine):
    """The CSV fmusim reads: time, then each track's displacement and velocity column, the
    seat force and its rate at 0; on a grid ``fine`` times finer than the samples (the
    displacement interpolated, the velocity held over each communication step)."""
    tf = np.arange(0.0, t[-1] + H / (2 * fine), H / fine)
    k = np.minimum(np.floor(tf / H + 1e-9).astype(int), len(t) - 1)
    cols, header = [tf], ["time"]
    for j, (dn, vn) in enumerate(names):
        cols += [np.interp(tf, t, z[:, j]), v[k, j]]
        header += [dn, vn]
    cols += [np.zeros_like(tf)] * 2
    header += ["seat_force", "seat_force_rate"]
    np.savetxt(
        path,
        np.column_stack(cols),
        delimiter=",",
        header=",".join(header),
        comments="",
        fmt="%.17g",
    )


def _fmusim(fmu, tmp_path, outputs, interface, *options, stop=T_END):
    """Run fmusim on ``fmu`` to ``stop``: the recorded outputs (after each event)."""
    out = tmp_path / "out.csv"
    args = [FMUSIM, "--interface-type", interface, "--stop-time", str(stop), *options]
    for o in outputs:
        args += ["--output-variable", o]
    p = subprocess.run(
        [*args, "--output-file", str(out), str(fmu)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,
    )
    assert p.returncode == 0, p.stdout + p.stderr
    run = np.genfromtxt(out, delimiter=",", names=True, deletechars="")
    keep = np.r_[np.diff(run["time"]) > 0, True]  # the value after each event
    return run[keep]


def _cosim(fmu, names, t, z, v, outputs, start_values=None):
    """fmpy's co-simulation of ``fmu`` with the road samples and chord slopes as inputs."""
    fields = [("time", float)] + [(n, float) for pair in names for n in pair]
    fields += [("seat_force", float), ("seat_force_rate", float)]
    rows = [(ti, *np.ravel(np.column_stack([zi, vi])), 0.0, 0.0) for ti, zi, vi in zip(t, z, v)]
    return simulate_fmu(
        str(fmu),
        stop_time=T_END,
        step_size=H,
        output_interval=H,
        input=np.array(rows, dtype=fields),
        output=outputs,
        start_values=start_values or {},
    )


def _errors(run, ref, outputs):
    """Largest difference of each output on the reference's grid, over its peak."""
    return {
        o: float(
            np.max(np.abs(np.interp(ref["time"], run["time"], run[o]) - ref[o]))
            / np.max(np.abs(ref[o]))
        )
        for o in outputs
    }


def _changes(run, flag):
    return run["time"][1:][np.diff(run[flag]) != 0]


def _euler_against_cosim(fmu, tmp_path, names, tracks, outputs):
    """fmusim's Euler at EULER_H and EULER_H / 2 on the road CSV and fmpy's co-simulation on
    the same road: (errors at h, at h / 2, of the Richardson extrapolation, runs, cs)."""
    t, z, v = _road_samples(tracks)
    cs = _cosim(fmu, names, t, z, v, outputs)
    csv = tmp_path / "in.csv"
    _write_input(csv, names, t, z, v, fine=10)
    runs = []
    for h in (EULER_H, EULER_H / 2):
        step = ("--solver", "euler", "--output-interval", f"{h!r}", "--input-file", str(csv))
        runs.append(_fmusim(fmu, tmp_path, outputs, "me", *step))
    coarse, fine = (_errors(r, cs, outputs) for r in runs)
    on_grid = [{o: np.interp(cs["time"], r["time"], r[o]) for o in outputs} for r in runs]
    richardson = {
        o: float(np.max(np.abs(2 * on_grid[1][o] - on_grid[0][o] - cs[o])) / np.max(np.abs(cs[o])))
        for o in outputs
    }
    return coarse, fine, richardson, runs, cs


ROAD_NAMES = (("road_displacement", "road_velocity"),)


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_quarter_car_model_exchange_over_the_bump_in_fmusim(native_fmus, tmp_path, fmi):
    """fmusim's forward Euler on the model-exchange QuarterCar over the 80 mm bump against
    fmpy's co-simulation on the same road: Euler's first-order error (at most 5e-3 of each
    output's peak at h = 1e-5 s, measured 7e-4 to 2.5e-3), halving with h (ratio 1.6 to
    2.4) and, extrapolated, at most a fifth of the error at h / 2; the wheel leaves the road
    and lands, each change within one communication step of the co-simulation's."""
    fmu = native_fmus[fmi + "QuarterCar"]
    outputs = (*CAR_OUT, "tire_contact")
    coarse, fine, richardson, runs, cs = _euler_against_cosim(
        fmu, tmp_path, ROAD_NAMES, [_bump], outputs
    )
    print("fmusim Euler, h and h/2 and extrapolated:", coarse, fine, richardson)
    for o in CAR_OUT:
        assert coarse[o] <= 5e-3, (o, coarse)
        assert 1.6 <= coarse[o] / fine[o] <= 2.4, (o, coarse, fine)
        assert richardson[o] <= fine[o] / 5, (o, fine, richardson)
    cs_changes = _changes(cs, "tire_contact")
    assert cs_changes.size == 4  # two lift-offs, two landings
    for run in runs:
        changes = _changes(run, "tire_contact")
        assert changes.size == cs_changes.size
        assert np.all(np.abs(changes - cs_changes) <= H), (changes, cs_changes)


#: the car alone, thrown: the wheel leaves the road, the body hits the bump stop, it lands
THROW = {"state.unsprung.v": 3.0, "state.sprung.v": -1.0}


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_quarter_car_model_exchange_with_cvode_in_fmusim(native_fmus, tmp_path, fmi):
    """fmusim's CVode on the thrown car (nothing moving the road) against fmpy's
    co-simulation with located events: the same lift-off and landing, each located by
    CVode's root finding within the output step before the co-simulation's flag changes;
    outputs within 1e3 rtol of each one's peak at rtol 1e-8 (the bound fmpy's CVode meets
    on this car; measured 1.6e2 rtol), the error falling with the tolerance (at least 10x
    from rtol 1e-6 to 1e-8; measured 66x and more).

    fmusim restarts CVode after an event only when the FMU says its states' values changed:
    at a regime change the FMU says so (the right-hand side switches), without which BDF's
    history spans the switch and the error stays near 1e-3 whatever the tolerance."""
    fmu = native_fmus[fmi + "QuarterCar"]
    outputs = (*CAR_OUT, "tire_contact")
    cs = simulate_fmu(fmu, stop_time=0.3, step_size=H, output=outputs, start_values=THROW)
    cs_changes = _changes(cs, "tire_contact")
    assert cs_changes.size == 2 and np.max(np.abs(cs["stop_force"])) > 1000
    errors = {}
    for rtol in (1e-6, 1e-8):
        options = ["--solver", "cvode", "--tolerance", f"{rtol:g}", "--output-interval", f"{H!r}"]
        for name, value in THROW.items():
            options += ["--start-value", name, str(value)]
        me = _fmusim(fmu, tmp_path, outputs, "me", *options, stop=0.3)
        errors[rtol] = _errors(me, cs, CAR_OUT)
        changes = _changes(me, "tire_contact")
        assert changes.size == 2
        assert np.all((cs_changes - changes >= 0) & (cs_changes - changes <= H)), (
            changes,
            cs_changes,
        )
    print("fmusim CVode, rtol 1e-6 and 1e-8:", errors)
    for o in CAR_OUT:
        assert errors[1e-8][o] <= 1e3 * 1e-8, (o, errors)
        assert errors[1e-6][o] >= 10 * errors[1e-8][o], (o, errors)


CORNERS = ("front_left", "front_right", "rear_left", "rear_right")
FULL_OUT = ("bounce", "pitch", "roll", *(f"tire_force_{c}" for c in CORNERS))


def _two_track():
    """Per corner: the left track's 80 mm bump at 10 m, the right track's 40 mm one at
    10.5 m; the rear wheels meet them a wheelbase (lf + lr = 2.8 m) later."""
    base = BUMP[2]
    ats = (base, base + 0.5, base + 2.8, base + 3.3)
    heights = (BUMP[0], BUMP[0] / 2, BUMP[0], BUMP[0] / 2)
    return [lambda t, h=h, a=a: _bump(t, h=h, at=a) for h, a in zip(heights, ats)]


FULL_NAMES = tuple((f"road_displacement_{c}", f"road_velocity_{c}") for c in CORNERS)


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_full_car_cosimulation_in_fmusim_equals_fmpy(native_fmus, tmp_path, fmi):
    """FullCar.fmu co-simulated by fmusim and by fmpy on the two-track bump, 1 ms steps, the
    same input values at the same communication points: equal to 1e-9 of each output's peak
    (rounding; the CSV carries 17 digits)."""
    fmu = native_fmus[fmi + "FullCar"]
    t, z, v = _road_samples(_two_track())
    cs = _cosim(fmu, FULL_NAMES, t, z, v, FULL_OUT)
    csv = tmp_path / "in.csv"
    _write_input(csv, FULL_NAMES, t, z, v, fine=1)
    run = _fmusim(
        fmu, tmp_path, FULL_OUT, "cs", "--output-interval", f"{H!r}", "--input-file", str(csv)
    )
    errors = _errors(run, cs, FULL_OUT)
    print("fmusim co-simulation against fmpy:", errors)
    assert np.max(np.abs(cs["roll"])) > 1e-3  # the tracks differ: the body rolls
    for o in FULL_OUT:
        assert errors[o] <= 1e-9, (o, errors)


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_full_car_model_exchange_in_fmusim(native_fmus, tmp_path, fmi):
    """FullCar.fmu in model exchange, fmusim's Euler on the two-track bump against fmpy's
    co-simulation on the same road: as the QuarterCar, first-order error (at most 5e-3 of
    each output's peak at h = 1e-5 s), halving with h, removed by extrapolation."""
    fmu = native_fmus[fmi + "FullCar"]
    coarse, fine, richardson, _, _ = _euler_against_cosim(
        fmu, tmp_path, FULL_NAMES, _two_track(), FULL_OUT
    )
    print("fmusim Euler, h and h/2 and extrapolated:", coarse, fine, richardson)
    for o in FULL_OUT:
        assert coarse[o] <= 5e-3, (o, coarse)
        assert 1.6 <= coarse[o] / fine[o] <= 2.4, (o, coarse, fine)
        assert richardson[o] <= fine[o] / 5, (o, fine, richardson)
