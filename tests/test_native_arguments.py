"""Argument checks of the native FMUs' FMI functions, all four FMUs, FMI 2.0 and 3.0.

Every call below breaks a rule of the standard that the FMU can see: a non-finite time or
continuous state, a NULL pointer the call reads or writes through, a co-simulation function
called on a model-exchange instance (or the reverse), a function the FMU does not provide.
Each must return Error, log one line that names the function, and leave the instance as it
was: its serialized FMU state (every byte of the model's time, states and inputs, with a
checksum) is compared before and after, so "nothing changed" is exact, not within a
tolerance. The log categories (``fmiXSetDebugLogging``) are checked the same way: with the
error category switched off a refusal is silent, switched on again it is logged.
"""

import math
import shutil
from ctypes import CDLL, byref, c_bool, c_char_p, c_double, c_int, c_size_t, c_uint, c_void_p

import pytest
from test_native_fmu import _fmi2_callbacks

pytestmark = pytest.mark.integration

NAMES = ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar", "Road")
ERROR = 3
NAN, INF = math.nan, math.inf


class Instance:
    """A native FMU instantiated in fmpy for model exchange or co-simulation and initialized;
    raw calls give their status, the log collects (status, message)."""

    def __init__(self, path, me):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Model, FMU2Slave
        from fmpy.fmi3 import FMU3Model, FMU3Slave

        self.md = read_model_description(path)
        self.fmi = 2 if self.md.fmiVersion == "2.0" else 3
        self.dir = extract(path)
        self.log = []
        iface = self.md.modelExchange if me else self.md.coSimulation
        cls = {(2, True): FMU2Model, (2, False): FMU2Slave, (3, True): FMU3Model}.get(
            (self.fmi, me), FMU3Slave
        )
        self.fmu = cls(
            guid=self.md.guid,
            unzipDirectory=self.dir,
            instanceName="arg",
            modelIdentifier=iface.modelIdentifier,
        )
        if self.fmi == 2:
            said = lambda env, name, status, cat, msg: self.log.append((status, msg.decode()))  # noqa: E731
            self.fmu.instantiate(callbacks=_fmi2_callbacks(said))
            self.fmu.setupExperiment(startTime=0.0)
        else:
            said = lambda env, status, cat, msg: self.log.append((status, msg.decode()))  # noqa: E731
            self.fmu.instantiate(logMessage=said)
        self.raw = CDLL(self.fmu.dll._name)  # its own function objects: fmpy's keep their types
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.n = self.md.numberOfContinuousStates
        if me:
            self.call(
                "NewDiscreteStates" if self.fmi == 2 else "UpdateDiscreteStates", *self._discrete()
            )
            self.call("EnterContinuousTimeMode")

    def _discrete(self):
        if self.fmi == 2:
            from fmpy.fmi2 import fmi2EventInfo

            return (byref(fmi2EventInfo()),)
        return tuple(
            byref(x) for x in (c_bool(), c_bool(), c_bool(), c_bool(), c_bool(), c_double())
        )

    def call(self, name, *args):
        """fmiX<name>(instance, *args) as the raw C call: its status."""
        fn = getattr(self.raw, f"fmi{self.fmi}{name}")
        fn.restype = c_int
        return fn(c_void_p(self.fmu.component), *args)

    def state(self):
        """The instance's serialized FMU state (bytes)."""
        return bytes(
            self.fmu.serializeFMUState(self.fmu.getFMUState())
            if self.fmi == 3
            else self.fmu.serializeFMUstate(self.fmu.getFMUstate())
        )

    def close(self):
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def _path(native_dist, name, fmi):
    return str(native_dist / ("fmi3" if fmi == 3 else "") / f"{name}.fmu")


def _me_calls(fmi, n):
    """The model-exchange calls with a bad argument: name -> (function, args)."""
    x_nan = (c_double * max(n, 1))(*([1e-3] * max(n, 1)))
    x_nan[0] = NAN
    x_inf = (c_double * max(n, 1))(*([1e-3] * max(n, 1)))
    x_inf[n - 1 if n else 0] = -INF
    out = (c_double * max(n, 1))()
    flag = c_int() if fmi == 2 else c_bool()
    calls = {
        "time nan": ("SetTime", c_double(NAN)),
        "time inf": ("SetTime", c_double(INF)),
        "time -inf": ("SetTime", c_double(-INF)),
        "states NULL": ("SetContinuousStates", None, c_size_t(n)) if n else None,
        "get states NULL": ("GetContinuousStates", None, c_size_t(n)) if n else None,
        "derivatives NULL": (
            (("GetDerivatives" if fmi == 2 else "GetContinuousStateDerivatives"), None, c_size_t(n))
            if n
            else None
        ),
        "nominals NULL": ("GetNominalsOfContinuousStates", None, c_size_t(n)) if n else None,
        "states nan": ("SetContinuousStates", x_nan, c_size_t(n)) if n else None,
        "states -inf": ("SetContinuousStates", x_inf, c_size_t(n)) if n else None,
        "completed NULL": ("CompletedIntegratorStep", c_int(1), None, byref(flag)),
        "completed NULL 2": ("CompletedIntegratorStep", c_int(1), byref(flag), None),
        "event indicators NULL": ("GetEventIndicators", None, c_size_t(1)),
        "get real NULL": (("GetReal" if fmi == 2 else "GetFloat64"), None, c_size_t(1))
        + ((out, c_size_t(1)) if fmi == 3 else (out,)),
        "get state NULL": (("GetFMUstate" if fmi == 2 else "GetFMUState"), None),
        "set state NULL": (("SetFMUstate" if fmi == 2 else "SetFMUState"), None),
        "directional NULL": (
            "GetDirectionalDerivative",
            None,
            c_size_t(1),
            None,
            c_size_t(1),
            None,
            None,
        )
        + ((c_size_t(1), None, c_size_t(1)) if fmi == 3 else ()),
        "directional seed nan": (
            "GetDirectionalDerivative",
            (c_uint * 1)(0),
            c_size_t(1),
            (c_uint * 1)(0),
            c_size_t(1),
            (c_double * 1)(NAN),
        )
        + ((c_size_t(1), out, c_size_t(1)) if fmi == 3 else (out,)),
        "log category": ("SetDebugLogging", c_int(1), c_size_t(1), (c_char_p * 1)(b"logNothing")),
        "log category NULL": ("SetDebugLogging", c_int(1), c_size_t(1), None),
        # a co-simulation function on a model-exchange instance
        "cs output derivatives": (
            ("GetRealOutputDerivatives" if fmi == 2 else "GetOutputDerivatives"),
            (c_uint * 1)(0),
            c_size_t(1),
            (c_int * 1)(1),
            out,
        )
        + ((c_size_t(1),) if fmi == 3 else ()),
    }
    if fmi == 2:
        calls.update(
            {  # co-simulation functions on a model-exchange instance
                "cs input derivatives": (
                    "SetRealInputDerivatives",
                    (c_uint * 1)(0),
                    c_size_t(1),
                    (c_int * 1)(1),
                    (c_double * 1)(0.0),
                ),
                "cs do step": ("DoStep", c_double(0.0), c_double(1e-3), c_int(1)),
                "cs cancel": ("CancelStep",),
                "cs status": ("GetStatus", c_int(0), byref(c_int())),
                "cs real status": ("GetRealStatus", c_int(2), byref(c_double())),
                "cs integer status": ("GetIntegerStatus", c_int(0), byref(c_int())),
                "cs boolean status": ("GetBooleanStatus", c_int(3), byref(c_int())),
                "cs string status": ("GetStringStatus", c_int(4), byref(c_char_p())),
                "new discrete NULL": ("NewDiscreteStates", None),
            }
        )
    else:
        b = byref(c_bool())
        calls.update(
            {
                "cs do step": (
                    "DoStep",
                    c_double(0.0),
                    c_double(1e-3),
                    c_bool(True),
                    b,
                    b,
                    b,
                    byref(c_double()),
                ),
                "cs enter step mode": ("EnterStepMode",),
                "number of states NULL": ("GetNumberOfContinuousStates", None),
                "number of indicators NULL": ("GetNumberOfEventIndicators", None),
                "update discrete NULL": (
                    "UpdateDiscreteStates",
                    None,
                    b,
                    b,
                    b,
                    b,
                    byref(c_double()),
                ),
                "adjoint": (
                    "GetAdjointDerivative",
                    None,
                    c_size_t(0),
                    None,
                    c_size_t(0),
                    None,
                    c_size_t(0),
                    None,
                    c_size_t(0),
                ),
                "configuration": ("EnterConfigurationMode",),
                "evaluate discrete": ("EvaluateDiscreteStates",),
                "dependencies": ("GetNumberOfVariableDependencies", c_uint(0), byref(c_size_t())),
            }
        )
    return {k: v for k, v in calls.items() if v is not None}


@pytest.mark.parametrize("fmi", (2, 3))
@pytest.mark.parametrize("name", NAMES)
def test_model_exchange_refuses_bad_arguments_with_a_log_line_and_the_state_kept(
    native_dist, name, fmi
):
    inst = Instance(_path(native_dist, name, fmi), me=True)
    try:
        # a real state to keep: states moved off the initial ones, time 0.25 s
        assert inst.call("SetTime", c_double(0.25)) == 0
        if inst.n:
            x = (c_double * inst.n)(*[1e-3 * (i + 1) for i in range(inst.n)])
            assert inst.call("SetContinuousStates", x, c_size_t(inst.n)) == 0
        before = inst.state()
        wrong = {}
        for case, (fn, *args) in _me_calls(fmi, inst.n).items():
            del inst.log[:]
            status = inst.call(fn, *args)
            logged = [m for s, m in inst.log if s == ERROR]
            if status != ERROR or len(logged) != 1 or f"fmi{fmi}{fn}" not in logged[0]:
                wrong[case] = (status, inst.log[:])
            assert inst.state() == before, case
        assert not wrong, wrong
    finally:
        inst.close()


@pytest.mark.parametrize("fmi", (2, 3))
@pytest.mark.parametrize("name", ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar", "HalfCar"))
def test_model_exchange_refuses_a_non_finite_input(native_dist, name, fmi):
    """Model exchange has no step to refuse a non-finite input at (co-simulation refuses it
    at DoStep): SetReal of NaN, inf or -inf on any input is refused with one log line naming
    the input, nothing changed, and the derivatives stay finite."""
    inst = Instance(_path(native_dist, name, fmi), me=True)
    inputs = [v.valueReference for v in inst.md.modelVariables if v.causality == "input"]
    names = {v.valueReference: v.name for v in inst.md.modelVariables}
    setter = "SetReal" if fmi == 2 else "SetFloat64"
    try:
        before = inst.state()
        wrong = {}
        for vr in inputs:
            for bad in (NAN, INF, -INF):
                del inst.log[:]
                args = ((c_uint * 2)(inputs[0], vr), c_size_t(2), (c_double * 2)(1e-3, bad))
                status = inst.call(setter, *args, *((c_size_t(2),) if fmi == 3 else ()))
                if status != ERROR or len(inst.log) != 1 or names[vr] not in inst.log[0][1]:
                    wrong[(names[vr], bad)] = (status, inst.log[:])
                assert inst.state() == before, (names[vr], bad)
        assert not wrong, wrong
        dx = (c_double * inst.n)()
        fn = "GetDerivatives" if fmi == 2 else "GetContinuousStateDerivatives"
        assert inst.call(fn, dx, c_size_t(inst.n)) == 0
        assert all(math.isfinite(x) for x in dx)
    finally:
        inst.close()


@pytest.mark.parametrize("fmi", (2, 3))
def test_model_exchange_functions_on_a_co_simulation_instance_are_refused(native_dist, fmi):
    inst = Instance(_path(native_dist, "HumanBody3DOF", fmi), me=False)
    try:
        before = inst.state()
        for fn, *args in (
            ("SetTime", c_double(0.5)),
            ("EnterContinuousTimeMode",),
            ("SetContinuousStates", (c_double * 3)(), c_size_t(3)),
        ):
            del inst.log[:]
            assert inst.call(fn, *args) == ERROR, fn
            assert len(inst.log) == 1 and "co-simulation instance" in inst.log[0][1], inst.log
        assert inst.state() == before
    finally:
        inst.close()


@pytest.mark.parametrize("fmi", (2, 3))
def test_debug_logging_switches_the_categories(native_dist, fmi):
    """SetDebugLogging(off) silences the refusals, (on, logStatusError) brings them back; the
    refusal itself does not depend on logging."""
    inst = Instance(_path(native_dist, "QuarterCar", fmi), me=True)
    cats = (c_char_p * 1)(b"logStatusError")
    try:
        assert inst.call("SetDebugLogging", c_int(0), c_size_t(0), None) == 0
        assert inst.call("SetTime", c_double(NAN)) == ERROR and inst.log == []
        assert inst.call("SetDebugLogging", c_int(1), c_size_t(1), cats) == 0
        assert inst.call("SetTime", c_double(NAN)) == ERROR and len(inst.log) == 1
        assert inst.call("SetDebugLogging", c_int(0), c_size_t(1), cats) == 0
        assert inst.call("SetTime", c_double(INF)) == ERROR and len(inst.log) == 1
    finally:
        inst.close()
