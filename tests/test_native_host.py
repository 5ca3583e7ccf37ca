"""A C program with no Python anywhere in its process runs the native FMUs.

tests/c_host/native_host.c is compiled here (gcc, and mingw-w64 for win64) and started with
an empty environment. It loads the FMU binary itself (dlopen / LoadLibrary), computes a seat
chirp in C, prints every input and output with %.17g, and reports whether a libpython is
mapped into its process (/proc/self/maps). The test compares its outputs with the library's
exact simulation computed from the printed inputs: 1e-12 of each output's peak for the
5-state HumanBody3DOF (measured: a few 1e-14); HumanBodyISO7962 to the tolerance of
tests/test_native_fmu.py (measured against scipy's exponential: the stiff model's step
matrices are defined to about 1e-10 only).
"""

import os
import shutil
import subprocess
import zipfile

import numpy as np
import pytest
from helpers import ROOT, compile_c_host, fmpy_headers, win64_host
from test_native_fmu import BODY_OUT, MODEL_OF, TIGHT, body_reference, relative_error, tolerance

from bodyvib.models import load_model

pytestmark = pytest.mark.integration

HOST = os.path.join(ROOT, "tests", "c_host", "native_host.c")
STEP, N_STEPS = 1e-3, 1500


@pytest.fixture(scope="module")
def host(tmp_path_factory):
    exe = str(tmp_path_factory.mktemp("native_host") / "native_host")
    return compile_c_host([HOST], exe, libs=("-ldl", "-lm", "-lpthread"))


@pytest.fixture(scope="module")
def unpacked(native_fmus, tmp_path_factory):
    """name -> (binary folder, guid, input vrs, output vrs, mass vr) of the FMI 2.0 FMUs."""
    from fmpy import read_model_description

    out = {}
    for name in MODEL_OF:
        folder = tmp_path_factory.mktemp(name)
        with zipfile.ZipFile(native_fmus[name]) as z:
            z.extractall(folder)
        md = read_model_description(native_fmus[name])
        vr = {v.name: v.valueReference for v in md.modelVariables}
        out[name] = (
            str(folder / "binaries"),
            md.guid,
            f"{vr['seat_displacement']},{vr['seat_velocity']}",
            ",".join(str(vr[n]) for n in BODY_OUT),
            str(
                vr["m1"]
                if "m1" in vr
                else vr[next(v.name for v in md.modelVariables if v.unit == "kg")]
            ),
        )
    return out


def run(
    host, unpacked, name, mode, platform="linux64", suffix=".so", prefix=(), env=None, steps=N_STEPS
):
    binaries, guid, ins, outs, mass = unpacked[name]
    argv = [
        *prefix,
        host,
        mode,
        os.path.join(binaries, platform, name + suffix),
        guid,
        ins,
        outs,
        repr(STEP),
        str(steps),
    ] + ([mass] if mode in ("checks", "fsm", "overflow") else [])
    return subprocess.run(
        argv, capture_output=True, text=True, timeout=600, env={} if env is None else env
    )


def table(stdout):
    rows = [l.split() for l in stdout.splitlines() if l[:1].isdigit()]
    return np.array(rows, dtype=float)


@pytest.mark.parametrize("mode", ["run", "vary"])
@pytest.mark.parametrize("name", list(MODEL_OF))
def test_c_host_without_python_matches_the_library(host, unpacked, name, mode):
    out = run(host, unpacked, name, mode)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0] == "libpython absent" and lines[-1] == "ok", lines[:2]
    data = table(out.stdout)
    assert data.shape == (N_STEPS + 1, 4 + len(BODY_OUT))
    t, x, v, y = data[:, 1], data[:, 2], data[:, 3], data[:, 4:]
    if mode == "vary":
        assert np.ptp(np.diff(t)) > 0.4 * STEP  # the steps did vary
    err = relative_error(y, body_reference(load_model(MODEL_OF[name]), t, x, v))
    assert np.all(err <= tolerance(name, t, x, v)), err


def test_c_host_sees_libpython_when_it_is_there(host, unpacked):
    """The host's libpython check can fail: with a libpython preloaded it reports it."""
    import sysconfig

    lib = os.path.join(
        sysconfig.get_config_var("LIBDIR") or "", sysconfig.get_config_var("LDLIBRARY") or ""
    )
    if not (sysconfig.get_config_var("Py_ENABLE_SHARED") and os.path.isfile(lib)):
        pytest.skip("this Python has no shared libpython to preload")
    out = run(host, unpacked, "HumanBody3DOF", "run", env={"LD_PRELOAD": lib}, steps=10)
    assert out.stdout.splitlines()[0] == "libpython present", out.stdout[:200] + out.stderr


@pytest.mark.parametrize("name", list(MODEL_OF))
def test_statuses_state_and_reset_in_a_c_host(host, unpacked, name):
    out = run(host, unpacked, name, "checks", steps=400)
    assert out.returncode == 0, out.stderr
    got = dict(l.split() for l in out.stdout.splitlines() if " " in l)
    assert got == {
        "nan_step": "3",
        "inf_step": "3",
        "negative_step": "3",
        "zero_step": "3",
        "refusals_leave_state": "1",
        "negative_mass_init": "3",
        "negative_mass_step": "3",
        "reset_equals_fresh": "1",
        "state_continue_equals_fresh": "1",
        "state_restore_equals_fresh": "1",
        "deserialized_equals_fresh": "1",
        "corrupt_state": "3",
        "short_state": "3",
        "foreign_state": "3",
    }, out.stdout
    assert "not finite" in out.stderr and "is invalid" in out.stderr


FSM = {  # the FMI 2.0 state machine: 3 = fmi2Error for every call out of order
    "getreal_instantiated": "3",
    "dostep_instantiated": "3",
    "exit_instantiated": "3",
    "terminate_instantiated": "3",
    "setreal_instantiated": "0",
    "setup_instantiated": "0",
    "enter": "0",
    "setup_initialization": "3",
    "enter_initialization": "3",
    "dostep_initialization": "3",
    "terminate_initialization": "3",
    "getreal_initialization": "0",
    "exit": "0",
    "exit_stepping": "3",
    "enter_stepping": "3",
    "set_parameter_stepping": "3",
    "dostep_wrong_time": "3",
    "dostep": "0",
    "unknown_vr_set": "3",
    "unknown_vr_nothing_set": "1",
    "terminate": "0",
    "dostep_terminated": "3",
    "setreal_terminated": "3",
    "terminate_terminated": "3",
    "getreal_terminated": "0",
    "parameter_unchanged": "1",
    "reset": "0",
    "getreal_after_reset": "3",
    "exit_invalid": "3",
    "dostep_failed": "3",
    "terminate_failed": "3",
    "getreal_failed": "0",
    "reset_failed": "0",
    "time_at_start": "1",
    "dostep_from_zero": "3",
    "start_time_run_equals": "1",
    "last_time_ok": "1",
}

OVERFLOW = {  # 2 = fmi2Discard: a step whose result is not finite; nothing changes
    "overflow_getreal": "3",
    "overflow_step": "2",
    "overflow_last_time": "1",
    "overflow_leaves_state": "1",
    "huge_step": "2",
    "huge_displacement": "2",
    "huge_displacement_back": "2",
    "huge_step_leaves_slope": "1",
    "huge_displacement_leaves_slope": "1",
    "crafted_state_0": "3",
    "crafted_state_1": "3",
    "crafted_state_2": "3",
    "denormal_init": "3",
    "reset_init": "0",
    "denormal_reset_recovers": "1",
    "denormal_getreal": "0",
    "mass_back_init": "0",
    "denormal_mass_back_recovers": "1",
}


@pytest.mark.parametrize("name", list(MODEL_OF))
def test_state_machine_refuses_calls_out_of_order_in_a_c_host(host, unpacked, name):
    """Each call the FMI 2.0 state table does not allow in the instance's state returns
    fmi2Error with the reason logged, and changes nothing; startTime is the model's time."""
    out = run(host, unpacked, name, "fsm", steps=300)
    assert out.returncode == 0, out.stderr
    got = dict(l.split() for l in out.stdout.splitlines() if " " in l)
    assert got == FSM, out.stdout
    assert "fmi2DoStep is not allowed in state Terminated" in out.stderr
    assert "fmi2GetReal is not allowed in state Instantiated" in out.stderr
    assert "but the model is at t = 2.5 s" in out.stderr


@pytest.mark.parametrize("name", list(MODEL_OF))
def test_overflow_huge_steps_crafted_states_and_denormal_mass_in_a_c_host(host, unpacked, name):
    """Finite inputs that overflow, a 1e300 s step or 1e300 m displacements with the
    velocity never set: fmi2Discard, and the run continues bit-identical to an undisturbed
    one (the slope bookkeeping included); a state with a valid checksum but inconsistent
    bookkeeping is refused; a denormal mass is refused without touching the model, so Reset
    (or setting the mass back) and initialization recover a run identical to a fresh one."""
    out = run(host, unpacked, name, "overflow", steps=300)
    assert out.returncode == 0, out.stderr
    got = dict(l.split() for l in out.stdout.splitlines() if " " in l)
    assert got == OVERFLOW, out.stdout
    assert "step refused (discard), state unchanged" in out.stderr


def test_two_instances_on_two_threads(host, unpacked):
    out = run(host, unpacked, "HumanBody3DOF", "threads", steps=2000)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines()[0] == "threads identical"


@pytest.mark.parametrize("mode", ["run", "checks", "threads", "fsm", "overflow"])
def test_c_host_under_valgrind_is_clean(host, unpacked, mode):
    valgrind = shutil.which("valgrind")
    if valgrind is None:
        pytest.skip("valgrind not found")
    out = run(
        host,
        unpacked,
        "HumanBodyISO7962",
        mode,
        steps=300,
        prefix=(
            valgrind,
            "--tool=memcheck",
            "--error-exitcode=9",
            "--leak-check=full",
            "--errors-for-leak-kinds=definite,indirect,possible",
            "--show-leak-kinds=definite,indirect,possible",
        ),
    )
    assert out.returncode == 0, out.stderr[-3000:]
    assert "ERROR SUMMARY: 0 errors" in out.stderr, out.stderr[-3000:]
    assert "definitely lost" not in out.stderr or "definitely lost: 0 bytes" in out.stderr


@pytest.mark.parametrize("fmu", ["HumanBody3DOF", "Road", "SkyhookController"])
def test_a_host_that_lies_about_n_is_refused_at_the_first_unknown_reference(
    host, unpacked, native_fmus, tmp_path, fmu
):
    """fmi2SetReal / fmi2GetReal with n = SIZE_MAX and one-element arrays holding an unknown
    reference: fmi2Error, and memcheck sees no read past the arrays (the scan for the time
    variable and the unknown references stops at the first unknown one) in the linear core,
    the table core and the controller."""
    from bodyvib.fmu.controller import build_controller_fmu

    valgrind = shutil.which("valgrind")
    if valgrind is None:
        pytest.skip("valgrind not found")
    if fmu == "HumanBody3DOF":
        binaries, guid = unpacked[fmu][:2]
    else:
        from fmpy import read_model_description

        path = (
            build_controller_fmu(tmp_path, ("",), platforms=("linux64",))
            if fmu == "SkyhookController"
            else native_fmus["HumanBody3DOF"].replace("HumanBody3DOF", fmu)
        )
        with zipfile.ZipFile(path) as z:
            z.extractall(tmp_path / "x")
        binaries, guid = str(tmp_path / "x" / "binaries"), read_model_description(path).guid
    argv = [valgrind, "--tool=memcheck", "--error-exitcode=9", host, "misuse"]
    argv += [os.path.join(binaries, "linux64", fmu + ".so"), guid, "0,1", "2", repr(STEP), "2"]
    out = subprocess.run(argv, capture_output=True, text=True, timeout=600, env={})
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.split() == ["setreal", "3", "getreal", "3", "ok"], out.stdout
    assert "ERROR SUMMARY: 0 errors" in out.stderr, out.stderr[-3000:]


def test_win64_binary_under_wine_matches_linux64(host, unpacked, tmp_path):
    exe = str(tmp_path / "native_host.exe")
    with win64_host(HOST, fmpy_headers(), exe, tmp_path) as (wine, env):
        for name in MODEL_OF:
            win = run(
                exe, unpacked, name, "run", platform="win64", suffix=".dll", prefix=(wine,), env=env
            )
            assert win.returncode == 0, win.stderr[-2000:]
            assert win.stdout.splitlines()[-1].strip() == "ok"
            linux = run(host, unpacked, name, "run")
            a, b = table(win.stdout), table(linux.stdout)
            assert a.shape == b.shape
            # the chirp comes from each platform's own sin/cos (1 ulp apart at most)
            assert np.max(np.abs(a[:, 2:4] - b[:, 2:4])) <= 1e-15
            err = relative_error(a[:, 4:], b[:, 4:])
            assert np.all(err <= np.maximum(TIGHT, tolerance(name, b[:, 1], b[:, 2], b[:, 3]))), err


def test_c_host_without_python_runs_the_full_car(host, native_fmus, tmp_path):
    """The native FullCar.fmu in the C host, its front left road pair driven by the host's
    chirp: the seat's vertical motion, sideways acceleration and the roll rate equal the
    library's exact simulation of the full car (its regimes stepped with located events) to
    1e-12 of each output's peak."""
    from fmpy import read_model_description

    from bodyvib.runtime.discretize import simulate
    from bodyvib.runtime.network import linear_model
    from bodyvib.vehicle.quarter_car import load_car

    with zipfile.ZipFile(native_fmus["FullCar"]) as z:
        z.extractall(tmp_path)
    md = read_model_description(native_fmus["FullCar"])
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outs = ["seat_displacement", "seat_acceleration_y", "roll_rate"]
    argv = [host, "run", str(tmp_path / "binaries" / "linux64" / "FullCar.so"), md.guid]
    argv += [f"{vr['road_displacement_front_left']},{vr['road_velocity_front_left']}"]
    argv += [",".join(str(vr[n]) for n in outs), repr(STEP), str(N_STEPS)]
    out = subprocess.run(argv, capture_output=True, text=True, timeout=600, env={})
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0] == "libpython absent" and lines[-1] == "ok", lines[:2]
    data = table(out.stdout)
    t, x, v, y = data[:, 1], data[:, 2], data[:, 3], data[:, 4:]
    car = load_car("full-car")  # its contacts and stops: the library's located events
    lm = linear_model(car)
    u = np.zeros((t.size, len(lm.inputs)))
    u[:, 0], u[:, 1] = x, v  # the front left road; the other corners level, no seat force
    _, ref = simulate(car, t, u)
    ref = ref[:, [lm.output_index(s) for s in ("seat.x", "seat.ay", "body.phi_rate")]]
    assert np.max(np.abs(ref[:, 2])) > 0  # one corner driven: the body rolls
    assert np.all(relative_error(y, ref) <= TIGHT), relative_error(y, ref)
