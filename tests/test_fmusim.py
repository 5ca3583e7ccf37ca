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

import subprocess

import numpy as np
import pytest
from fmpy import simulate_fmu
from host_runs import (
    CAR_OUT,
    FULL_NAMES,
    FULL_OUT,
    ROAD_NAMES,
    T_END,
    H,
    assert_first_order,
    bump,
    cosim,
    euler_against_cosim,
    flag_changes,
    host_program,
    peak_errors,
    road_samples,
    two_track,
    write_input,
)

FMUSIM, pytestmark = host_program(
    "FMUSIM",
    "fmusim",
    "fmusim",
    "the C fmusim of modelica/Reference-FMUs, up to release v0.0.39: its release archives "
    "or its sources",
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


def _fmusim_euler(fmu, tmp_path, outputs, h, csv):
    """fmusim's forward Euler at step ``h`` on the input CSV ``csv``."""
    step = ("--solver", "euler", "--output-interval", f"{h!r}", "--input-file", str(csv))
    return _fmusim(fmu, tmp_path, outputs, "me", *step)


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_quarter_car_model_exchange_over_the_bump_in_fmusim(native_fmus, tmp_path, fmi):
    """fmusim's forward Euler on the model-exchange QuarterCar over the 80 mm bump against
    fmpy's co-simulation on the same road: Euler's first-order error (at most 5e-3 of each
    output's peak at h = 1e-5 s, measured 7e-4 to 2.5e-3), halving with h (ratio 1.6 to
    2.4) and, extrapolated, at most a fifth of the error at h / 2; the wheel leaves the road
    and lands, each change within one communication step of the co-simulation's."""
    fmu = native_fmus[fmi + "QuarterCar"]
    outputs = (*CAR_OUT, "tire_contact")
    coarse, fine, richardson, runs, cs = euler_against_cosim(
        fmu, tmp_path, ROAD_NAMES, [bump], outputs, _fmusim_euler
    )
    print("fmusim Euler, h and h/2 and extrapolated:", coarse, fine, richardson)
    assert_first_order(coarse, fine, richardson, CAR_OUT)
    cs_changes = flag_changes(cs, "tire_contact")
    assert cs_changes.size == 4  # two lift-offs, two landings
    for run in runs:
        changes = flag_changes(run, "tire_contact")
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
    cs_changes = flag_changes(cs, "tire_contact")
    assert cs_changes.size == 2 and np.max(np.abs(cs["stop_force"])) > 1000
    errors = {}
    for rtol in (1e-6, 1e-8):
        options = ["--solver", "cvode", "--tolerance", f"{rtol:g}", "--output-interval", f"{H!r}"]
        for name, value in THROW.items():
            options += ["--start-value", name, str(value)]
        me = _fmusim(fmu, tmp_path, outputs, "me", *options, stop=0.3)
        errors[rtol] = peak_errors(me, cs, CAR_OUT)
        changes = flag_changes(me, "tire_contact")
        assert changes.size == 2
        assert np.all((cs_changes - changes >= 0) & (cs_changes - changes <= H)), (
            changes,
            cs_changes,
        )
    print("fmusim CVode, rtol 1e-6 and 1e-8:", errors)
    for o in CAR_OUT:
        assert errors[1e-8][o] <= 1e3 * 1e-8, (o, errors)
        assert errors[1e-6][o] >= 10 * errors[1e-8][o], (o, errors)


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_full_car_cosimulation_in_fmusim_equals_fmpy(native_fmus, tmp_path, fmi):
    """FullCar.fmu co-simulated by fmusim and by fmpy on the two-track bump, 1 ms steps, the
    same input values at the same communication points: equal to 1e-9 of each output's peak
    (rounding; the CSV carries 17 digits)."""
    fmu = native_fmus[fmi + "FullCar"]
    t, z, v = road_samples(two_track())
    cs = cosim(fmu, FULL_NAMES, t, z, v, FULL_OUT)
    csv = tmp_path / "in.csv"
    write_input(csv, FULL_NAMES, t, z, v, fine=1)
    run = _fmusim(
        fmu, tmp_path, FULL_OUT, "cs", "--output-interval", f"{H!r}", "--input-file", str(csv)
    )
    errors = peak_errors(run, cs, FULL_OUT)
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
    coarse, fine, richardson, _, _ = euler_against_cosim(
        fmu, tmp_path, FULL_NAMES, two_track(), FULL_OUT, _fmusim_euler
    )
    print("fmusim Euler, h and h/2 and extrapolated:", coarse, fine, richardson)
    assert_first_order(coarse, fine, richardson, FULL_OUT)
