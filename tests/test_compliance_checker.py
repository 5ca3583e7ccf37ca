"""The FMU Compliance Checker (modelica-tools/FMUComplianceChecker, on Modelon's FMI Library)
on the FMI 2.0 FMUs: the native ones (bodies, cars, roads) in co-simulation and model exchange,
the pythonfmu ones in co-simulation (with the interpreter's libpython preloaded).

The checker's default run gives the FMUs no input, so nothing switches. The native cars are
also driven over the 80 mm bump at 20 m/s from an input CSV, where the wheels leave the road
and land: in model exchange the checker steps forward Euler and handles each state event its
event indicators report at the end of the step (no location), so its result is compared
with fmpy's co-simulation of the same FMU on the same road as a first-order method's
(``host_runs``); in co-simulation it sets the same inputs at the same communication points
as fmpy, so the two agree to rounding.

The checker is a C host that knows nothing of Python: it loads the FMU, checks its model
description, simulates it and unloads it. Its summary must report no error and no warning,
from the checker or the FMU, and the process must exit 0 (a pythonfmu FMU whose interpreter is
torn down in the wrong order at exit ended it with SIGABRT after a correct simulation, 10 of 10
runs; bodyvib.runtime.teardown now releases it from a C exit handler, nothing asked of the
host).

The project does not build the checker. The tests run when ``fmuCheck.linux64`` is on ``PATH``
or the ``FMUCHECK`` environment variable names it, and skip with that reason otherwise.
"""

import os
import re
import subprocess
import sysconfig

import host_runs as hosts
import numpy as np
import pytest
from conftest import FMU_NAMES

CHECKER, pytestmark = hosts.host_program(
    "FMUCHECK",
    "fmuCheck.linux64",
    "FMU Compliance Checker",
    "build modelica-tools/FMUComplianceChecker from source",
)


def _libpython():
    """The shared libpython of this interpreter: pythonfmu's binary does not link it, so a C
    host preloads it (as pythonfmu's own documentation says)."""
    return os.path.join(sysconfig.get_config_var("LIBDIR"), sysconfig.get_config_var("LDLIBRARY"))


def _check(path, mode, tmp_path, *options, env=None):
    """Run the checker on one FMU (``options``: step, input file, ...; a 1 ms step by
    default): (exit status, its log, the result CSV's rows)."""
    out = tmp_path / "result.csv"
    p = subprocess.run(
        [CHECKER, "-k", mode, *(options or ("-h", "1e-3")), "-s", str(hosts.T_END), "-l", "4"]
        + ["-o", str(out), path],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
        env=env,
    )
    rows = out.read_text().splitlines() if out.exists() else []
    return p.returncode, p.stdout + p.stderr, rows


def _summary(log):
    counts = {}
    for what, pattern in (
        ("fmu", r"(\d+) warning\(s\) and error\(s\)"),
        ("warnings", r"\t(\d+) Warning\(s\)"),
        ("errors", r"\t(\d+) Error\(s\)"),
    ):
        m = re.search(pattern, log)
        counts[what] = int(m.group(1)) if m else None
    return counts


#: the native FMI 2.0 FMUs: the bodies, the cars and the roads
NATIVE = FMU_NAMES + ("HalfCar", "FullCar", "Road", "RoadFrontRear", "RoadFourWheel")


@pytest.mark.parametrize("mode", ["cs", "me"])
@pytest.mark.parametrize("name", NATIVE)
def test_native_fmi2_fmus_pass_the_compliance_checker(native_dist, tmp_path, name, mode):
    status, log, rows = _check(str(native_dist / f"{name}.fmu"), mode, tmp_path)
    assert status == 0, log[-2000:]
    assert _summary(log) == {"fmu": 0, "warnings": 0, "errors": 0}, log[-2000:]
    assert len(rows) > 10  # a header and the simulated points


@pytest.mark.parametrize("name", FMU_NAMES)
def test_pythonfmu_fmus_pass_the_compliance_checker_and_exit_cleanly(python_fmus, tmp_path, name):
    env = {**os.environ, "LD_PRELOAD": _libpython()}
    status, log, rows = _check(python_fmus[name], "cs", tmp_path, env=env)
    assert _summary(log) == {"fmu": 0, "warnings": 0, "errors": 0}, log[-2000:]
    assert len(rows) > 10
    assert status == 0, f"exit status {status} after a complete check:\n{log[-1000:]}"


def _result(rows, outputs):
    """The checker's result CSV as columns (its header quotes the names), the value after
    each event where a time repeats."""
    names = [n.strip('"') for n in rows[0].split(",")]
    data = np.array([[float(x) for x in r.split(",")] for r in rows[1:]])
    keep = np.r_[np.diff(data[:, 0]) > 0, True]
    return {n: data[keep, names.index(n)] for n in ("time", *outputs)}


def _checker_run(fmu, tmp_path, outputs, mode, *options):
    """The checker's run of ``fmu`` with ``options``, which must report nothing: the outputs."""
    status, log, rows = _check(str(fmu), mode, tmp_path, *options)
    assert status == 0, log[-2000:]
    assert _summary(log) == {"fmu": 0, "warnings": 0, "errors": 0}, log[-2000:]
    return _result(rows, outputs)


def _checker_euler(fmu, tmp_path, outputs, h, csv):
    """The checker's model exchange (forward Euler at step ``h``) on the input CSV, an output
    row about each millisecond."""
    points = str(round(hosts.T_END / hosts.H))
    return _checker_run(fmu, tmp_path, outputs, "me", "-h", repr(h), "-n", points, "-i", str(csv))


#: the QuarterCar's outputs that are states or sums of states (no event-time kink)
DISPLACEMENTS = ("seat_displacement", "suspension_deflection")


def test_quarter_car_model_exchange_over_the_bump_in_the_checker(native_fmus, tmp_path):
    """The model-exchange QuarterCar over the 80 mm bump at 20 m/s: the checker reports
    nothing; its Euler result is first order against fmpy's co-simulation (at most 5e-3 of
    each output's peak at h = 1e-5 s, halving with h). Extrapolation removes it from the
    displacements (measured 2e-6 and 1e-5 of the peak), not from the forces (a third of it
    left here, all of it at the full car's tires):
    the checker takes each event at the end of the Euler step it falls in, a fraction of h
    late that varies irregularly with h, and a force's slope jumps there. The wheel
    leaves the road and lands twice, each change within one communication step of the
    co-simulation's (the checker detects a crossing at the end of the Euler step and writes
    the next output row on its own grid of Euler steps, within a step of the millisecond)."""
    outputs = (*hosts.CAR_OUT, "tire_contact")
    coarse, fine, richardson, runs, cs = hosts.euler_against_cosim(
        native_fmus["QuarterCar"], tmp_path, hosts.ROAD_NAMES, [hosts.bump], outputs, _checker_euler
    )
    print("checker Euler, h and h/2 and extrapolated:", coarse, fine, richardson)
    hosts.assert_first_order(coarse, fine, richardson, hosts.CAR_OUT, DISPLACEMENTS)
    cs_changes = hosts.flag_changes(cs, "tire_contact")
    assert cs_changes.size == 4
    for run in runs:
        changes = hosts.flag_changes(run, "tire_contact")
        assert changes.size == cs_changes.size
        assert np.all(np.abs(changes - cs_changes) <= 1.05 * hosts.H), (changes, cs_changes)


@pytest.mark.parametrize(
    ("name", "names", "tracks", "outputs"),
    [
        ("QuarterCar", hosts.ROAD_NAMES, [hosts.bump], (*hosts.CAR_OUT, "tire_contact")),
        ("FullCar", hosts.FULL_NAMES, hosts.two_track(), hosts.FULL_OUT),
    ],
)
def test_cars_cosimulation_over_the_bump_in_the_checker_equals_fmpy(
    native_fmus, tmp_path, name, names, tracks, outputs
):
    """The co-simulation QuarterCar and FullCar (two-track bump) driven by the checker and
    by fmpy with the same inputs at the same 1 ms communication points: the checker reports
    nothing and the outputs agree to 1e-9 of each one's peak (rounding; the CSV carries 17
    digits), wheels leaving the road included."""
    t, z, v = hosts.road_samples(tracks)
    ref = hosts.cosim(native_fmus[name], names, t, z, v, outputs)
    csv = tmp_path / "in.csv"
    hosts.write_input(csv, names, t, z, v, fine=1)
    points = ("-n", str(round(hosts.T_END / hosts.H)))
    run = _checker_run(
        native_fmus[name], tmp_path, outputs, "cs", "-h", repr(hosts.H), *points, "-i", str(csv)
    )
    errors = hosts.peak_errors(run, ref, outputs)
    print("checker co-simulation against fmpy:", errors)
    for o in outputs:
        assert errors[o] <= 1e-9, (o, errors)


def test_full_car_model_exchange_over_the_bump_in_the_checker(native_fmus, tmp_path):
    """The model-exchange FullCar on the two-track bump: as the QuarterCar, the checker
    reports nothing and its Euler result is first order against fmpy's co-simulation, the
    body's motion (bounce, pitch, roll) extrapolated to at most a fifth (measured 1e-6 to
    3e-6 of the peak)."""
    coarse, fine, richardson, _, _ = hosts.euler_against_cosim(
        native_fmus["FullCar"],
        tmp_path,
        hosts.FULL_NAMES,
        hosts.two_track(),
        hosts.FULL_OUT,
        _checker_euler,
    )
    print("checker Euler, h and h/2 and extrapolated:", coarse, fine, richardson)
    hosts.assert_first_order(coarse, fine, richardson, hosts.FULL_OUT, hosts.FULL_OUT[:3])
