"""The pythonfmu slave of every bodyvib FMU (HumanBody3DOF, HumanBodyISO7962, QuarterCar, Road).

A thin slave: it declares its core's variables and delegates every call to the core
that :data:`bodyvib.runtime.cores.CORES` makes for its ``KIND`` (a network's exact
stepping, :class:`bodyvib.runtime.engine.FmuCore`, or a tabulated signal,
:class:`bodyvib.runtime.tabulated.SourceCore`). ``python build_fmu.py`` (or ``bodyvib build``) renders this one
source per FMU (:func:`bodyvib.fmu.pythonfmu.render_slave_script`): it renames the
class to the FMU's model name, sets ``KIND`` and ``DESCRIPTION``, points
``RUNTIME`` at the FMU's private copy of the run-time modules, and puts the
parameter file at ``resources/bodyvib_model.json``.

Why one rendered script and not a shared base class: pythonfmu 0.7.0 releases
one reference to the slave module's ``__dict__`` per instantiation that it
does not own; the methods defined here hold references to that dictionary and
keep it alive. A script whose class only inherits its methods lost its
dictionary at the second instantiation (measured).

No method raises: pythonfmu 0.7.0 turns any Python exception into fmi2Fatal
and then releases the instance's Python objects twice (once more in
fmi2FreeInstance), which corrupts the host's interpreter. A refused step
(non-finite input, step size not positive) returns False, which pythonfmu
reports as fmi2Discard, with the reason logged at error level; the instance
stays usable. Invalid parameters are refused at fmi2ExitInitializationMode with
the reason logged at error level (pythonfmu gives that call no error status
short of fmi2Fatal), and every later step is refused with the same reason.

A state that is not one of this FMU's (another FMU's, bytes that are no serialized
state, invalid parameters) is refused with the reason logged at error level and the
instance's state unchanged; fmi2SetFMUstate and fmi2DeSerializeFMUstate still return
fmi2OK, for the same reason. Serialized states carry a SHA-256 checksum
(``bodyvib.runtime.statebytes``): changed bytes (a flipped bit, a truncation) are refused.

An unknown value reference (including 2**32 - 1, which pythonfmu 0.7.0 passes through a
C ``int`` as -1) is logged at error level, reads as NaN and is ignored when set; the call
returns fmi2OK, because pythonfmu 0.7.0 maps every Python exception of fmi2GetReal and
fmi2SetReal to fmi2Fatal (``handle_py_exception`` throws ``cppfmu::FatalError``) and has
no other status for them: fmi2Error cannot be returned from the slave. Likewise
``fmi2GetReal(c, NULL, 3, NULL)`` dereferences the NULL arrays inside pythonfmu's C++
wrapper (``PySlaveInstance::GetReal`` reads ``vr[i]`` to build the Python list) before
the slave is called: the host crashes, and nothing in the slave can prevent it.

Each instance registers its FMU binary with ``bodyvib.runtime.teardown``, which releases
pythonfmu's interpreter state when a Python host exits: pythonfmu 0.7.0's own exit-time
teardown writes into freed memory and sometimes aborts the host after its work is done.
"""

import importlib

from pythonfmu import (
    DefaultExperiment,
    Fmi2Causality,
    Fmi2Initial,
    Fmi2Slave,
    Fmi2Variability,
    Real,
)
from pythonfmu.enums import Fmi2Status

RUNTIME = "bodyvib.runtime"  # build_fmu.py: the FMU's private copy of the run-time package
KIND = "body"  # build_fmu.py: "body", "car" or "source"
DESCRIPTION = "bodyvib FMU"  # build_fmu.py: the FMU's one-line description

_cores = importlib.import_module(RUNTIME + ".cores")
_statebytes = importlib.import_module(RUNTIME + ".statebytes")
_teardown = importlib.import_module(RUNTIME + ".teardown")


class BodyvibSlave(Fmi2Slave):  # build_fmu.py: renamed to the FMU's model name
    author = "bodyvib"
    description = DESCRIPTION
    default_experiment = DefaultExperiment(start_time=0.0, stop_time=10.0, step_size=1e-3)

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        _teardown.release_at_exit(self.resources, type(self).__name__)  # pythonfmu 0.7.0 exit bug
        self.core = _cores.load_core(KIND, self.resources, type(self).__name__, log=self._log_core)
        for vr, v in enumerate(self.core.variables):
            var = Real(
                v.name,
                causality=getattr(Fmi2Causality, v.causality),
                variability=getattr(Fmi2Variability, v.variability),
                initial=Fmi2Initial.calculated if v.causality == "output" else None,
                description=v.description,
                start=v.start,
            )
            self.register_variable(var, nested=False)
            assert var.value_reference == vr

    def _log_core(self, message, level):
        self.log(message, getattr(Fmi2Status, level))

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        self.core.setup_experiment(start_time)

    def exit_initialization_mode(self):
        try:
            self.core.initialize()
        except Exception as exc:  # invalid parameter: logged; the instance refuses to step
            self.log(str(exc), Fmi2Status.error)

    def do_step(self, current_time, step_size):
        try:
            self.core.do_step(current_time, step_size)
        except Exception as exc:  # refuse the step, keep the instance alive
            self.log(str(exc), Fmi2Status.error)
            return False
        return True

    def _unknown(self, vrs, what):
        """Value references this FMU does not have, logged at error level (or [])."""
        n = len(self.core.variables)
        if not vrs or (min(vrs) >= 0 and max(vrs) < n):  # the hot path: every call
            return []
        bad = [vr for vr in vrs if not 0 <= vr < n]
        if bad:
            self.log(
                f"{type(self).__name__}: {what}: unknown value reference(s) "
                f"{', '.join(map(str, bad[:5]))} (this FMU has 0 to {n - 1}); "
                "their values are NaN / ignored",
                Fmi2Status.error,
            )
        return bad

    def get_real(self, vrs):
        # pythonfmu passes a value reference through a C int: 2**32 - 1 arrives as -1,
        # which would index the last variable
        if self._unknown(vrs, "fmi2GetReal"):
            n, nan = len(self.core.variables), float("nan")
            known = [vr for vr in vrs if 0 <= vr < n]
            values = dict(zip(known, self.core.get_real(known)))
            return [values.get(vr, nan) if 0 <= vr < n else nan for vr in vrs]
        return self.core.get_real(vrs)

    def set_real(self, vrs, values):
        if self._unknown(vrs, "fmi2SetReal"):
            n = len(self.core.variables)
            pairs = [(vr, v) for vr, v in zip(vrs, values) if 0 <= vr < n]
            vrs, values = [vr for vr, _ in pairs], [v for _, v in pairs]
        self.core.set_real(vrs, values)

    def _get_fmu_state(self):
        return self.core.get_state()

    def _set_fmu_state(self, state):
        if isinstance(state, dict) and set(state) == {"error"}:  # bytes refused at deserializing
            self.log(
                f"{type(self).__name__}: FMU state refused, state unchanged: {state['error']}",
                Fmi2Status.error,
            )
            return
        try:
            self.core.set_state(state)
        except Exception as exc:  # a state of another FMU, or invalid: refused, logged
            self.log(str(exc), Fmi2Status.error)

    @staticmethod
    def _fmu_state_to_bytes(state):
        return _statebytes.pack_state(state)  # with a checksum: a flipped bit is refused

    @staticmethod
    def _fmu_state_from_bytes(state):
        try:
            return _statebytes.unpack_state(state)
        except Exception as exc:  # changed or foreign bytes: _set_fmu_state refuses them
            return {"error": str(exc)}
