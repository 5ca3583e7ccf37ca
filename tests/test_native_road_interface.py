"""The standard's interface of the native Road.fmu (FMI 2.0, 3.0), through fmpy.

Road.fmu has the linear FMUs' state machine (the same code, ``bodyvib_fsm.c``): calls the
standard's table does not allow are errors with the reason logged, the run's start time is
the model's time (the outputs are the table at speed * t, t from the start time). It has no
inputs (input derivatives are refused), no states (model exchange sets the time and reads
the outputs there; no directional derivatives, as its model description says), and exact
output derivatives: order 1 of road_displacement is road_velocity, order 2 the cubic
Hermite interpolant's second derivative times speed^2 (order 1 of road_velocity too), order
2 of road_velocity its third derivative times speed^3 -- derivatives of the cubic of the
row interval the position lies in, checked against central differences of the outputs.
"""

import numpy as np
import pytest
from test_native_fmi_interface import Raw

pytestmark = pytest.mark.integration

SPEED = 20.0  # m/s, Road.fmu's default
OUTS = ["road_displacement", "road_velocity"]


@pytest.fixture(scope="module")
def table():
    """The library's interpolant of the table Road.fmu carries (the independent reference)."""
    from bodyvib.vehicle.fmus import fmu_road
    from bodyvib.vehicle.road.synthetic import road_table

    return road_table(fmu_road(), 601.0)


def _road(native_dist, fmi):
    return Raw(str(native_dist / ("fmi3/" if fmi == 3 else "") / "Road.fmu"))


def _library(table, t):
    z, dz = table.evaluate(SPEED * np.atleast_1d(float(t)))
    return [z[0, 0], SPEED * dz[0, 0]]


@pytest.mark.parametrize("fmi", [2, 3])
def test_road_obeys_the_state_machine_and_its_start_time(native_dist, table, fmi):
    """Out-of-order calls are Error with the reason logged; started at t0 = 2.5 s the outputs
    are the library's interpolant at speed * t0 (initialization) and speed * (t0 + h) after a
    step, bit for bit; a step not from the model's time, a step after Terminate, a parameter
    change after initialization and GetReal before initialization are refused."""
    f = _road(native_dist, fmi)
    get = "getFloat64" if f.fmi3 else "getReal"
    set_ = "setFloat64" if f.fmi3 else "setReal"
    vr = [f.vr[n] for n in OUTS]
    t0, h = 2.5, 1e-3
    try:
        seen = {
            "get_instantiated": f.status(get, vr),
            "step_instantiated": f.status("doStep", t0, h),
        }
        if f.fmi3:
            f.fmu.enterInitializationMode(startTime=t0)
        else:
            f.fmu.setupExperiment(startTime=t0)
            f.fmu.enterInitializationMode()
        at_start = f.get(OUTS)
        seen["step_initialization"] = f.status("doStep", t0, h)
        f.fmu.exitInitializationMode()
        seen["speed_stepping"] = f.status(set_, [f.vr["speed"]], [10.0])
        seen["step_from_zero"] = f.status("doStep", 0.0, h)
        seen["step"] = f.status("doStep", t0, h)
        after_step = f.get(OUTS)
        seen["terminate"] = f.status("terminate")
        seen["step_terminated"] = f.status("doStep", t0 + h, h)
        seen["get_terminated"] = f.status(get, vr)
    finally:
        f.close()
    assert {k for k, v in seen.items() if v == 0} == {"step", "terminate", "get_terminated"}
    assert {k for k, v in seen.items() if v == 3} == set(seen) - {
        "step",
        "terminate",
        "get_terminated",
    }, seen
    assert at_start == _library(table, t0)
    assert after_step == _library(table, t0 + h)
    text = "\n".join(f.messages)
    name = "fmi3GetFloat64" if f.fmi3 else "fmi2GetReal"
    assert f"{name} is not allowed in state Instantiated" in text, text
    assert f"fmi{fmi}DoStep is not allowed in state Terminated" in text, text
    assert "but the model is at t = 2.5 s" in text, text
    assert "parameter speed is fixed after initialization" in text, text


@pytest.mark.parametrize("fmi", [2, 3])
def test_road_started_late_gives_the_table_at_speed_times_time(native_dist, table, fmi):
    """fmpy's simulate_fmu from t0 = 3.21 s to 4.21 s at 1 ms: the outputs equal the library's
    interpolant at speed * t, bit for bit (a run that ignored the start time would be 64 m
    off)."""
    from fmpy import simulate_fmu

    sub = "fmi3/" if fmi == 3 else ""
    r = simulate_fmu(
        str(native_dist / f"{sub}Road.fmu"), start_time=3.21, stop_time=4.21, output_interval=1e-3
    )
    assert r["time"][0] == 3.21
    z, dz = table.evaluate(SPEED * r["time"])
    np.testing.assert_array_equal(r["road_displacement"], z[:, 0])
    np.testing.assert_array_equal(r["road_velocity"], SPEED * dz[:, 0])


def _inside_a_row_interval(table, t, delta):
    """t moved so that speed * (t +- delta) lies in the middle of one row interval."""
    u = (SPEED * t - table._p0) / table._dp
    return (np.floor(u) + 0.5) * table._dp / SPEED + table._p0 / SPEED


@pytest.mark.parametrize("fmi", [2, 3])
def test_road_output_derivatives_equal_central_differences(native_dist, table, fmi):
    """At six times inside row intervals, outputs read from instances started at t - d, t,
    t + d (d = 10 us, 0.2 mm at 20 m/s, a hundredth of the 20 mm row spacing): order 1 of
    road_displacement is road_velocity exactly and the central difference within
    d^2/6 |x'''| (the truncation of a cubic) plus rounding; order 2 of road_displacement and
    order 1 of road_velocity equal the second / first central differences (exact for the
    cubic and its quadratic derivative) within rounding; order 2 of road_velocity is the
    interval's constant third derivative, equal to the second difference of road_velocity."""
    f = _road(native_dist, fmi)
    d, eps = 1e-5, np.finfo(float).eps
    times = [_inside_a_row_interval(table, t, d) for t in (0.5, 1.2345, 2.0, 3.3, 4.75, 6.1)]
    checked = 0
    try:
        for t in times:
            rows = []
            for s in (t - d, t, t + d):
                f.status("reset")
                f.init(start=s)
                rows.append(f.get(OUTS))
                if s == t:
                    der = f.derivatives(OUTS * 2, [1, 1, 2, 2])
            (zm, vm), (z0, v0), (zp, vp) = rows
            third = der[3]  # speed^3 z''': d^3 x / dt^3 on this interval
            # rounding of an output: eps times its size and its change over the time's ulp
            rz = 4 * eps * (abs(z0) + abs(v0) * t)
            rv = 4 * eps * (abs(v0) + abs(der[1]) * t)
            assert der[0] == v0  # order 1 of road_displacement is road_velocity
            assert abs((zp - zm) / (2 * d) - der[0]) <= d**2 / 6 * abs(third) + rz / d
            assert abs((zp - 2 * z0 + zm) / d**2 - der[2]) <= 4 * rz / d**2
            assert abs((vp - vm) / (2 * d) - der[1]) <= rv / d
            assert der[2] == der[1]  # both speed^2 z''
            assert abs((vp - 2 * v0 + vm) / d**2 - third) <= 4 * rv / d**2
            assert abs(third) > 0 and abs(der[1]) > 0
            checked += 1
    finally:
        f.close()
    assert checked == len(times)


@pytest.mark.parametrize("fmi", [2, 3])
def test_road_refuses_input_and_directional_derivatives(native_dist, fmi):
    """No inputs: any input derivative is Error (logged); no states and no inputs: the model
    description says providesDirectionalDerivative(s)=false and a call is Error; output
    derivatives of the parameter or of order 3 are Error."""
    from fmpy import read_model_description

    path = str(native_dist / ("fmi3/" if fmi == 3 else "") / "Road.fmu")
    md = read_model_description(path)
    for element in (md.coSimulation, md.modelExchange):
        assert element is not None
        assert element.providesDirectionalDerivative is False
    f = _road(native_dist, fmi)
    speed, z = f.vr["speed"], f.vr["road_displacement"]
    try:
        f.init()
        if f.fmi3:
            seen = [
                f.status("getDirectionalDerivative", [z], [speed], [1.0]),
                f.status("getOutputDerivatives", [speed], [1]),
                f.status("getOutputDerivatives", [z], [3]),
            ]
        else:
            seen = [
                f.status("setRealInputDerivatives", [speed], [1], [0.0]),
                f.status("setRealInputDerivatives", [z], [1], [0.0]),
                f.status("getDirectionalDerivative", [z], [speed], [1.0]),
                f.status("getRealOutputDerivatives", [speed], [1]),
                f.status("getRealOutputDerivatives", [z], [3]),
            ]
    finally:
        f.close()
    assert seen == [3] * len(seen)
    text = "\n".join(f.messages)
    assert "provides none" in text, text
    if not f.fmi3:
        assert "is not an input; input derivatives are for inputs only" in text, text


@pytest.mark.parametrize("fmi", [2, 3])
def test_road_in_model_exchange_equals_co_simulation(native_dist, fmi):
    """fmpy's model-exchange run (no continuous states: the outputs at the times it sets)
    from t0 = 1.5 s equals the co-simulation run sample for sample."""
    from fmpy import simulate_fmu

    path = str(native_dist / ("fmi3/" if fmi == 3 else "") / "Road.fmu")
    kw = dict(start_time=1.5, stop_time=3.0, output_interval=1e-3, start_values={"speed": 17.3})
    cs = simulate_fmu(path, fmi_type="CoSimulation", **kw)
    me = simulate_fmu(path, fmi_type="ModelExchange", **kw)
    np.testing.assert_array_equal(me["time"], cs["time"])
    for name in OUTS:
        assert np.max(np.abs(me[name] - cs[name])) <= 1e-12 * np.max(np.abs(cs[name])), name


def test_road_in_a_c_host_under_valgrind(native_dist, tmp_path):
    """tests/c_host/road_host.c, linked with the FMU's own sources/, walks Road.fmu (FMI 2.0)
    through the state machine, its FMU states and model exchange with every status as
    expected; under valgrind: no error, no leak."""
    import os
    import shutil
    import subprocess
    import zipfile

    from fmpy import read_model_description
    from helpers import ROOT, compile_c_host, fmpy_headers

    path = native_dist / "Road.fmu"
    with zipfile.ZipFile(path) as z:
        z.extractall(tmp_path / "fmu")
    src = tmp_path / "fmu" / "sources"
    exe = str(tmp_path / "road_host")
    files = [str(src / f) for f in sorted(os.listdir(src)) if f.endswith(".c")]
    host = os.path.join(ROOT, "tests", "c_host", "road_host.c")
    compile_c_host(
        [host, *files], exe, ("-g", "-O1", "-Wall"), [str(src), fmpy_headers()], ("-lm",)
    )
    md = read_model_description(str(path))
    vr = {v.name: str(v.valueReference) for v in md.modelVariables}
    argv = [exe, md.guid, vr["road_displacement"], vr["road_velocity"], vr["speed"]]
    plain = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert plain.returncode == 0, plain.stdout + plain.stderr
    assert "fmi2DoStep is not allowed in state Terminated" in plain.stdout
    valgrind = shutil.which("valgrind")
    if valgrind is None:
        pytest.skip("valgrind not found")
    run = subprocess.run(
        [
            valgrind,
            "--tool=memcheck",
            "--error-exitcode=9",
            "--leak-check=full",
            "--errors-for-leak-kinds=definite,indirect,possible",
            *argv,
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    assert "ERROR SUMMARY: 0 errors" in run.stderr, run.stderr[-3000:]


def test_road_is_the_library_interpolant_wherever_the_time_jumps(native_dist, table, tmp_path):
    """The periodic table's position is reduced from the whole periods of the last read (no
    fmod while a run moves on): at times that jump back and forth across periods, negative
    (fewer than zero periods), near whole periods and beyond 2^52 table rows (where the
    reduction falls back to fmod), set in model exchange one after the other, the outputs
    are the library's interpolant bit for bit (the same operations in the same order: a
    reduction off by a period or by one rounding shows here)."""
    from helpers import fmi2_model_exchange

    path = str(native_dist / "Road.fmu")
    md, fmu = fmi2_model_exchange(path, tmp_path / "fmu", "jumps")
    refs = {v.name: v.valueReference for v in md.modelVariables}
    vr = [refs[n] for n in OUTS]
    period = 601.0 / SPEED  # s: the table's length at the default speed
    rng = np.random.default_rng(28)
    times = [-1000.0, -period, -1e-9, 0.0, period, 2 * period, 1e-3, 3 * period - 1e-12]
    times += [4.4e12, 1e13, 1e17, 5.0, -7.3, 5.001, 1e6 * period]
    times += list(rng.uniform(-1e4, 1e4, 200)) + list(10.0 ** rng.uniform(-3, 16, 200))
    try:
        fmu.enterContinuousTimeMode()
        got = []
        for t in times:
            fmu.setTime(float(t))
            got.append(fmu.getReal(vr))
    finally:
        fmu.terminate()
        fmu.freeInstance()
    want = [_library(table, t) for t in times]
    assert got == want
