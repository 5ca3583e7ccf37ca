"""pythonfmu FMUs under calls a careful host never makes.

- A refused step (``DoStep(h=1e300)`` with the seat velocity never set) must not move
  the unconnected-velocity bookkeeping: the continuation equals an undisturbed run,
  bit for bit (the slope of a 1e300 s step must not reach the next step's rate).
- An unknown value reference is not fmi2Fatal (pythonfmu 0.7.0 cannot return fmi2Error
  from a slave: the values read NaN, the set is ignored, an error is logged).
- A serialized state carries a checksum: 60 of 60 single-bit flips are refused, the
  instance's state unchanged (JSON alone would accept some flips as changed values).
"""

import math
import random

import numpy as np
import pytest
from test_fmu_integration import Slave

from bodyvib.models import load_model
from bodyvib.runtime.engine import FmuCore
from bodyvib.runtime.errors import BodyvibError

pytestmark = pytest.mark.integration

H = 1e-3
OUT = ("head_acceleration", "head_displacement", "torso_displacement", "seat_force")


def _seat(k):
    t = k * H
    return 0.01 * math.sin(2 * math.pi * 4.0 * t) + 0.004 * math.sin(2 * math.pi * 11.0 * t)


def _core_run(refuse_at=None, steps=300):
    core = FmuCore("body", load_model("reduced-paper"), "B")
    core.setup_experiment(0.0)
    core.initialize()
    vr = {v.name: i for i, v in enumerate(core.variables)}
    outs = [vr[n] for n in OUT]
    y = []
    for k in range(steps):
        core.set_real([vr["seat_displacement"]], [_seat(k)])  # the velocity is never set
        if k == refuse_at:
            with pytest.raises(BodyvibError, match="overflows"):
                core.do_step(k * H, 1e300)
        core.do_step(k * H, H)
        y.append(core.get_real(outs))
    return np.array(y)


def test_refused_step_leaves_the_slope_bookkeeping_of_the_core_as_it_was():
    ref = _core_run()
    for k in (0, 1, 2, 50, 299):
        assert np.array_equal(_core_run(refuse_at=k), ref), k


def _fmu_run(path, refuse_at=None, steps=300):
    from fmpy.fmi1 import FMICallException

    s = Slave(path)
    y = []
    try:
        for k in range(steps):
            s.set(["seat_displacement"], [_seat(k)])
            if k == refuse_at:
                with pytest.raises(FMICallException) as exc:
                    s.fmu.doStep(k * H, 1e300)
                assert exc.value.status == 2  # fmi2Discard
            s.fmu.doStep(k * H, H)
            y.append(s.get(list(OUT)))
    finally:
        s.close()
    return np.array(y)


def test_refused_step_leaves_the_slope_bookkeeping_of_the_fmu_as_it_was(python_fmus):
    ref = _fmu_run(python_fmus["HumanBody3DOF"])
    for k in (1, 120):
        assert np.array_equal(_fmu_run(python_fmus["HumanBody3DOF"], refuse_at=k), ref), k


@pytest.mark.parametrize("bad", [99, 2**31 - 1, 2**32 - 1])
def test_unknown_value_reference_is_an_error_not_fatal(python_fmus, bad):
    s = Slave(python_fmus["HumanBody3DOF"])
    try:
        head = s.vr["head_acceleration"]
        s.fmu.doStep(0.0, H)
        good = s.fmu.getReal([head])[0]
        values = s.fmu.getReal([head, bad])  # returns, does not end the instance
        assert values[0] == good and math.isnan(values[1])
        assert s.messages[-1][0] == 3 and "unknown value reference" in s.messages[-1][1]
        s.fmu.setReal([bad], [1.0])  # ignored, logged
        assert s.messages[-1][0] == 3 and "unknown value reference" in s.messages[-1][1]
        s.fmu.doStep(H, H)  # the instance still steps
        assert math.isfinite(s.fmu.getReal([head])[0])
    finally:
        s.close()


def test_every_single_bit_flip_of_a_serialized_state_is_refused(python_fmus):
    rng = random.Random(20261201)
    s = Slave(python_fmus["HumanBody3DOF"])
    try:
        for k in range(50):
            s.set(["seat_displacement", "seat_velocity"], [_seat(k), 0.3])
            s.fmu.doStep(k * H, H)
        state = s.fmu.getFMUstate()
        data = bytes(s.fmu.serializeFMUstate(state))
        s.fmu.freeFMUstate(state)
        # a good copy restores (the checksum does not refuse what it should accept)
        before = s.get(list(OUT))
        s.fmu.doStep(50 * H, H)
        good = s.fmu.deSerializeFMUstate(data)
        s.fmu.setFMUstate(good)
        s.fmu.freeFMUstate(good)
        assert s.get(list(OUT)) == before
        s.fmu.doStep(50 * H, H)
        after = s.get(list(OUT))
        refused = 0
        for _ in range(60):
            flipped = bytearray(data)
            bit = rng.randrange(len(flipped) * 8)
            flipped[bit // 8] ^= 1 << (bit % 8)
            n = len(s.messages)
            st = s.fmu.deSerializeFMUstate(bytes(flipped))
            s.fmu.setFMUstate(st)
            s.fmu.freeFMUstate(st)
            if any(status == 3 and "refused" in m for status, m in s.messages[n:]):
                refused += 1
            assert s.get(list(OUT)) == after, bit  # the state unchanged
        assert refused == 60
    finally:
        s.close()
