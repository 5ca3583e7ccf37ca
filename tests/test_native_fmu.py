"""The native (C) FMUs in fmpy: validity, contract, and the library's exact simulation.

The native FMUs are built once by ``build_fmu.py --native`` (conftest ``native_fmus``)
and driven through fmpy's FMU2Slave / FMU3Slave by a seat chirp. References:

* :func:`bodyvib.runtime.discretize.simulate` (the library's exact simulation), and the pythonfmu
  FMUs driven the same way;
* for seat_force_rate, the derivative row ``C_sf (A x + B u) + D_sf du`` evaluated on the
  library's states.

Tolerances. HumanBody3DOF and QuarterCar: 1e-12 of each output's peak (measured: a few
1e-14). HumanBodyISO7962 is stiff (poles -1.1e8 and a lightly damped pair at 1.4 kHz):
its step matrices are defined only to the rounding of the scaling-and-squaring
exponential, whose s = ceil(log2(||M h||_1 / 5.37)) squarings (21 at 1 ms) can each
double the relative rounding error, so they carry up to 2^s eps; the slowest mode
remembers each step's error over its time constant, 1 / (|Re lambda|_min h) steps (82).
The tolerance is twice that product, 2^s eps / (|Re lambda|_min h) (3.8e-8 at 1 ms,
:func:`rounding_bound`), from the model and the steps alone, not from another
implementation on this machine (measured: 1.3e-9 at fixed and up to 2.8e-8 at varying
steps; the library and scipy's expm disagree by up to 1e-9).
"""

import os
import re
import subprocess
import sys
import zipfile

import numpy as np
import pytest
import scipy.linalg
from helpers import ROOT

from bodyvib.models import load_model
from bodyvib.runtime.discretize import input_rates, simulate
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.network import linear_model
from bodyvib.vehicle.quarter_car import load_car

pytestmark = pytest.mark.integration

MODEL_OF = {"HumanBody3DOF": "reduced-paper", "HumanBodyISO7962": "iso7962"}
BODY_OUT = [
    "head_acceleration",
    "head_displacement",
    "torso_displacement",
    "seat_force",
    "seat_force_rate",
    "neck_force",
    "lumbar_force",
]
BODY_SIG = ["head.a", "head.x", "torso.x", "seat_force", "neck_force", "lumbar_force"]
CAR_OUT = [
    "seat_displacement",
    "seat_velocity",
    "sprung_acceleration",
    "suspension_deflection",
    "tire_force",
]
CAR_SIG = ["seat.x", "seat.v", "seat.a", "suspension.deflection", "tire.force"]
TIGHT = 1e-12
ISO_FACTOR = 2
N = 1500


def grid(vary, n=N, h=1e-3):
    """Communication times: uniform, or steps h (1 + 0.5 r) with r uniform in [0, 1)."""
    steps = h * (1 + 0.5 * np.random.default_rng(7).random(n)) if vary else np.full(n, h)
    return np.concatenate([[0.0], np.cumsum(steps)])


def chirp(t, amp=0.01, f0=0.5, f1=20.0):
    T = t[-1]
    phase = 2 * np.pi * (f0 * t + (f1 - f0) * t**2 / (2 * T))
    return amp * np.sin(phase), amp * 2 * np.pi * (f0 + (f1 - f0) * t / T) * np.cos(phase)


def _fmi2_callbacks(logger):
    """fmpy's FMI 2.0 callbacks with a Python logger (fmpy's C proxy formats the message)."""
    from ctypes import byref

    from fmpy import calloc, free
    from fmpy.fmi2 import (
        defaultCallbacks,
        fmi2CallbackAllocateMemoryTYPE,
        fmi2CallbackFreeMemoryTYPE,
        fmi2CallbackFunctions,
        fmi2CallbackLoggerTYPE,
    )
    from fmpy.logging import addLoggerProxy

    if logger is None:
        return defaultCallbacks
    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(logger)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    addLoggerProxy(byref(cb))
    _KEEP.append(cb)  # alive as long as the FMUs may call it
    return cb


_KEEP = []


class Fmu:
    """An FMU instantiated and initialized in fmpy (FMI 2.0 or 3.0), variables by name."""

    def __init__(self, path, start=None, logger=None):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave
        from fmpy.fmi3 import FMU3Slave

        self.md = read_model_description(path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.dir = extract(path)
        cls = FMU2Slave if self.md.fmiVersion == "2.0" else FMU3Slave
        self.fmu = cls(
            guid=self.md.guid,
            unzipDirectory=self.dir,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName="t",
        )
        if self.md.fmiVersion == "2.0":
            self.fmu.instantiate(loggingOn=True, callbacks=_fmi2_callbacks(logger))
            self.fmu.setupExperiment(startTime=0.0)
            self.get, self.set = self.fmu.getReal, self.fmu.setReal
        else:
            kw = (
                {}
                if logger is None
                else {
                    "logMessage": lambda env, status, category, message: logger(
                        None, None, status, category, message
                    )
                }
            )
            self.fmu.instantiate(loggingOn=True, **kw)
            self.get, self.set = self.fmu.getFloat64, self.fmu.setFloat64
        try:
            if start:
                self.set([self.vr[k] for k in start], list(start.values()))
            self.fmu.enterInitializationMode()
            self.fmu.exitInitializationMode()
        except Exception:  # a refused initialization: leave nothing behind, then report it
            import shutil

            self.fmu.freeInstance()
            shutil.rmtree(self.dir, ignore_errors=True)
            raise

    def close(self):
        import shutil

        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def drive(path, t, inputs, outputs, start=None):
    """Set the inputs at each t_k, read the outputs, step; (n, len(outputs)) array."""
    f = Fmu(path, start)
    ins = [f.vr[k] for k in inputs]
    outs = [f.vr[k] for k in outputs]
    rows = []
    try:
        for k in range(t.size):
            f.set(ins, [float(inputs[name][k]) for name in inputs])
            rows.append(f.get(outs))
            if k < t.size - 1:
                f.fmu.doStep(t[k], t[k + 1] - t[k])
    finally:
        f.close()
    return np.array(rows)


def body_reference(model, t, x, v, expm=None):
    """Library outputs (and seat_force_rate) for the seat chirp; expm: another exponential."""
    lm = linear_model(model) if not hasattr(model, "A") else model
    u = np.column_stack([x, v])
    if expm is None:
        X, y = simulate(lm, t, u)
    else:
        X = stepped(lm, t, u, expm)
        y = X @ lm.C.T + u @ lm.D.T
    sig = [lm.output_index(s) for s in BODY_SIG]
    du = input_rates(lm, u)
    rate = (X @ lm.A.T + u @ lm.B.T) @ lm.C[sig[3]] + du @ lm.D[sig[3]]
    return np.column_stack([y[:, sig[:4]], rate, y[:, sig[4:]]])  # in BODY_OUT's order


def stepped(lm, t, u, expm):
    """The exact stepping of bodyvib.runtime.discretize with another matrix exponential."""
    n, m = lm.B.shape
    du = input_rates(lm, u)
    X = np.zeros((t.size, n))
    cache = {}
    for k in range(t.size - 1):
        h = float(f"{t[k + 1] - t[k]:.12g}")
        if h not in cache:
            M = np.zeros((n + 2 * m, n + 2 * m))
            M[:n, :n], M[:n, n : n + m], M[n : n + m, n + m :] = lm.A, lm.B, np.eye(m)
            E = expm(M * h)
            cache[h] = E[:n, :n], E[:n, n : n + m], E[:n, n + m :]
        Phi, G0, G1 = cache[h]
        X[k + 1] = Phi @ X[k] + G0 @ u[k] + G1 @ du[k]
    return X


def relative_error(y, ref):
    return np.max(np.abs(y - ref), axis=0) / np.max(np.abs(ref), axis=0)


def rounding_bound(model, steps):
    """Relative rounding of exact stepping: 2^s eps over the slowest mode's memory.

    ``s`` squarings of the scaling-and-squaring exponential of the augmented matrix at
    the largest step, each able to double the relative error; errors made at each step
    persist for 1 / (|Re lambda|_min h) steps at the mean step.
    """
    lm = linear_model(model) if not hasattr(model, "A") else model
    n, m = lm.B.shape
    aug = np.zeros((n + 2 * m, n + 2 * m))
    aug[:n, :n], aug[:n, n : n + m], aug[n : n + m, n + m :] = lm.A, lm.B, np.eye(m)
    steps = np.asarray(steps, dtype=float)
    s = max(0, int(np.ceil(np.log2(np.linalg.norm(aug * steps.max(), 1) / 5.37))))
    memory = 1.0 / (np.min(np.abs(np.linalg.eigvals(lm.A).real)) * steps.mean())
    return 2.0**s * np.finfo(float).eps * memory


def tolerance(name, t, x=None, v=None):
    """1e-12, or for the stiff ISO model ISO_FACTOR x :func:`rounding_bound` (per output)."""
    if name != "HumanBodyISO7962":
        return np.full(len(BODY_OUT), TIGHT)
    bound = rounding_bound(load_model(MODEL_OF[name]), np.diff(t))
    return np.full(len(BODY_OUT), max(TIGHT, ISO_FACTOR * bound))


def test_fmpy_validate_is_clean_for_both_fmi_versions(native_fmus):
    from fmpy.validation import validate_fmu

    for key, path in native_fmus.items():
        assert validate_fmu(path) == [], key


def test_archives_hold_both_binaries_sources_and_model(native_fmus):
    for key, path in native_fmus.items():
        name = os.path.basename(path)[:-4]
        with zipfile.ZipFile(path) as z:
            files = set(z.namelist())
        fmi3 = key.startswith("fmi3/")
        plat = ("x86_64-linux", "x86_64-windows") if fmi3 else ("linux64", "win64")
        assert f"binaries/{plat[0]}/{name}.so" in files
        assert f"binaries/{plat[1]}/{name}.dll" in files
        assert {
            "sources/bodyvib_core.c",
            "sources/bodyvib_core.h",
            "sources/bodyvib_model.c",
            f"sources/fmi{3 if fmi3 else 2}Functions.c",
            "resources/bodyvib_model.json",
        } <= files
        assert ("sources/buildDescription.xml" in files) == fmi3


def test_binaries_need_only_libc_and_libm_export_only_fmi_and_have_no_mutable_globals(
    native_fmus, tmp_path
):
    with zipfile.ZipFile(native_fmus["HumanBody3DOF"]) as z:
        z.extractall(tmp_path)
    so = tmp_path / "binaries" / "linux64" / "HumanBody3DOF.so"
    dyn = subprocess.run(["readelf", "-d", str(so)], capture_output=True, text=True).stdout
    needed = sorted(l.split("[")[1].rstrip("]") for l in dyn.splitlines() if "(NEEDED)" in l)
    assert needed == ["libc.so.6", "libm.so.6"], needed
    syms = subprocess.run(
        ["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True
    ).stdout.split()
    exported = [s for s in syms if s.startswith(("fmi", "bv_", "_"))]
    assert exported and all(s.startswith("fmi2") for s in exported), exported
    # old glibc suffices (pow/exp/log would need 2.29; the core avoids them)
    versions = subprocess.run(["objdump", "-T", str(so)], capture_output=True, text=True).stdout
    newest = max(
        tuple(int(p) for p in v.split(".")) for v in re.findall(r"GLIBC_([0-9.]+)", versions)
    )
    assert newest <= (2, 17), newest
    # no mutable global state: the only writable objects are the C runtime's own
    table = subprocess.run(["objdump", "-t", str(so)], capture_output=True, text=True).stdout
    writable = {
        l.split()[-1]
        for l in table.splitlines()
        if any(f" {sec}\t" in l for sec in (".data", ".bss"))
    }
    assert writable <= {"completed.0", "__dso_handle", "__TMC_END__"}, writable
    dll = tmp_path / "binaries" / "win64" / "HumanBody3DOF.dll"
    dump = subprocess.run(
        ["x86_64-w64-mingw32-objdump", "-p", str(dll)], capture_output=True, text=True
    )
    if dump.returncode == 0:
        imports = {
            l.split(":")[1].strip().lower() for l in dump.stdout.splitlines() if "DLL Name:" in l
        }
        assert imports <= {"kernel32.dll", "msvcrt.dll"} | {
            i for i in imports if i.startswith("api-ms-win-crt")
        }, imports


def test_contract_is_the_pythonfmu_contract_plus_seat_force_rate(native_fmus, python_fmus):
    from fmpy import read_model_description
    from helpers import VARIABLE_ATTRIBUTES

    for name in ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar"):
        py = {v.name: v for v in read_model_description(python_fmus[name]).modelVariables}
        nat = {v.name: v for v in read_model_description(native_fmus[name]).modelVariables}
        nat3 = {
            v.name: v for v in read_model_description(native_fmus[f"fmi3/{name}"]).modelVariables
        }
        for vname, p in py.items():
            for other in (nat[vname], nat3[vname]):
                for attr in VARIABLE_ATTRIBUTES:
                    assert str(getattr(other, attr)) == str(getattr(p, attr)), (name, vname, attr)
        # plus, for model exchange, the continuous states and their derivatives (locals)
        me = {n for n in nat if n.startswith(("state.", "der(state."))}
        assert set(nat) - me == set(py)
        order = [n for n in sorted(nat, key=lambda n: nat[n].valueReference) if n in py]
        assert order == sorted(py, key=lambda n: py[n].valueReference)
        assert all(nat[n].causality == "local" for n in me) and me
        if name != "QuarterCar":
            rate = nat["seat_force_rate"]
            assert (rate.causality, rate.unit) == ("output", "N/s")
        # FMI 3.0 also has time, and the car its event indicators as variables
        events = {"event.tire.contact", "event.stops.compression", "event.stops.rebound"}
        assert set(nat3) - set(nat) == {"time"} | (events if name == "QuarterCar" else set())
        assert set(nat) - set(nat3) == set()


def test_seat_force_rate_depends_on_both_seat_inputs(native_fmus):
    from fmpy import read_model_description

    md = read_model_description(native_fmus["HumanBody3DOF"])
    deps = {
        u.variable.name: sorted(d.name for d in u.dependencies if d.causality == "input")
        for u in md.outputs
    }  # the states (model exchange) are dependencies too
    assert deps["seat_force_rate"] == ["seat_displacement", "seat_velocity"]
    assert deps["seat_force"] == ["seat_displacement"]
    assert deps["head_displacement"] == []


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
@pytest.mark.parametrize("vary", [False, True], ids=["fixed", "varying"])
@pytest.mark.parametrize("name", list(MODEL_OF))
def test_body_outputs_equal_the_library(native_fmus, name, vary, fmi):
    t = grid(vary)
    x, v = chirp(t)
    y = drive(native_fmus[fmi + name], t, {"seat_displacement": x, "seat_velocity": v}, BODY_OUT)
    err = relative_error(y, body_reference(load_model(MODEL_OF[name]), t, x, v))
    assert np.all(err <= tolerance(name, t, x, v)), err


def test_iso_tolerance_is_needed_and_sufficient(native_fmus):
    """The ISO FMU differs from the library by more than 1e-12 (so the derived tolerance is
    not slack for nothing) but within it; the library and scipy's exponential, two correct
    double implementations, disagree within it too (the bound describes double precision)."""
    t = grid(False)
    x, v = chirp(t)
    y = drive(
        native_fmus["HumanBodyISO7962"], t, {"seat_displacement": x, "seat_velocity": v}, BODY_OUT
    )
    model = load_model("iso7962")
    err = relative_error(y, body_reference(model, t, x, v))
    spread = relative_error(
        body_reference(model, t, x, v, scipy.linalg.expm), body_reference(model, t, x, v)
    )
    tol = tolerance("HumanBodyISO7962", t)
    assert np.max(err) > TIGHT and np.max(spread) > TIGHT
    assert np.all(err <= tol), (err, tol)
    assert np.all(spread <= tol), (spread, tol)


@pytest.mark.parametrize("vary", [False, True], ids=["fixed", "varying"])
def test_car_outputs_equal_the_library(native_fmus, vary):
    """The 20 mm chirp lifts the wheel off the road: the native car's located events against
    the library's (``simulate`` of the network, bodyvib.runtime.regimes), the same method
    in C and numpy, within 1e-12 of each output's peak (measured 3e-14)."""
    t = grid(vary)
    z, zv = chirp(t, amp=0.02)
    F = 300 * np.sin(2 * np.pi * 3 * t)
    Fr = 300 * 2 * np.pi * 3 * np.cos(2 * np.pi * 3 * t)
    y = drive(
        native_fmus["QuarterCar"],
        t,
        {"road_displacement": z, "road_velocity": zv, "seat_force": F, "seat_force_rate": Fr},
        CAR_OUT + ["tire_contact"],
    )
    assert np.min(y[:, -1]) == 0.0  # the wheel leaves the road
    lm = linear_model(load_car())
    u = np.column_stack([z, zv, -F])
    du = np.column_stack([zv, np.zeros_like(z), -Fr])
    _, ref = simulate(load_car(), t, u, du=du)
    ref = ref[:, [lm.output_index(s) for s in CAR_SIG]]
    err = relative_error(y[:, :-1], ref)
    assert np.all(err <= TIGHT), err


@pytest.mark.parametrize("name", list(MODEL_OF) + ["QuarterCar"])
def test_outputs_equal_the_pythonfmu_fmus(native_fmus, python_fmus, name):
    t = grid(True, n=600)
    if name == "QuarterCar":
        # 5 mm: the tire keeps the road (the events: tests/test_native_regimes.py)
        z, zv = chirp(t, amp=0.005)
        inputs = {
            "road_displacement": z,
            "road_velocity": zv,
            "seat_force": 200 * np.sin(9 * t),
            "seat_force_rate": 1800 * np.cos(9 * t),
        }
        outs, tol = CAR_OUT, TIGHT
    else:
        x, v = chirp(t)
        a = np.gradient(v, t)  # any acceleration: both FMUs curve the seat with it
        inputs = {"seat_displacement": x, "seat_velocity": v, "seat_acceleration": a}
        outs, tol = BODY_OUT, tolerance(name, t, x, v)
    ours = drive(native_fmus[name], t, inputs, outs)
    theirs = drive(python_fmus[name], t, inputs, outs)
    err = relative_error(ours, theirs)
    assert np.all(err <= tol), err


def test_parameters_are_tunable_before_initialization(native_fmus):
    t = grid(False, n=800)
    x, v = chirp(t)
    changed = {"m1": 6.0, "k2": 7.5e4, "c2": 2500.0}
    y = drive(
        native_fmus["HumanBody3DOF"],
        t,
        {"seat_displacement": x, "seat_velocity": v},
        BODY_OUT,
        start=changed,
    )
    model = load_model("reduced-paper").with_parameters(**changed)
    err = relative_error(y, body_reference(model, t, x, v))
    assert np.all(err <= TIGHT), err
    default = body_reference(load_model("reduced-paper"), t, x, v)
    assert np.max(relative_error(y, default)) > 1e-3  # the parameters did change the model


def fallback_run(path, t, x, disp, outs, logger=None):
    """Set only the displacement input; outputs and the velocity input as read back."""
    f = Fmu(path, logger=logger or (lambda *a: None))
    vel = disp.replace("displacement", "velocity")
    vrs = [f.vr[k] for k in outs] + [f.vr[vel]]
    rows = []
    for k in range(t.size):
        f.set([f.vr[disp]], [float(x[k])])
        rows.append(f.get(vrs))
        if k < t.size - 1:
            f.fmu.doStep(t[k], t[k + 1] - t[k])
    f.close()
    return np.array(rows)


def slopes(t, x):
    """The fallback's slopes: used in the step from t_k (k >= 1), and in force when the
    outputs at t_k are read (the slope of the previous step, from k >= 2)."""
    step = np.zeros_like(x)
    step[1:] = np.diff(x) / np.diff(t)
    read = np.zeros_like(x)
    read[2:] = step[1:-1]
    return step, read


@pytest.mark.parametrize("name", ["HumanBody3DOF", "QuarterCar"])
def test_unconnected_velocity_falls_back_to_the_slope_like_the_pythonfmu_fmu(
    native_fmus, python_fmus, name
):
    """The velocity input never set: from the first doStep that sees the displacement move,
    the velocity is the slope (x_k - x_{k-1}) / h_{k-1} (it reads back as 0); one warning
    names the input. Checked against the library with those inputs and against the
    pythonfmu FMU."""
    messages = []

    def logger(component, instance, status, category, message):
        messages.append((status, message.decode()))

    t = grid(True, n=600)
    body = name != "QuarterCar"
    # the car's tire keeps the road at 5 mm (the events: tests/test_native_regimes.py)
    x, _ = chirp(t, amp=0.01 if body else 0.005)
    disp = "seat_displacement" if body else "road_displacement"
    outs = BODY_OUT if body else CAR_OUT
    ours = fallback_run(native_fmus[name], t, x, disp, outs, logger)
    warnings = [m for s_, m in messages if s_ == 1]
    vel = disp.replace("displacement", "velocity")
    assert len(warnings) == 1 and vel in warnings[0], messages
    assert np.all(ours[:, -1] == 0.0)  # the velocity input reads back as set
    theirs = fallback_run(python_fmus[name], t, x, disp, outs)
    assert np.all(relative_error(ours[:, :-1], theirs[:, :-1]) <= TIGHT)
    lm = linear_model(load_model("reduced-paper") if body else load_car())
    step, read = slopes(t, x)
    zero = np.zeros_like(x)
    extra = [] if body else [zero]
    X, _ = simulate(
        lm, t, np.column_stack([x, step] + extra), du=np.column_stack([step, zero] + extra)
    )
    u_read = np.column_stack([x, read] + extra)
    du_read = np.column_stack([read, zero] + extra)
    y = X @ lm.C.T + u_read @ lm.D.T
    if body:
        sig = [lm.output_index(s_) for s_ in BODY_SIG]
        rate = (X @ lm.A.T + u_read @ lm.B.T) @ lm.C[sig[3]] + du_read @ lm.D[sig[3]]
        ref = np.column_stack([y[:, sig[:4]], rate, y[:, sig[4:]]])  # in BODY_OUT's order
    else:
        ref = y[:, [lm.output_index(s_) for s_ in CAR_SIG]]
    err = relative_error(ours[:, :-1], ref)
    assert np.all(err <= TIGHT), err


def test_connected_velocity_gives_no_warning(native_fmus):
    messages = []

    def logger(component, instance, status, category, message):
        messages.append(message.decode())

    t = grid(False, n=50)
    x, v = chirp(t)
    f = Fmu(native_fmus["HumanBody3DOF"], logger=logger)
    for k in range(t.size - 1):
        f.set([f.vr["seat_displacement"], f.vr["seat_velocity"]], [float(x[k]), float(v[k])])
        f.fmu.doStep(t[k], t[k + 1] - t[k])
    f.close()
    assert messages == []


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_nan_input_negative_step_and_negative_mass_are_errors(native_fmus, fmi):
    from fmpy.fmi1 import FMICallException

    messages = []

    def logger(*args):
        messages.append(args[-1].decode())

    f = Fmu(native_fmus[fmi + "HumanBody3DOF"], logger=logger)
    f.set([f.vr["seat_displacement"]], [float("nan")])
    with pytest.raises(FMICallException) as exc:
        f.fmu.doStep(0.0, 1e-3)
    assert exc.value.status == 3  # fmi2Error / fmi3Error
    assert any("seat_displacement" in m and "not finite" in m for m in messages)
    f.set([f.vr["seat_displacement"]], [0.0])
    with pytest.raises(FMICallException) as exc:
        f.fmu.doStep(0.0, -1e-3)
    assert exc.value.status == 3
    f.fmu.doStep(0.0, 1e-3)  # the instance stays usable
    f.close()
    with pytest.raises(FMICallException) as exc:
        Fmu(native_fmus[fmi + "HumanBody3DOF"], start={"m1": -4.88}, logger=logger)
    assert exc.value.status == 3
    assert any("m1 = -4.88" in m for m in messages), messages


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_fmu_state_round_trip_and_reset_in_fmpy(native_fmus, fmi):
    """Get/set and (de)serialize the state half-way: the rest of the run is bit-identical;
    a corrupted byte or another model's state is refused; reset gives a fresh run."""
    from fmpy.fmi1 import FMICallException

    t = grid(True, n=400)
    x, v = chirp(t)
    f = Fmu(native_fmus[fmi + "HumanBody3DOF"], logger=lambda *a: None)
    ins, outs = [f.vr["seat_displacement"], f.vr["seat_velocity"]], [f.vr[k] for k in BODY_OUT]
    fmu = f.fmu
    two = f.md.fmiVersion == "2.0"
    get_state = fmu.getFMUstate if two else fmu.getFMUState
    set_state = fmu.setFMUstate if two else fmu.setFMUState
    serialize = fmu.serializeFMUstate if two else fmu.serializeFMUState
    deserialize = fmu.deSerializeFMUstate if two else fmu.deserializeFMUState

    def run(k0, k1):
        rows = []
        for k in range(k0, k1):
            f.set(ins, [float(x[k]), float(v[k])])
            rows.append(f.get(outs))
            fmu.doStep(t[k], t[k + 1] - t[k])
        return np.array(rows)

    first = run(0, 200)
    state = get_state()
    blob = serialize(state)
    rest = run(200, 400)
    set_state(state)
    assert np.array_equal(run(200, 400), rest)
    set_state(deserialize(blob))
    assert np.array_equal(run(200, 400), rest)
    bad = bytearray(blob)
    bad[len(bad) // 2] ^= 1
    with pytest.raises(FMICallException):
        deserialize(bytes(bad))
    other = Fmu(native_fmus[fmi + "HumanBodyISO7962"], logger=lambda *a: None)
    foreign = (other.fmu.serializeFMUstate if two else other.fmu.serializeFMUState)(
        (other.fmu.getFMUstate if two else other.fmu.getFMUState)()
    )
    other.close()
    with pytest.raises(FMICallException):
        deserialize(foreign)
    fmu.reset()
    if two:
        fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    again = run(0, 200)
    assert np.array_equal(again, first)
    f.close()


def test_fmpy_simulates_the_fmi3_versions(native_fmus):
    from fmpy import simulate_fmu

    t = grid(False, n=1000)
    x, v = chirp(t)
    signals = np.array(
        list(zip(t, x, v)),
        dtype=[("time", float), ("seat_displacement", float), ("seat_velocity", float)],
    )
    for name in MODEL_OF:
        res = simulate_fmu(
            native_fmus[f"fmi3/{name}"],
            start_time=0.0,
            stop_time=float(t[-1]),
            step_size=1e-3,
            output_interval=1e-3,
            input=signals,
            output=BODY_OUT[:4],
        )
        assert res["time"].size == t.size
        ref = body_reference(load_model(MODEL_OF[name]), t, x, v)[:, :4]
        y = np.column_stack([res[o] for o in BODY_OUT[:4]])
        # fmpy records the outputs after the step, before it sets the next input: compare the
        # states (head and torso displacement), which do not depend on the current input
        err = relative_error(y[:, 1:3], ref[:, 1:3])
        assert np.all(err <= tolerance(name, t, x, v)[1:3]), (name, err)
    car = simulate_fmu(native_fmus["fmi3/QuarterCar"], stop_time=1.0, step_size=1e-3)
    assert np.all(np.isfinite(car["tire_force"]))


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_fmpy_compile_builds_the_sources(native_fmus, fmi, tmp_path):
    from helpers import fmpy_compile_sources

    path = tmp_path / "HumanBody3DOF.fmu"
    folder = "x86_64-linux" if fmi else "linux64"
    fmpy_compile_sources(native_fmus[fmi + "HumanBody3DOF"], path, tmp_path)
    with zipfile.ZipFile(path) as z:
        assert f"binaries/{folder}/HumanBody3DOF.so" in z.namelist()
    t = grid(False, n=400)
    x, v = chirp(t)
    y = drive(str(path), t, {"seat_displacement": x, "seat_velocity": v}, BODY_OUT)
    err = relative_error(y, body_reference(load_model("reduced-paper"), t, x, v))
    assert np.all(err <= TIGHT), err


def test_params_file_is_baked_in(tmp_path):
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "bodyvib.cli",
            "build",
            "--native",
            "--params",
            os.path.join(ROOT, "params", "refit-iso7962.json"),
            "--fmus",
            "HumanBody3DOF",
            "--dest",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    from fmpy import read_model_description

    refit = load_model(os.path.join(ROOT, "params", "refit-iso7962.json"))
    for sub in ("native", "native/fmi3"):
        md = read_model_description(str(tmp_path / sub / "HumanBody3DOF.fmu"))
        starts = {v.name: float(v.start) for v in md.modelVariables if v.causality == "parameter"}
        assert starts == {k: float(v) for k, v in refit.parameters.items()}


def test_a_failed_build_leaves_the_good_fmu(tmp_path, monkeypatch):
    from bodyvib.fmu import native as native_build

    model = load_model("reduced-paper")
    good = native_build.build_native_fmu(
        model, "body", "HumanBody3DOF", "reduced body", tmp_path, platforms=["linux64"]
    )
    before = good.read_bytes()
    with pytest.raises(BodyvibError, match="m1"):
        native_build.build_native_fmu(
            model.with_parameters(m1=-4.88),
            "body",
            "HumanBody3DOF",
            "reduced body",
            tmp_path,
            platforms=["linux64"],
        )
    assert good.read_bytes() == before
    compiler, flags, *rest = native_build.PLATFORMS["linux64"]
    monkeypatch.setitem(
        native_build.PLATFORMS,
        "linux64",
        (compiler, flags + ["-include", "bodyvib_no_such_header.h"], *rest),
    )
    with pytest.raises(BodyvibError, match="failed"):
        native_build.build_native_fmu(
            model, "body", "HumanBody3DOF", "reduced body", tmp_path, platforms=["linux64"]
        )
    assert good.read_bytes() == before
