"""The standard's interface of the native FMUs, through fmpy's low-level API (FMI 2.0, 3.0).

* The state machine: every call the standard's state table does not allow in the instance's
  state returns Error with the reason logged and changes nothing; the start time of
  fmi2SetupExperiment / fmi3EnterInitializationMode is the model's time.
* Refusals: a step whose result is not finite is discarded (status 2, as the pythonfmu FMU
  reports a refused step) with the state unchanged; a denormal mass is refused at
  initialization without touching the model, so Reset and valid parameters recover.
* Interpolation: input derivatives (fmi2SetRealInputDerivatives, orders 1 and 2 on the
  displacement inputs) are the rate inputs, bit for bit; output derivatives
  (fmi2GetRealOutputDerivatives, fmi3GetOutputDerivatives) are exact: order 1 of the car's
  seat_displacement is its seat_velocity output and order 2 its sprung_acceleration (other
  rows of the model, to rounding), order 1 of the body's seat_force is its seat_force_rate,
  order 2 agrees with central differences of a fine run. A Jacobi host that couples car and
  body through displacements, forces and these derivatives alone (no seat_velocity,
  seat_acceleration or seat_force_rate wired) is as accurate against the monolithic
  reference as the wired coupling (tests/test_native_cosim.py: 0.0101 % at 1 ms with the
  seat acceleration wired; measured here 0.0065 %), second order in the step.
"""

import shutil

import numpy as np
import pytest
from test_native_cosim import DURATION, road
from test_native_fmu import BODY_OUT, _fmi2_callbacks, chirp, grid

from bodyvib.models import load_model
from bodyvib.vehicle.quarter_car import load_car
from bodyvib.vehicle.reference import nrmse, reference_run

pytestmark = pytest.mark.integration


class Raw:
    """A native FMU in fmpy, instantiated only; calls report their status instead of raising."""

    def __init__(self, path, name="t"):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave
        from fmpy.fmi3 import FMU3Slave

        self.md = read_model_description(path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.fmi3 = self.md.fmiVersion == "3.0"
        self.dir = extract(path)
        self.messages = []
        cls = FMU3Slave if self.fmi3 else FMU2Slave
        self.fmu = cls(
            guid=self.md.guid,
            unzipDirectory=self.dir,
            instanceName=name,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
        )
        if self.fmi3:
            self.fmu.instantiate(
                logMessage=lambda env, status, category, message: self.messages.append(
                    message.decode()
                )
            )
        else:
            self.fmu.instantiate(
                callbacks=_fmi2_callbacks(
                    lambda env, name, status, category, message: self.messages.append(
                        message.decode()
                    )
                )
            )

    def status(self, fn, *args, **kw):
        """The FMI status of one call (0 OK, 2 Discard, 3 Error)."""
        from fmpy.fmi1 import FMICallException

        try:
            getattr(self.fmu, fn)(*args, **kw)
        except FMICallException as exc:
            return exc.status
        return 0

    def get(self, names):
        call = self.fmu.getFloat64 if self.fmi3 else self.fmu.getReal
        return call([self.vr[n] for n in names])

    def set(self, values):
        call = self.fmu.setFloat64 if self.fmi3 else self.fmu.setReal
        call([self.vr[n] for n in values], [float(v) for v in values.values()])

    def init(self, start=0.0):
        if self.fmi3:
            self.fmu.enterInitializationMode(startTime=start)
        else:
            self.fmu.setupExperiment(startTime=start)
            self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def derivatives(self, names, orders):
        vrs = [self.vr[n] for n in names]
        if self.fmi3:
            return self.fmu.getOutputDerivatives(vrs, orders)
        return self.fmu.getRealOutputDerivatives(vrs, orders)

    def close(self):
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_calls_out_of_order_are_errors_that_change_nothing(native_fmus, fmi):
    f = Raw(native_fmus[fmi + "HumanBody3DOF"])
    h, get, step = 1e-3, ("getFloat64" if f.fmi3 else "getReal"), "doStep"
    set_ = "setFloat64" if f.fmi3 else "setReal"
    m1, head = f.vr["m1"], [f.vr["head_acceleration"]]
    try:
        seen = {
            "get_instantiated": f.status(get, head),
            "step_instantiated": f.status(step, 0.0, h),
            "exit_instantiated": f.status("exitInitializationMode"),
            "terminate_instantiated": f.status("terminate"),
        }
        if f.fmi3:
            seen["enter"] = f.status("enterInitializationMode", startTime=1.5)
        else:
            seen["enter"] = f.status("setupExperiment", startTime=1.5) + f.status(
                "enterInitializationMode"
            )
            seen["setup_initialization"] = f.status("setupExperiment", startTime=0.0)
        seen.update(
            {
                "enter_initialization": f.status("enterInitializationMode"),
                "step_initialization": f.status(step, 1.5, h),
                "get_initialization": f.status(get, head),
                "exit": f.status("exitInitializationMode"),
                "exit_stepping": f.status("exitInitializationMode"),
                "parameter_stepping": f.status(set_, [m1], [9.0]),
                "step_from_zero": f.status(step, 0.0, h),
                "step_from_start": f.status(step, 1.5, h),
                "terminate": f.status("terminate"),
                "step_terminated": f.status(step, 1.5 + h, h),
                "set_terminated": f.status(set_, [f.vr["seat_displacement"]], [0.1]),
                "terminate_terminated": f.status("terminate"),
                "get_terminated": f.status(get, [m1]),
            }
        )
        if f.fmi3:
            seen["step_mode"] = f.status("enterStepMode")
        assert f.get(["m1"]) == [pytest.approx(4.88)]  # the refused parameter change
        seen["reset"] = f.status("reset")
        seen["get_after_reset"] = f.status(get, head)
    finally:
        f.close()
    errors = {k for k, v in seen.items() if v == 3}
    allowed = {
        "enter",
        "get_initialization",
        "exit",
        "step_from_start",
        "terminate",
        "get_terminated",
        "reset",
    }
    assert {k for k, v in seen.items() if v == 0} == allowed, seen
    assert errors == set(seen) - allowed, seen
    text = "\n".join(f.messages)
    for fn in ("DoStep", "GetReal" if not f.fmi3 else "GetFloat64"):
        assert f"fmi{3 if f.fmi3 else 2}{fn} is not allowed in state" in text, text
    assert "but the model is at t = 1.5 s" in text


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_overflow_is_discarded_and_a_denormal_mass_recovers_after_reset(native_fmus, fmi):
    t = grid(False, n=300)
    x, v = chirp(t)

    def run(f):
        rows = []
        for k in range(t.size):
            f.set({"seat_displacement": x[k], "seat_velocity": v[k]})
            rows.append(f.get(BODY_OUT))
            if k < t.size - 1:
                assert f.status("doStep", t[k], t[k + 1] - t[k]) == 0, f.messages[-3:]
        return np.array(rows)

    fresh = Raw(native_fmus[fmi + "HumanBody3DOF"])
    fresh.init()
    y0 = run(fresh)
    fresh.close()
    f = Raw(native_fmus[fmi + "HumanBody3DOF"])
    try:
        f.set({"m1": 1e-310})
        if f.fmi3:
            f.fmu.enterInitializationMode()
        else:
            f.fmu.setupExperiment(startTime=0.0)
            f.fmu.enterInitializationMode()
        assert f.status("exitInitializationMode") == 3
        assert f.status("doStep", 0.0, 1e-3) == 3
        assert f.status("reset") == 0
        f.init()
        y1 = run(f)
        assert np.array_equal(y1, y0)  # the model the instance had: bit for bit
        # finite inputs that overflow the step: discarded, the state unchanged
        end = float(t[-1])
        before = f.get(BODY_OUT)
        f.set({"seat_displacement": 1e308, "seat_velocity": 1e308})
        assert f.status("doStep", end, 1e-3) == 2
        f.set({"seat_displacement": x[-1], "seat_velocity": v[-1]})
        assert f.get(BODY_OUT) == before
        assert f.status("doStep", end, 1e-3) == 0  # and it steps on from where it was
        assert any("step refused (discard), state unchanged" in m for m in f.messages)
    finally:
        f.close()


def test_model_descriptions_declare_the_interpolation_interface(native_fmus):
    from fmpy import read_model_description

    for name in ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar"):
        cs2 = read_model_description(native_fmus[name]).coSimulation
        cs3 = read_model_description(native_fmus["fmi3/" + name]).coSimulation
        assert cs2.canInterpolateInputs and cs2.maxOutputDerivativeOrder == 2
        assert cs3.maxOutputDerivativeOrder == 2


def test_input_derivatives_are_the_rate_inputs_bit_for_bit(native_fmus):
    """fmi2SetRealInputDerivatives(seat_displacement, 1 and 2) gives the same run as setting
    seat_velocity and seat_acceleration; the car's road_displacement has no order 2 (its
    velocity has no rate input): a non-zero order 2 is refused, a zero one accepted."""
    t = grid(False, n=300)
    x, v = chirp(t)
    a = np.gradient(v, t)
    runs = []
    for mode in ("rates", "derivatives"):
        f = Raw(native_fmus["HumanBody3DOF"])
        f.init()
        vr = f.vr["seat_displacement"]
        rows = []
        try:
            for k in range(t.size):
                if mode == "rates":
                    f.set(
                        {
                            "seat_displacement": x[k],
                            "seat_velocity": v[k],
                            "seat_acceleration": a[k],
                        }
                    )
                else:
                    f.set({"seat_displacement": x[k]})
                    f.fmu.setRealInputDerivatives([vr, vr], [1, 2], [v[k], a[k]])
                rows.append(f.get(BODY_OUT))
                if k < t.size - 1:
                    f.fmu.doStep(t[k], t[k + 1] - t[k])
            assert not any("never set" in m for m in f.messages)  # no slope fallback
        finally:
            f.close()
        runs.append(np.array(rows))
    assert np.array_equal(runs[0], runs[1])
    car = Raw(native_fmus["QuarterCar"])
    try:
        car.init()
        road_vr = car.vr["road_displacement"]
        assert car.status("setRealInputDerivatives", [road_vr], [2], [3.0]) == 3
        assert car.status("setRealInputDerivatives", [road_vr], [2], [0.0]) == 0
        assert (
            car.status("setRealInputDerivatives", [car.vr["seat_displacement"]], [1], [1.0]) == 3
        )  # an output
        assert any("no in-step derivative of order 2" in m for m in car.messages)
    finally:
        car.close()


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_output_derivatives_are_exact(native_fmus, fmi):
    """Car on a road sweep: orders 1 and 2 of seat_displacement equal its seat_velocity and
    sprung_acceleration outputs (other rows of the model) to rounding. Body: order 1 of
    seat_force equals seat_force_rate; order 2, in the free decay after a chirp (inputs 0,
    so the force is smooth across steps), equals central differences of seat_force_rate
    over 10 us steps (truncation error h^2/6 of its 4th derivative: about 1e-6)."""
    h, n = 1e-4, 2000
    t = np.arange(n + 1) * h
    z, zv = road(t)
    car = Raw(native_fmus[fmi + "QuarterCar"])
    rows, derivs = [], []
    try:
        car.init()
        for k in range(n + 1):
            car.set({"road_displacement": z[k], "road_velocity": zv[k]})
            rows.append(car.get(["seat_velocity", "sprung_acceleration"]))
            derivs.append(car.derivatives(["seat_displacement"] * 2, [1, 2]))
            if k < n:
                car.fmu.doStep(t[k], h)
        assert (
            car.status(
                "getRealOutputDerivatives" if not car.fmi3 else "getOutputDerivatives",
                [car.vr["seat_displacement"]],
                [3],
            )
            == 3
        )
    finally:
        car.close()
    rows, derivs = np.array(rows), np.array(derivs)
    assert np.all(np.max(np.abs(derivs - rows), axis=0) <= 1e-12 * np.max(np.abs(rows), axis=0))

    body = Raw(native_fmus[fmi + "HumanBody3DOF"])
    x, v = chirp(t)
    rate, d1, d2 = [], [], []
    try:
        body.init()
        for k in range(n):
            body.set({"seat_displacement": x[k], "seat_velocity": v[k]})
            body.fmu.doStep(t[k], h)
        body.set({"seat_displacement": 0.0, "seat_velocity": 0.0})
        hf, time = 1e-5, t[n]
        for _k in range(400):
            rate.append(body.get(["seat_force_rate"])[0])
            a, b = body.derivatives(["seat_force", "seat_force"], [1, 2])
            d1.append(a)
            d2.append(b)
            body.fmu.doStep(time, hf)
            time += hf
    finally:
        body.close()
    rate, d1, d2 = np.array(rate), np.array(d1), np.array(d2)
    assert np.max(np.abs(d1 - rate)) <= 1e-12 * np.max(np.abs(rate))
    fd = (rate[2:] - rate[:-2]) / (2 * hf)
    rel = np.max(np.abs(d2[1:-1] - fd)) / np.max(np.abs(fd))
    assert rel < 1e-4, rel


def coupled_by_derivatives(native_fmus, h, derivatives=True):
    """Jacobi host: car and body exchange displacement and force, with their derivatives
    (orders 1 and 2 of the seat displacement, order 1 of the seat force) when asked; the
    road is given as road_displacement and its order-1 derivative. No rate port is set."""
    n = int(round(DURATION / h))
    t = np.arange(n + 1) * h
    z, zv = road(t)
    car, body = Raw(native_fmus["QuarterCar"]), Raw(native_fmus["HumanBody3DOF"])
    head = np.zeros(n + 1)
    seat, force, road_x = (
        car.vr["seat_displacement"],
        car.vr["seat_force"],
        car.vr["road_displacement"],
    )
    body_seat, body_force = body.vr["seat_displacement"], body.vr["seat_force"]
    try:
        car.init()
        body.init()
        for k in range(n):
            # in the order of the direct dependencies (no algebraic loop): the seat motion
            # and its slope (no feedthrough), the body's force, the seat's curvature (it
            # depends on the car's inputs), the force's slope (it depends on the curvature)
            xs = car.get(["seat_displacement"])[0]
            body.set({"seat_displacement": xs})
            if derivatives:
                d1 = car.fmu.getRealOutputDerivatives([seat], [1])[0]
                body.fmu.setRealInputDerivatives([body_seat], [1], [d1])
            car.set({"seat_force": body.get(["seat_force"])[0], "road_displacement": z[k]})
            car.fmu.setRealInputDerivatives([road_x], [1], [zv[k]])
            if derivatives:
                d2 = car.fmu.getRealOutputDerivatives([seat], [2])[0]
                body.fmu.setRealInputDerivatives([body_seat], [2], [d2])
                df = body.fmu.getRealOutputDerivatives([body_force], [1])[0]
                car.fmu.setRealInputDerivatives([force], [1], [df])
            car.fmu.doStep(t[k], h)
            body.fmu.doStep(t[k], h)
            head[k + 1] = body.get(["head_acceleration"])[0]
    finally:
        car.close()
        body.close()
    ref = reference_run(load_car(), load_model("reduced-paper"), z, zv, h)["head_acceleration"]
    return nrmse(head, ref)


def test_derivatives_alone_couple_car_and_body_to_the_wired_accuracy(native_fmus):
    """Measured: 0.0065 % at 1 ms, 0.0016 % at 0.5 ms (ratio 3.96): better than the Jacobi
    hosts with every rate port wired (tests/test_native_cosim.py: 0.0101 % at 1 ms), since
    the derivatives are exchanged in the order of their direct dependencies; without
    derivatives (displacement and force held, the slope fallback for the velocity) 0.43 %."""
    e1 = coupled_by_derivatives(native_fmus, 1e-3)
    e2 = coupled_by_derivatives(native_fmus, 5e-4)
    plain = coupled_by_derivatives(native_fmus, 1e-3, derivatives=False)
    print(f"derivative coupling NRMSE: {e1:.3e} (1 ms), {e2:.3e} (0.5 ms); without {plain:.3e}")
    assert e1 < 1.0e-4 and e1 < plain / 30, (e1, plain)
    assert 3.0 < e1 / e2 < 6.0, (e1, e2)


def test_fmi3_time_reads_among_outputs_and_an_unknown_reference_refuses(native_fmus):
    """FMI 3.0's independent variable (value reference after the contract's) read in one
    fmi3GetFloat64 with outputs: the time at its place, the outputs as read alone, bit for
    bit; an unknown reference in such a request refuses the call (Error, logged)."""
    f = Raw(native_fmus["fmi3/HumanBody3DOF"])
    try:
        f.init(start=0.25)
        f.set({"seat_displacement": 0.01, "seat_velocity": 0.2})
        f.fmu.doStep(0.25, 1e-3)
        names = ["head_acceleration", "seat_force"]
        alone = f.get(names)
        t = max(v.valueReference for v in f.md.modelVariables if v.name == "time")
        out, force = [f.vr[n] for n in names]
        mixed = f.fmu.getFloat64([out, t, force, t])
        refused = f.status("getFloat64", [out, t, t + 10_000])
    finally:
        f.close()
    assert mixed == [alone[0], 0.25 + 1e-3, alone[1], 0.25 + 1e-3]
    assert refused == 3
    assert "no variable with value reference" in "\n".join(f.messages)


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_changed_step_size_steps_with_its_own_matrices(native_fmus, fmi):
    """Steps of 1, 0.5, 1 and 2 ms in one run: the native step keeps the matrices of its
    last step size and makes new ones when the size changes, so every output after every
    step equals that of the library's FmuCore (its own exponential, in numpy) given the
    same steps and inputs, to 1e-9 of the output's largest magnitude: the exponentials
    agree to about 1e-14, and 200 steps of the damped 5-state recursion keep that far below
    1e-9, while steps with another size's matrices are off by more than the outputs' own
    size (measured with the step-size test of the fast path broken)."""
    from bodyvib.runtime.engine import FmuCore

    f = Raw(native_fmus["HumanBody3DOF" if fmi == 2 else "fmi3/HumanBody3DOF"])
    core = FmuCore("body", load_model("reduced-paper"), "HumanBody3DOF")
    names = [v.name for v in f.md.modelVariables if v.causality == "output"]
    outs = [f.vr[n] for n in names]
    ins = [f.vr[n] for n in ("seat_displacement", "seat_velocity", "seat_acceleration")]
    core.initialize()
    native, library, t = [], [], 0.0
    try:
        f.init()
        for h in [1e-3] * 50 + [5e-4] * 50 + [1e-3] * 50 + [2e-3] * 50:
            w = 2 * np.pi * 3.0
            s = [0.01 * np.sin(w * t), 0.01 * w * np.cos(w * t), -0.01 * w * w * np.sin(w * t)]
            f.set(dict(zip(("seat_displacement", "seat_velocity", "seat_acceleration"), s)))
            core.set_real(ins, s)
            f.fmu.doStep(t, h)
            core.do_step(t, h)
            native.append(f.get(names))
            library.append(core.get_real(outs))
            t += h
    finally:
        f.close()
    native, library = np.array(native), np.array(library)
    scale = np.abs(library).max(axis=0)
    assert np.all(scale > 0)
    np.testing.assert_array_less(np.abs(native - library).max(axis=0), 1e-9 * scale)


@pytest.mark.parametrize("name", ["HumanBody3DOF", "QuarterCar"])
def test_fmi3_time_cannot_be_set_and_a_request_with_it_sets_nothing(native_fmus, name):
    """fmi3SetFloat64 of an input together with the independent variable time: Error, the
    reason logged, the input keeps its value and the model its time."""
    f = Raw(native_fmus[f"fmi3/{name}"])
    first = next(v.name for v in f.md.modelVariables if v.causality == "input")
    t = max(v.valueReference for v in f.md.modelVariables if v.name == "time")
    try:
        f.init(start=0.5)
        f.set({first: 0.01})
        refused = f.status("setFloat64", [f.vr[first], t], [0.02, 7.0])
        after = f.fmu.getFloat64([f.vr[first], t])
    finally:
        f.close()
    assert refused == 3
    assert after == [0.01, 0.5]
    assert any("time is the independent variable" in m for m in f.messages), f.messages
