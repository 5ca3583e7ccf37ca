"""Model Exchange of the native FMUs (FMI 2.0 and 3.0): fmpy's CVode against the exact solution,
exact directional derivatives against finite differences and the library's matrices.

In model exchange the FMU gives ``x' = A x + B U s`` and ``y = C x + D U s`` for the inputs
``s`` the host holds at the current time (the velocity inputs are the host's values). fmpy
applies the inputs only between its output points and its CVode integrates past them in
``CV_NORMAL`` mode, so a smoothly varying input is held by an unknown amount; the test input
is therefore a staircase (a sine sampled every ``HOLD`` output intervals, each stair a
repeated time stamp, which fmpy treats as an input event and restarts CVode at). The exact
solution of a staircase is the library's zero-order-hold discretization
(:func:`bodyvib.runtime.discretize.discretize`, ``x <- Phi x + Gamma0 u``).

Tolerances. fmpy gives CVode ``atol = rtol * nominal`` with the FMU's nominals 1. The states'
errors must fall with the tolerance (a factor of 10 per factor of 100 in ``rtol`` at least;
measured about 70) and, at ``rtol = 1e-10``, stay below 1e-5 of each state's peak (measured:
3e-9 on HumanBody3DOF, 1.2e-6 on the ISO body's m1 and m2 velocities, whose stiff coupling
(the pole at -1.1e8 1/s) CVode's error test sees only through ``atol``). Outputs are rows of
``C`` on the states: an output's error is bounded by ``|C_r| . e_x`` (``e_x`` the states'
errors), which matters for the ISO body's head acceleration, 4.4e7 1/s^2 times the difference
of two stiffly coupled states (measured relative error 3e-4 at ``rtol = 1e-10``, while its
displacement is 4e-9).

A C model-exchange host (``tests/c_host/me_host.c``, RK4 with the inputs at every stage) is
checked against the analytic sine response, on linux64 and, under wine, win64.
"""

import os
import shutil
import subprocess
import zipfile
from ctypes import POINTER, c_double, c_int, c_void_p
from xml.etree import ElementTree as ET

import numpy as np
import pytest
import scipy.linalg
from helpers import ROOT, compile_c_host, fmi2_initialized, fmpy_headers, win64_host
from test_native_fmu import _fmi2_callbacks

from bodyvib.models import load_model
from bodyvib.runtime.contract import KINDS
from bodyvib.runtime.discretize import discretize
from bodyvib.runtime.network import linear_model
from bodyvib.vehicle.quarter_car import load_car

pytestmark = pytest.mark.integration

#: FMU -> (model loader, kind, driven displacement input, its velocity input, outputs checked)
FMUS = {
    "HumanBody3DOF": (
        lambda: load_model("reduced-paper"),
        "body",
        "seat_displacement",
        "seat_velocity",
        {"head_displacement": "head.x", "seat_force": "seat_force", "head_acceleration": "head.a"},
    ),
    "HumanBodyISO7962": (
        lambda: load_model("iso7962"),
        "body",
        "seat_displacement",
        "seat_velocity",
        {"head_displacement": "head.x", "seat_force": "seat_force", "head_acceleration": "head.a"},
    ),
    "QuarterCar": (
        load_car,
        "car",
        "road_displacement",
        "road_velocity",
        {
            "seat_displacement": "seat.x",
            "tire_force": "tire.force",
            "suspension_deflection": "suspension.deflection",
        },
    ),
    "HalfCar": (
        lambda: load_car("half-car"),
        "car",
        "road_displacement_front",
        "road_velocity_front",
        {
            "seat_displacement": "seat.x",
            "pitch": "body.theta",
            "tire_force_rear": "tire_rear.force",
        },
    ),
    "FullCar": (
        lambda: load_car("full-car"),
        "car",
        "road_displacement_front_left",
        "road_velocity_front_left",
        {
            "seat_displacement": "seat.x",
            "roll_rate": "body.phi_rate",
            "seat_acceleration_y": "seat.ay",
        },
    ),
}
CASES = [(name, fmi) for name in FMUS for fmi in (2, 3)]
T_END, DT, HOLD, F_HZ, AMP = 0.5, 1e-3, 5, 3.0, 0.01


def _path(native_fmus, name, fmi):
    return native_fmus[name if fmi == 2 else f"fmi3/{name}"]


def _staircase(din, vin):
    """Sine displacement and its velocity, held over HOLD output intervals (input events)."""
    t = np.arange(0.0, T_END + DT / 2, DT)
    tk = t[::HOLD]
    w = 2 * np.pi * F_HZ
    d, v = AMP * np.sin(w * tk), AMP * w * np.cos(w * tk)
    sig = np.zeros(2 * len(tk) - 1, dtype=[("time", float), (din, float), (vin, float)])
    sig["time"][0::2], sig["time"][1::2] = tk, tk[1:]
    sig[din][0::2], sig[din][1::2] = d, d[:-1]
    sig[vin][0::2], sig[vin][1::2] = v, v[:-1]
    held = np.repeat(np.stack([d, v], 1), HOLD, axis=0)[: len(t)]
    return t, sig, held


def _exact(network, kind, held, n_inputs):
    """States and model inputs of the exact zero-order-hold solution at the output points."""
    lm = linear_model(network)
    U = KINDS[kind](network).input_map
    s = np.zeros((len(held), n_inputs))
    s[:, :2] = held  # displacement and velocity are the first two FMU inputs of either kind
    u = s @ U.T
    Phi, G0, _ = discretize(lm.A, lm.B, DT)
    X = np.zeros((len(held), lm.A.shape[0]))
    for k in range(len(held) - 1):
        X[k + 1] = Phi @ X[k] + G0 @ u[k]
    return lm, X, u


def _simulate(path, sig, names, rtol):
    from fmpy import simulate_fmu

    return simulate_fmu(
        path,
        fmi_type="ModelExchange",
        solver="CVode",
        relative_tolerance=rtol,
        stop_time=T_END,
        output_interval=DT,
        input=sig,
        record_events=False,
        output=names,
    )


@pytest.mark.parametrize("name,fmi", CASES)
def test_model_exchange_cvode_converges_to_the_exact_solution(native_fmus, name, fmi):
    load, kind, din, vin, outputs = FMUS[name]
    network = load()
    t, sig, held = _staircase(din, vin)
    n_inputs = len(KINDS[kind](network).inputs)
    lm, X, u = _exact(network, kind, held, n_inputs)
    states = [f"state.{s}" for s in lm.states]
    errors = {}
    for rtol in (1e-8, 1e-10):
        res = _simulate(_path(native_fmus, name, fmi), sig, states + list(outputs), rtol)
        assert len(res) == len(t)
        got = np.stack([res[s] for s in states], 1)
        errors[rtol] = np.max(np.abs(got - X), axis=0)
    peak = np.max(np.abs(X), axis=0)
    e = errors[1e-10]
    assert np.all(e <= 1e-5 * peak), (name, fmi, e / peak)
    # convergence: the tighter tolerance is at least 10 times closer (all states together)
    assert np.max(e / peak) * 10 <= np.max(errors[1e-8] / peak), (errors, peak)
    for out, signal in outputs.items():
        r = lm.output_index(signal)
        ref = X @ lm.C[r] + u @ lm.D[r]
        bound = np.abs(lm.C[r]) @ e + 1e-12 * np.max(np.abs(ref))
        assert np.max(np.abs(res[out] - ref)) <= bound, (out, np.max(np.abs(res[out] - ref)), bound)


def _me_model(md, folder, fmi):
    """The extracted native FMU as fmpy's model-exchange instance, not yet instantiated."""
    from fmpy.fmi2 import FMU2Model
    from fmpy.fmi3 import FMU3Model

    return (FMU2Model if fmi == 2 else FMU3Model)(
        guid=md.guid if fmi == 2 else md.instantiationToken,
        unzipDirectory=folder,
        instanceName="me",
        modelIdentifier=md.modelExchange.modelIdentifier,
    )


class _MeInstance:
    """A native FMU instantiated for model exchange in fmpy, in continuous-time mode."""

    def __init__(self, path, logger=None):
        from fmpy import extract, read_model_description

        self.md = read_model_description(path)
        self.dir = extract(path)
        self.fmi = 2 if self.md.fmiVersion == "2.0" else 3
        self.fmu = _me_model(self.md, self.dir, self.fmi)
        if self.fmi == 2:
            self.fmu.instantiate(loggingOn=True, callbacks=_fmi2_callbacks(logger))
            self.fmu.setupExperiment(startTime=0.0)
        else:
            self.fmu.instantiate(
                loggingOn=True,
                logMessage=None
                if logger is None
                else (
                    lambda env, status, category, message: logger(
                        None, None, status, category, message
                    )
                ),
            )
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        if self.fmi == 2:
            self.fmu.newDiscreteStates()
        else:
            self.fmu.updateDiscreteStates()
        self.fmu.enterContinuousTimeMode()
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.n = self.md.numberOfContinuousStates
        self.states = [v for v in self.md.modelVariables if v.name.startswith("state.")]
        self.ders = [v for v in self.md.modelVariables if v.name.startswith("der(state.")]
        self.inputs = [v for v in self.md.modelVariables if v.causality == "input"]
        self.outputs = [v for v in self.md.modelVariables if v.causality == "output"]

    def set_states(self, x):
        x = np.ascontiguousarray(x, dtype=float)
        self.fmu.setContinuousStates(x.ctypes.data_as(POINTER(c_double)), self.n)

    def derivatives(self):
        dx = np.zeros(self.n)
        p = dx.ctypes.data_as(POINTER(c_double))
        if self.fmi == 2:
            self.fmu.fmi2GetDerivatives(self.fmu.component, p, self.n)
        else:
            self.fmu.fmi3GetContinuousStateDerivatives(self.fmu.component, p, self.n)
        return dx

    def set_inputs(self, values):
        vrs = [v.valueReference for v in self.inputs]
        if self.fmi == 2:
            self.fmu.setReal(vrs, list(values))
        else:
            self.fmu.setFloat64(vrs, list(values))

    def outputs_now(self):
        vrs = [v.valueReference for v in self.outputs]
        get = self.fmu.getReal if self.fmi == 2 else self.fmu.getFloat64
        return np.array(get(vrs))

    def f(self, x, s):
        """Derivatives and outputs at states x and inputs s."""
        self.set_states(x)
        self.set_inputs(s)
        return np.concatenate([self.derivatives(), self.outputs_now()])

    def jacobian(self):
        """Directional derivatives: unknowns (derivatives, outputs) x knowns (states, inputs)."""
        unknowns = [v.valueReference for v in self.ders + self.outputs]
        knowns = [v.valueReference for v in self.states + self.inputs]
        J = np.zeros((len(unknowns), len(knowns)))
        for j in range(len(knowns)):
            seed = [0.0] * len(knowns)
            seed[j] = 1.0
            J[:, j] = self.fmu.getDirectionalDerivative(unknowns, knowns, seed)
        return J

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


@pytest.mark.parametrize("name,fmi", CASES)
def test_directional_derivatives_are_exact(native_fmus, name, fmi):
    """The Jacobian equals central differences of the ME functions, and the library's A, B U.

    The model is linear, so central differences have no truncation error; their rounding
    error is about eps |f| / delta, with |f| <= |J| (|x| + delta): below 1e-10 of each row's
    largest entry for delta = 1e-3 and |x|, |s| <= 1e-2."""
    load, kind, _, _, _ = FMUS[name]
    network = load()
    inst = _MeInstance(_path(native_fmus, name, fmi))
    try:
        rng = np.random.default_rng(3)
        n, ni = inst.n, len(inst.inputs)
        x0, s0 = rng.uniform(-1e-2, 1e-2, n), rng.uniform(-1e-2, 1e-2, ni)
        J = inst.jacobian()
        delta = 1e-3
        fd = np.zeros_like(J)
        for j in range(n + ni):
            e = np.zeros(n + ni)
            e[j] = delta
            plus = inst.f(x0 + e[:n], s0 + e[n:])
            minus = inst.f(x0 - e[:n], s0 - e[n:])
            fd[:, j] = (plus - minus) / (2 * delta)
        scale = np.max(np.abs(J), axis=1, keepdims=True) + 1e-300
        assert np.all(np.abs(fd - J) <= 1e-10 * scale), np.max(np.abs(fd - J) / scale)
        # the library's explicit state space (numpy's solve of the descriptor form)
        lm = linear_model(network)
        BU = lm.B @ KINDS[kind](network).input_map
        assert [v.name for v in inst.states] == [f"state.{s}" for s in lm.states]
        ref = np.hstack([lm.A, BU])
        rows = np.max(np.abs(ref), axis=1, keepdims=True)
        assert np.all(np.abs(J[:n] - ref) <= 1e-12 * rows), np.max(np.abs(J[:n] - ref) / rows)
        # a known that is not a state or an input is refused
        with pytest.raises(Exception):
            inst.fmu.getDirectionalDerivative(
                [inst.ders[0].valueReference], [inst.outputs[0].valueReference], [1.0]
            )
    finally:
        inst.close()


@pytest.mark.parametrize("fmi", (2, 3))
def test_model_description_offers_both_interfaces(native_fmus, fmi):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    for name in FMUS:
        path = _path(native_fmus, name, fmi)
        assert validate_fmu(path) == []
        md = read_model_description(path)
        assert md.modelExchange.modelIdentifier == md.coSimulation.modelIdentifier == name
        with zipfile.ZipFile(path) as z:
            root = ET.fromstring(z.read("modelDescription.xml"))
        flag = "providesDirectionalDerivative" + ("s" if fmi == 3 else "")
        for interface in ("ModelExchange", "CoSimulation"):
            assert root.find(interface).get(flag) == "true"
        assert md.numberOfContinuousStates == linear_model(FMUS[name][0]()).A.shape[0]
        assert len(md.derivatives) == md.numberOfContinuousStates
        for der in md.derivatives:
            assert der.variable.derivative.name == der.variable.name[4:-1]


def test_interface_functions_refuse_the_other_interface(native_fmus):
    """An ME call on a co-simulation instance and DoStep on an ME instance return Error."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import fmi2Error

    path = _path(native_fmus, "HumanBody3DOF", 2)
    md = read_model_description(path)
    inst = _MeInstance(path)
    try:
        do_step = inst.fmu.dll.fmi2DoStep
        do_step.argtypes, do_step.restype = [c_void_p, c_double, c_double, c_int], c_int
        assert do_step(inst.fmu.component, 0.0, 1e-3, 1) == fmi2Error
    finally:
        inst.close()
    folder = extract(path)
    try:
        cs = fmi2_initialized(md, folder, "cs", slave=True)
        set_time = cs.dll.fmi2SetTime
        set_time.argtypes, set_time.restype = [c_void_p, c_double], c_int
        assert set_time(cs.component, 0.5) == fmi2Error
        cs.doStep(0.0, 1e-3)
        # the states are readable variables in co-simulation too
        x = cs.getReal([v.valueReference for v in md.modelVariables if v.name.startswith("state.")])
        assert len(x) == md.numberOfContinuousStates
        cs.terminate()
        cs.freeInstance()
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@pytest.mark.parametrize("fmi", (2, 3))
def test_model_exchange_calls_out_of_order_are_errors(native_fmus, fmi):
    """Model-exchange calls are checked against the instance's state, as the co-simulation
    ones: before ExitInitializationMode and after Terminate they return Error, logged."""
    from fmpy import extract, read_model_description

    path = _path(native_fmus, "HumanBody3DOF", fmi)
    md = read_model_description(path)
    folder = extract(path)
    said = []
    logger = lambda *a: said.append(a[-1])  # noqa: E731
    try:
        fmu = _me_model(md, folder, fmi)
        if fmi == 2:
            fmu.instantiate(loggingOn=True, callbacks=_fmi2_callbacks(logger))
            fmu.setupExperiment(startTime=0.0)
            names = ("fmi2EnterContinuousTimeMode", "fmi2CompletedIntegratorStep")
        else:
            fmu.instantiate(
                loggingOn=True, logMessage=lambda env, status, cat, msg: said.append(msg)
            )
            names = ("fmi3EnterContinuousTimeMode",)
        error = 3
        enter = getattr(fmu.dll, names[0])
        enter.argtypes, enter.restype = [c_void_p], c_int
        set_time = getattr(fmu.dll, f"fmi{fmi}SetTime")
        set_time.argtypes, set_time.restype = [c_void_p, c_double], c_int
        assert enter(fmu.component) == error  # Instantiated: not yet
        assert any(b"not allowed" in (m if isinstance(m, bytes) else m.encode()) for m in said)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        assert set_time(fmu.component, 0.001) == 0 and enter(fmu.component) == 0
        fmu.terminate()
        assert set_time(fmu.component, 0.002) == error  # Terminated
        fmu.freeInstance()
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@pytest.mark.parametrize("fmi", (2, 3))
def test_event_and_continuous_time_modes_refuse_each_others_calls(native_fmus, fmi):
    """After ExitInitializationMode a model-exchange instance is in Event Mode; the calls of
    Continuous-Time Mode (SetContinuousStates, CompletedIntegratorStep) are refused there,
    and in Continuous-Time Mode those of Event Mode (NewDiscreteStates / UpdateDiscreteStates,
    EnterContinuousTimeMode; FMI 3.0: EnterEventMode only from Continuous-Time Mode), each
    with Error, the reason logged and the states unchanged (the standard's state tables, as
    the Reference FMUs' masks have them); SetTime and the derivatives are allowed in both."""
    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException

    path = _path(native_fmus, "HumanBody3DOF", fmi)
    md = read_model_description(path)
    folder = extract(path)
    said = []
    n = md.numberOfContinuousStates

    def status(call, *args):
        try:
            call(*args)
        except FMICallException as exc:
            return exc.status
        return 0

    try:
        fmu = _me_model(md, folder, fmi)
        if fmi == 2:
            fmu.instantiate(callbacks=_fmi2_callbacks(lambda *a: said.append(a[-1].decode())))
            fmu.setupExperiment(startTime=0.0)
            discrete, derivatives = fmu.newDiscreteStates, fmu.getDerivatives
        else:
            fmu.instantiate(logMessage=lambda env, st, cat, msg: said.append(msg.decode()))
            discrete, derivatives = fmu.updateDiscreteStates, fmu.getContinuousStateDerivatives
        x = (c_double * n)(*[1e-3 * (i + 1) for i in range(n)])
        before, after, dx = (c_double * n)(), (c_double * n)(), (c_double * n)()
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.getContinuousStates(before, n)
        seen = {  # Event Mode
            "set_states": status(fmu.setContinuousStates, x, n),
            "completed": status(fmu.completedIntegratorStep),
            "enter_event": status(fmu.enterEventMode),
            "set_time": status(fmu.setTime, 1e-3),
            "derivatives": status(derivatives, dx, n),
            "discrete": status(discrete),
        }
        fmu.getContinuousStates(after, n)
        assert list(after) == list(before)  # the refusals changed nothing
        seen["enter_continuous"] = status(fmu.enterContinuousTimeMode)
        seen.update(
            {  # Continuous-Time Mode
                "ct_discrete": status(discrete),
                "ct_enter_continuous": status(fmu.enterContinuousTimeMode),
                "ct_set_states": status(fmu.setContinuousStates, x, n),
                "ct_completed": status(fmu.completedIntegratorStep),
                "ct_set_time": status(fmu.setTime, 2e-3),
                "ct_enter_event": status(fmu.enterEventMode),
                "back_set_states": status(fmu.setContinuousStates, x, n),  # Event Mode again
                "terminate": status(fmu.terminate),
            }
        )
        fmu.freeInstance()
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    refused = {
        "set_states",
        "completed",
        "ct_discrete",
        "ct_enter_continuous",
        "back_set_states",
    } | ({"enter_event"} if fmi == 3 else set())
    assert {k for k, v in seen.items() if v == 3} == refused, seen
    assert {k for k, v in seen.items() if v == 0} == set(seen) - refused, seen
    text = "\n".join(said)
    assert f"fmi{fmi}SetContinuousStates is not allowed in state EventMode" in text, text
    discrete_name = "NewDiscreteStates" if fmi == 2 else "UpdateDiscreteStates"
    assert f"fmi{fmi}{discrete_name} is not allowed in state ContinuousTimeMode" in text, text


@pytest.mark.parametrize("fmi", (2, 3))
def test_unconnected_velocity_warns_once_in_model_exchange(native_fmus, fmi):
    """No slope fallback in model exchange (the velocity input is used as given), but the
    co-simulation's single warning when the displacement moves and the velocity never was set."""
    for set_velocity in (False, True):
        messages = []

        def logger(component, instance, status, category, message):
            text = message.decode() if isinstance(message, bytes) else str(message)
            messages.append((int(status), text))

        inst = _MeInstance(_path(native_fmus, "HumanBody3DOF", fmi), logger)
        try:
            if set_velocity:
                inst.set_inputs([0.0, 0.05, 0.0])
            inst.derivatives()
            for d in (0.01, 0.02):
                inst.set_inputs([d, 0.05 if set_velocity else 0.0, 0.0])
                dx = inst.derivatives()
            x = np.zeros(inst.n)
            s = np.array([0.02, 0.05 if set_velocity else 0.0, 0.0])
            lm = linear_model(load_model("reduced-paper"))
            ref = lm.B @ KINDS["body"](lm.network).input_map @ s  # the velocity as given
            assert np.allclose(dx, ref + lm.A @ x, rtol=1e-13, atol=0.0)
        finally:
            inst.close()
        warnings = [m for st, m in messages if st == 1]
        if set_velocity:
            assert warnings == [], messages
        else:
            assert len(warnings) == 1 and "seat_velocity was never set" in warnings[0], messages


ME_HOST = os.path.join(ROOT, "tests", "c_host", "me_host.c")
ME_CASES = ("HumanBody3DOF", "QuarterCar")  # RK4-stable at 1e-4 s (the ISO body needs 2e-8 s)
RK4_T, RK4_AMP, RK4_HZ = 0.5, 0.01, 2.0


def _sine_response(network, kind, t):
    """Exact states under d = a sin(w t), v = a w cos(w t) from rest: the harmonic response
    plus the free response that cancels it at t = 0."""
    lm = linear_model(network)
    iface = KINDS[kind](network)
    w = 2 * np.pi * RK4_HZ
    s = np.zeros(len(iface.inputs), dtype=complex)
    s[0], s[1] = -1j * RK4_AMP, RK4_AMP * w  # d = Re(s0 e^{iwt}), v = Re(s1 e^{iwt})
    X = np.linalg.solve(1j * w * np.eye(len(lm.A)) - lm.A, lm.B @ iface.input_map @ s)
    x0 = -X.real
    return (
        lm,
        iface,
        np.array([(X * np.exp(1j * w * tk)).real + scipy.linalg.expm(lm.A * tk) @ x0 for tk in t]),
    )


def _me_host_run(
    exe, native_fmus, name, h, platform="linux64", suffix=".so", prefix=(), env=None, folder=None
):
    from fmpy import read_model_description

    md = read_model_description(native_fmus[name])
    states = [v for v in md.modelVariables if v.name.startswith("state.")]
    ders = [v for v in md.modelVariables if v.name.startswith("der(state.")]
    ni = sum(v.causality == "input" for v in md.modelVariables)
    binary = os.path.join(folder, "binaries", platform, name + suffix)
    argv = [
        *prefix,
        exe,
        binary,
        md.guid,
        str(len(states)),
        str(ni),
        str(states[0].valueReference),
        str(ders[0].valueReference),
        repr(h),
        str(int(round(RK4_T / h))),
        repr(RK4_AMP),
        repr(RK4_HZ),
    ]
    out = subprocess.run(
        argv, capture_output=True, text=True, timeout=600, env={} if env is None else env
    )
    assert out.returncode == 0, out.stderr[-2000:]
    lines = out.stdout.splitlines()
    assert lines[-1].strip() == "ok"
    steps = np.array([l.split() for l in lines if l[:1].isdigit()], dtype=float)
    jac = np.array([l.split()[2:] for l in lines if l.startswith("jac ")], dtype=float).T
    return steps[:, 1], steps[:, 2:], jac


@pytest.fixture(scope="module")
def me_host(tmp_path_factory):
    exe = str(tmp_path_factory.mktemp("me_host") / "me_host")
    return compile_c_host([ME_HOST], exe)


@pytest.mark.parametrize("name", ME_CASES)
def test_c_host_rk4_converges_to_the_analytic_sine_response(me_host, native_fmus, name, tmp_path):
    """A C model-exchange host (no Python) integrates the FMU with RK4, inputs at every stage.

    Against the analytic response to a sine displacement with its exact velocity: fourth-order
    convergence (the error falls 16-fold when h halves; accepted 12 to 20) and below 1e-8 of
    the peak at h = 1e-4 s (measured 2.2e-10 and 1.7e-11) show that the FMU's derivatives are
    the model's; its Jacobian equals the library's [A | B U]."""
    with zipfile.ZipFile(native_fmus[name]) as z:
        z.extractall(tmp_path)
    load, kind = FMUS[name][:2]
    errors = []
    for h in (2e-4, 1e-4):
        t, x, jac = _me_host_run(me_host, native_fmus, name, h, folder=str(tmp_path))
        lm, iface, ref = _sine_response(load(), kind, t)
        errors.append(np.max(np.abs(x - ref) / np.max(np.abs(ref), axis=0)))
    assert errors[1] <= 1e-8, errors
    assert 12 <= errors[0] / errors[1] <= 20, errors
    exact = np.hstack([lm.A, lm.B @ iface.input_map])
    rows = np.max(np.abs(exact), axis=1, keepdims=True)
    assert np.all(np.abs(jac - exact) <= 1e-12 * rows)


ME_MODES = {  # me_host --modes: 3 = fmi2Error, a call of the other model-exchange mode
    "states_event": "0",
    "setstates_event": "3",
    "completed_event": "3",
    "settime_event": "0",
    "derivatives_event": "0",
    "discrete_event": "0",
    "refusals_left_states": "1",
    "continuous_event": "0",
    "discrete_continuous": "3",
    "continuous_continuous": "3",
    "setstates_continuous": "0",
    "completed_continuous": "0",
    "event_continuous": "0",
    "event_event": "0",
    "setstates_event_again": "3",
    "terminate_event": "0",
}


@pytest.mark.parametrize("name", ME_CASES)
def test_c_host_refuses_calls_of_the_other_model_exchange_mode(
    me_host, native_fmus, name, tmp_path
):
    """A C host walks an instance from ExitInitializationMode (Event Mode) into Continuous-Time
    Mode and back: each call the current mode does not allow returns fmi2Error with the reason
    logged and leaves the states as they were; the others return fmi2OK."""
    from fmpy import read_model_description

    with zipfile.ZipFile(native_fmus[name]) as z:
        z.extractall(tmp_path)
    md = read_model_description(native_fmus[name])
    states = [v for v in md.modelVariables if v.name.startswith("state.")]
    ders = [v for v in md.modelVariables if v.name.startswith("der(state.")]
    ni = sum(v.causality == "input" for v in md.modelVariables)
    argv = [
        me_host,
        "--modes",
        os.path.join(str(tmp_path), "binaries", "linux64", name + ".so"),
        md.guid,
        str(len(states)),
        str(ni),
        str(states[0].valueReference),
        str(ders[0].valueReference),
        "1e-3",
        "1",
        "0.01",
        "2",
    ]
    out = subprocess.run(argv, capture_output=True, text=True, timeout=120, env={})
    assert out.returncode == 0 and out.stdout.splitlines()[-1] == "ok", out.stderr
    got = dict(l.split() for l in out.stdout.splitlines() if " " in l)
    assert got == ME_MODES, out.stdout
    assert "fmi2SetContinuousStates is not allowed in state EventMode" in out.stderr
    assert "fmi2NewDiscreteStates is not allowed in state ContinuousTimeMode" in out.stderr


def test_win64_model_exchange_under_wine_matches_linux64(me_host, native_fmus, tmp_path):
    exe = str(tmp_path / "me_host.exe")
    with win64_host(ME_HOST, fmpy_headers(), exe, tmp_path) as (wine, env):
        for name in ME_CASES:
            folder = tmp_path / name
            with zipfile.ZipFile(native_fmus[name]) as z:
                z.extractall(folder)
            _, xw, jw = _me_host_run(
                exe,
                native_fmus,
                name,
                1e-3,
                platform="win64",
                suffix=".dll",
                prefix=(wine,),
                env=env,
                folder=str(folder),
            )
            _, xl, jl = _me_host_run(me_host, native_fmus, name, 1e-3, folder=str(folder))
            # the sine comes from each platform's own libm (1 ulp apart at most)
            assert np.max(np.abs(xw - xl) / np.max(np.abs(xl), axis=0)) <= 1e-12
            assert np.array_equal(jw, jl)
