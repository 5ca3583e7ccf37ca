"""SkyhookController.fmu's contract with its host (issue 38, defects 2 to 4).

The FMU is built as ``bodyvib build --control`` builds it and driven through raw FMI 2.0
calls in fmpy. Each refusal must return fmi2Error, log one line, and leave the instance
as it was: its time (fmi2LastSuccessfulTime), every real variable and its outputs are
compared before and after, exactly.
"""

import math
import shutil
from ctypes import CDLL, byref, c_double, c_int, c_uint, c_void_p

import pytest
from test_native_fmu import _fmi2_callbacks

pytestmark = pytest.mark.integration

C_SKY, C_GROUND, H = 4000.0, 1500.0, 1e-3
OK, ERROR = 0, 3


@pytest.fixture(scope="module")
def controller(tmp_path_factory):
    from bodyvib.fmu.controller import build_controller_fmu

    dest = tmp_path_factory.mktemp("controller")
    return str(build_controller_fmu(dest, ("",), C_SKY, C_GROUND, platforms=("linux64",)))


class Controller:
    """One instance in fmpy, set up and initialized; ``call`` gives a raw call's status."""

    def __init__(self, path, initialize=True):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        md = read_model_description(path)
        self.vr = {v.name: v.valueReference for v in md.modelVariables if v.type == "Real"}
        self.dir = extract(path)
        self.log = []
        self.fmu = FMU2Slave(
            guid=md.guid,
            unzipDirectory=self.dir,
            instanceName="ctl",
            modelIdentifier=md.coSimulation.modelIdentifier,
        )
        said = lambda env, name, status, cat, msg: self.log.append((status, msg.decode()))  # noqa: E731
        self.fmu.instantiate(callbacks=_fmi2_callbacks(said))
        self.raw = CDLL(self.fmu.dll._name)
        if initialize:
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
            self.fmu.exitInitializationMode()

    def call(self, name, *args):
        fn = getattr(self.raw, f"fmi2{name}")
        fn.restype = c_int
        return fn(c_void_p(self.fmu.component), *args)

    def set(self, **values):
        refs = (c_uint * len(values))(*[self.vr[n] for n in values])
        vals = (c_double * len(values))(*values.values())
        return self.call("SetReal", refs, len(values), vals)

    def force(self):
        return self.fmu.getReal([self.vr["actuator_force"], self.vr["actuator_force_rate"]])

    def snapshot(self):
        """Time, every real variable's value and the outputs, as read now (with the calls'
        statuses: before initialization they are refused)."""
        t = c_double()
        status = self.call("GetRealStatus", c_int(2), byref(t))  # fmi2LastSuccessfulTime
        refs = sorted(self.vr.values())
        values = (c_double * len(refs))()
        status2 = self.call("GetReal", (c_uint * len(refs))(*refs), len(refs), values)
        return [status, t.value, status2] + list(values)

    def close(self):
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def test_outputs_follow_new_inputs_at_once(controller):
    """After a step the force is the law of the inputs in force: the velocities set before
    the step carried over it along the accelerations (what a Jacobi host reads), then,
    once the host sets new values, the law of those values (the issue's set-then-read
    case: -c 0.2, not the extrapolation -c (0.2 + 2 h))."""
    ctl = Controller(controller)
    try:
        assert ctl.set(upper_velocity=0.1, upper_acceleration=1.0, lower_velocity=0.05) == OK
        assert ctl.force() == [-C_SKY * 0.1 + C_GROUND * 0.05, -C_SKY * 1.0]
        ctl.fmu.doStep(0.0, H)
        assert ctl.force()[0] == -C_SKY * (0.1 + 1.0 * H) + C_GROUND * 0.05
        assert ctl.set(upper_velocity=0.2, upper_acceleration=2.0) == OK
        assert ctl.force() == [-C_SKY * 0.2 + C_GROUND * 0.05, -C_SKY * 2.0]
        ctl.fmu.doStep(H, H)  # and the new values are carried over the next step
        assert ctl.force()[0] == -C_SKY * (0.2 + 2.0 * H) + C_GROUND * 0.05
    finally:
        ctl.close()


NAN, INF = math.nan, math.inf


def _misuse(ctl):
    """(case, function, args) of the calls the state machine or the checks must refuse in
    Step Mode, in order (some move the instance on: Terminate last)."""
    return [
        ("EnterInitializationMode after init", "EnterInitializationMode"),
        (
            "SetupExperiment after init",
            "SetupExperiment",
            0,
            c_double(0),
            c_double(0),
            0,
            c_double(1),
        ),
        ("ExitInitializationMode twice", "ExitInitializationMode"),
        ("DoStep at NaN", "DoStep", c_double(NAN), c_double(H), 1),
        ("DoStep at inf", "DoStep", c_double(INF), c_double(H), 1),
        ("DoStep infinite step", "DoStep", c_double(0.0), c_double(INF), 1),
        ("DoStep NaN step", "DoStep", c_double(0.0), c_double(NAN), 1),
        ("DoStep zero step", "DoStep", c_double(0.0), c_double(0.0), 1),
        ("DoStep back in time", "DoStep", c_double(-H), c_double(H), 1),
        ("DoStep forward in time", "DoStep", c_double(5 * H), c_double(H), 1),
    ]


def _refused(ctl, fn, *args):
    """Error, one log line, nothing changed: else what happened."""
    before = ctl.snapshot()
    del ctl.log[:]
    status = ctl.call(fn, *args)
    log = ctl.log[:]
    if status != ERROR or len(log) != 1 or log[0][0] != ERROR or ctl.snapshot() != before:
        return (status, log)
    return None


def test_the_state_machine_refuses_calls_out_of_order(controller):
    """Each call of the issue's list: fmi2Error, one log line, the state kept."""
    ctl = Controller(controller)
    wrong = {}
    try:
        ctl.set(upper_velocity=0.1, upper_acceleration=1.0)
        ctl.fmu.doStep(0.0, H)
        for case, fn, *args in _misuse(ctl):
            wrong[case] = _refused(ctl, fn, *args)
        assert ctl.call("Terminate") == OK
        for case, fn, *args in [
            ("Terminate twice", "Terminate"),
            ("DoStep after Terminate", "DoStep", c_double(H), c_double(H), 1),
            ("SetReal after Terminate", "SetReal", (c_uint * 1)(0), 1, (c_double * 1)(0.3)),
        ]:
            wrong[case] = _refused(ctl, fn, *args)
    finally:
        ctl.close()
    fresh = Controller(controller, initialize=False)
    try:
        wrong["ExitInitializationMode without Enter"] = _refused(fresh, "ExitInitializationMode")
        nan_start = (0, c_double(0), c_double(NAN), 0, c_double(1))
        wrong["SetupExperiment NaN start"] = _refused(fresh, "SetupExperiment", *nan_start)
        # and the instance still works: a valid start, initialization, a step
        assert fresh.call("SetupExperiment", *nan_start[:2], c_double(0.0), *nan_start[3:]) == OK
        assert fresh.call("EnterInitializationMode") == OK
        assert fresh.call("ExitInitializationMode") == OK
        assert fresh.call("DoStep", c_double(0.0), c_double(H), 1) == OK
    finally:
        fresh.close()
    assert not {k: v for k, v in wrong.items() if v}, wrong


def test_a_force_that_would_overflow_is_refused(controller):
    """A finite input of 1e308 makes a force of -4e311: not finite. The step (the velocity
    carried over it) and the read are refused with fmi2Error and a log line; nothing
    changes, and with a sane input the instance steps on."""
    ctl = Controller(controller)
    try:
        assert ctl.set(upper_velocity=1e308) == OK
        del ctl.log[:]
        assert ctl.call("DoStep", c_double(0.0), c_double(H), 1) == ERROR
        assert len(ctl.log) == 1 and "actuator_force" in ctl.log[0][1], ctl.log
        out = (c_double * 1)()
        del ctl.log[:]
        status = ctl.call("GetReal", (c_uint * 1)(ctl.vr["actuator_force"]), 1, out)
        assert status == ERROR and len(ctl.log) == 1, ctl.log
        assert ctl.set(upper_velocity=0.1) == OK
        assert ctl.call("DoStep", c_double(0.0), c_double(H), 1) == OK
        assert ctl.force()[0] == -C_SKY * 0.1
    finally:
        ctl.close()
