"""The co-simulation master: a body FMU on the quarter-car FMU, two-way coupled (fmpy).

Any FMU with the body interface of the FMU contract
(:mod:`bodyvib.runtime.contract`: inputs ``seat_displacement``,
``seat_velocity``; outputs ``head_acceleration``, ``head_displacement``,
``torso_displacement``, ``seat_force``) sits on any FMU with the car interface
(inputs ``road_displacement``, ``road_velocity``, ``seat_force`` and
optionally ``seat_force_rate``; outputs ``seat_displacement``,
``seat_velocity``) that also has the outputs the shipped cars declare in their
parameter files' ``fmu_outputs`` (:data:`bodyvib.vehicle.quarter_car.CAR_FMU_OUTPUTS`:
``sprung_acceleration``, ``suspension_deflection``, ``tire_force``). Both run
in fmpy's ``FMU2Slave`` with a fixed communication step ``h``.

One macro-step from ``t_k`` to ``t_{k+1}`` (Gauss-Seidel, car first):

1. car: road ``z_k`` and its slope ``v_k``; seat force ``F_k`` with the rate
   ``(F_k - F_{k-1}) / h`` (linear extrapolation from the last two
   communication points; a car FMU without ``seat_force_rate`` gets the mean
   of that line over the step, ``F_k + (F_k - F_{k-1}) / 2``, held); ``doStep``;
   read the seat motion ``x_{k+1}``, ``v_{k+1}`` (states: exact right after
   the step). The car's outputs are recorded at ``t_k`` after its inputs of
   ``t_k`` are set, since tire force and seat acceleration are feedthrough.
2. body: seat displacement ``x_k`` with the slope ``(x_{k+1} - x_k) / h``, so
   that its in-step seat motion is the chord between the car's two points and
   ends exactly where the car's seat is; ``doStep``.
3. body: set ``x_{k+1}``, ``v_{k+1}`` (the seat force is feedthrough: it is
   computed on read from these) and read ``F_{k+1}`` and the head outputs.

A plain master that holds ``F_k`` over the step (``extrapolate=False``) is
first order in ``h``; the extrapolation makes the coupling second order. On a
class C road at 20 m/s the head-acceleration NRMSE against the monolithic
reference (:mod:`bodyvib.vehicle.reference`) at h = 1 ms is about 0.43 % held and
0.03 % extrapolated (docs/getting_started.md,
"The master and its coupling error").
"""

import contextlib
import math
import os
import shutil
import tempfile
import time
import zipfile
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from bodyvib.fmu.inspect import check_extracted_fmu
from bodyvib.process import interrupts
from bodyvib.process.outputs import PendingFile
from bodyvib.process.progress import progress_bar
from bodyvib.runtime import contract
from bodyvib.runtime.discretize import check_step
from bodyvib.runtime.errors import BodyvibError

from .quarter_car import CAR_FMU_OUTPUTS
from .road.driven import road_columns
from .signals import (
    BODY_SIGNALS,
    CAR_DEFAULTS,
    CAR_SIGNALS,
    MASTER_SIGNALS,
    OPTIONAL_CAR_SIGNALS,
    OPTIONAL_SIGNALS,
    SIGNALS,
    car_variable,
    car_wheels,
    corner_variable,
    header,
    wheel_columns,
)

__all__ = [
    "check_fmu",
    "BODY_INPUTS",
    "BODY_OUTPUTS",
    "CAR_INPUTS",
    "CAR_OUTPUTS",
    "MASTER_SIGNALS",
    "Master",
    "Slave",
    "open_fmu",
    "road_pairs",
    "actuator_pairs",
    "controller_suffixes",
    "FmuController",
    "open_controller",
    "model_from_fmu",
    "cosimulate",
    "write_csv",
    "CsvStream",
]

#: What the master sets and reads (names from the FMU contract): of the body's, the
#: seat motion and the first four outputs; of the car's, ``seat_force_rate`` is
#: optional (used if present).
BODY_INPUTS = contract.BODY_INPUTS[:2]  # seat_acceleration: optional, left at 0 (linear seat)
BODY_OUTPUTS = contract.BODY_OUTPUTS[:4]  # seat_force_rate: not read by this master
CAR_INPUTS = contract.CAR_INPUTS[:3]
_SEAT_FORCE_RATE = contract.CAR_INPUTS[3]
CAR_OUTPUTS = contract.CAR_OUTPUTS + CAR_FMU_OUTPUTS
#: A controller FMU's variables per actuator (suffix ``_<name>`` as the car's).
CONTROLLER_INPUTS = ("upper_velocity", "lower_velocity")
CONTROLLER_OUTPUTS = ("actuator_force",)
_INTERFACES = {
    "body": (BODY_INPUTS, BODY_OUTPUTS),
    "car": (CAR_INPUTS, CAR_OUTPUTS),
    "controller": (CONTROLLER_INPUTS, CONTROLLER_OUTPUTS),
}


class Slave:
    """An FMI 2.0 co-simulation FMU instantiated in fmpy, with its variables by name.

    Use :func:`open_fmu` (a context manager that also cleans up).

    Attributes
    ----------
    fmu : fmpy.fmi2.FMU2Slave
    vr : dict of str to int
        Value reference of each variable.
    path : str
    """

    def __init__(self, fmu, vr, path, unzipdir):
        self.fmu = fmu
        self.vr = vr
        self.path = path
        self._unzipdir = unzipdir

    def close(self):
        """Terminate and free the instance, delete the extracted files."""
        try:
            self.fmu.terminate()
        finally:
            self.fmu.freeInstance()
            shutil.rmtree(self._unzipdir, ignore_errors=True)


#: Where each kind of FMU goes (:func:`bodyvib.vehicle.study.run_study`'s parameters).
_PARAMETERS = {"body": "body_fmus", "car": "car_fmu", "controller": "controller"}


def _missing(md, kind):
    inputs, outputs = _INTERFACES[kind]
    have = {v.name: v.causality for v in md.modelVariables}
    if kind == "controller":  # per actuator force output, its two velocity inputs
        suffixes = controller_suffixes(have) or [""]
        inputs = [f"{n}{s}" for s in suffixes for n in inputs]
        outputs = [f"{n}{s}" for s in suffixes for n in outputs]
    if kind == "car" and road_pairs(have):  # a car driven at several road points
        inputs = [n for pair in road_pairs(have) for n in pair] + list(inputs[2:])
        outputs = [corner_variable(n, have) for n in outputs]
    return [n for n in inputs if have.get(n) != "input"] + [
        n for n in outputs if have.get(n) != "output"
    ]


def road_pairs(variables):
    """The road inputs of a car FMU, as (displacement, velocity) pairs in declaration order.

    Parameters
    ----------
    variables : iterable of str
        The FMU's variable names, in value-reference order.

    Returns
    -------
    list of (str, str)
        ``[("road_displacement", "road_velocity")]`` for a quarter car; a pair per
        axle (``road_displacement_front``, ``road_velocity_front``, then the rear) for
        a half car (:func:`bodyvib.runtime.contract.road_inputs`).

    Examples
    --------
    >>> road_pairs(["road_displacement_front", "road_velocity_front", "seat_force"])
    [('road_displacement_front', 'road_velocity_front')]
    """
    names = list(variables)
    return [
        (n, "road_velocity" + n[len("road_displacement") :])
        for n in names
        if n == "road_displacement" or n.startswith("road_displacement_")
    ]


def actuator_pairs(variables, path="car FMU"):
    """The actuator variables of a car FMU, by name: force, rate, upper and lower velocity.

    Parameters
    ----------
    variables : collection of str
        The car FMU's variable names.
    path : str
        The FMU, for the message.

    Returns
    -------
    list of (str, str, str, str)
        ``actuator_force<sfx>``, ``actuator_force_rate<sfx>``,
        ``actuator_upper_velocity<sfx>``, ``actuator_lower_velocity<sfx>`` per actuator
        (see :mod:`bodyvib.runtime.contract`).

    Raises
    ------
    BodyvibError
        No actuator, or an actuator force without its rate input or velocity outputs.

    Examples
    --------
    >>> actuator_pairs(["actuator_force", "actuator_force_rate", "actuator_upper_velocity",
    ...                 "actuator_lower_velocity"])
    [('actuator_force', 'actuator_force_rate', 'actuator_upper_velocity', 'actuator_lower_velocity')]
    """
    out = []
    for name in variables:
        if not name.startswith("actuator_force") or name.startswith("actuator_force_rate"):
            continue
        sfx = name[len("actuator_force") :]
        names = (name, f"actuator_force_rate{sfx}")
        names += (f"actuator_upper_velocity{sfx}", f"actuator_lower_velocity{sfx}")
        missing = [n for n in names if n not in variables]
        if missing:
            raise BodyvibError(
                f"{path}: actuator input {name} comes without {', '.join(missing)}; "
                "a controller needs them (build the car from a file with 'actuators')"
            )
        out.append(names)
    if not out:
        raise BodyvibError(
            f"{path} has no actuator inputs (actuator_force): a controller needs a car "
            "built from a file with 'actuators' (car=quarter-car-active, half-car-active or "
            "full-car-active)",
            parameters=("car",),
        )
    return out


def controller_suffixes(variables):
    """The actuator suffixes a controller FMU drives: those of its ``actuator_force`` outputs.

    Parameters
    ----------
    variables : dict of str to str
        Variable name -> causality.

    Returns
    -------
    list of str
        ``[""]`` for ``actuator_force``, ``["_front", "_rear"]`` for a half car's.

    Examples
    --------
    >>> controller_suffixes({"actuator_force_front": "output", "upper_velocity_front": "input"})
    ['_front']
    """
    return [
        n[len("actuator_force") :]
        for n, causality in variables.items()
        if n.startswith("actuator_force")
        and not n.startswith("actuator_force_rate")
        and causality == "output"
    ]


class FmuController:
    """A controller FMU in the master's loop: actuator forces from the car's velocities.

    Use :func:`open_controller`, which checks it against the car.

    Parameters
    ----------
    slave : Slave
        The initialized controller FMU.
    suffixes : sequence of str
        The car's actuator suffixes, in the car's order.
    """

    linear = False  # what the FMU computes is its own: no closed-loop reference from it

    def __init__(self, slave: Slave, suffixes):
        self.slave = slave
        self._in = [slave.vr[f"{n}{s}"] for s in suffixes for n in CONTROLLER_INPUTS]
        self._out = [slave.vr[f"actuator_force{s}"] for s in suffixes]

    def forces(self, velocities):
        """Set the velocities (upper, lower per actuator), read the forces (feedthrough)."""
        self.slave.fmu.setReal(self._in, list(velocities))
        return list(self.slave.fmu.getReal(self._out))

    def advance(self, t: float, step: float) -> None:
        """Step the FMU with the master (a stateless law ignores it)."""
        self.slave.fmu.doStep(t, step)


@contextlib.contextmanager
def open_controller(path, car: "Slave"):
    """Instantiate a controller FMU for a car FMU: refused in one line if it does not fit.

    Parameters
    ----------
    path : str
        ``.fmu`` file: FMI 2.0 co-simulation with, per actuator of the car,
        inputs ``upper_velocity<sfx>``, ``lower_velocity<sfx>`` and the output
        ``actuator_force<sfx>`` (``SkyhookController.fmu``).
    car : Slave
        The car FMU it drives.

    Yields
    ------
    FmuController

    Raises
    ------
    BodyvibError
        Not FMI 2.0 co-simulation (a Model Exchange only FMU), missing variables, or
        actuators other than the car's.
    """
    wanted = [a[0][len("actuator_force") :] for a in actuator_pairs(car.vr, car.path)]
    with open_fmu(path, "controller", "controller") as slave:
        have = controller_suffixes(
            {n: ("output" if n.startswith("actuator_force") else "input") for n in slave.vr}
        )
        if sorted(have) != sorted(wanted):
            raise BodyvibError(
                f"controller FMU '{path}' drives the actuator force(s) "
                f"{', '.join('actuator_force' + s for s in have)}; the car has "
                f"{', '.join('actuator_force' + s for s in wanted)}: build it for this car"
            )
        yield FmuController(slave, wanted)


def _check_interface(md, path, kind):
    inputs, outputs = _INTERFACES[kind]
    missing = _missing(md, kind)
    if missing:
        other = [k for k in _INTERFACES if k != kind and not _missing(md, k)]
        what = (
            f"it is a {other[0]} FMU (give it to '{_PARAMETERS[other[0]]}')"
            if other
            else f"no {', '.join(missing)}"
        )
        raise BodyvibError(
            f"FMU '{path}' lacks the {kind} interface: {what}; a {kind} FMU "
            f"needs inputs {', '.join(inputs)} and outputs {', '.join(outputs)} (the FMU contract: docs/tutorials/fmu_hosts.md)",
            parameters=[_PARAMETERS[k] for k in other[:1]],
        )


def _model_description(path, kind):
    """The model description of an existing ``.fmu`` file of the ``kind`` interface.

    What :func:`check_fmu` and :func:`open_fmu` both read first: a file fmpy cannot
    read, another FMI version than 2.0, no co-simulation or a missing interface
    variable is refused.
    """
    from fmpy import read_model_description

    try:
        md = read_model_description(path)
    except Exception as exc:
        raise BodyvibError(f"'{path}' is not a readable FMU: {exc}") from None
    if md.fmiVersion != "2.0":
        raise BodyvibError(f"FMU '{path}' is FMI {md.fmiVersion}; FMI 2.0 is needed")
    _check_interface(md, path, kind)
    if md.coSimulation is None:
        raise BodyvibError(
            f"FMU '{path}' is not a co-simulation FMU (Model Exchange only); FMI 2.0 "
            "co-simulation is needed"
        )
    return md


def check_fmu(path, kind: str) -> None:
    """Refuse an FMU that is not an FMI 2.0 co-simulation FMU of ``kind``, without running it.

    Reads only the model description: a body FMU given as the car (``cosim --car-fmu
    HumanBody3DOF.fmu``) is named for what it is before anything is built or run.

    Parameters
    ----------
    path : str
        ``.fmu`` file.
    kind : str
        ``"body"`` or ``"car"``.

    Raises
    ------
    BodyvibError
        Missing or unreadable file, another FMI version, missing interface variables
        (naming the interface the FMU has, if it has the other one).
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise BodyvibError(f"FMU file '{path}' does not exist")
    _model_description(path, kind)


@contextlib.contextmanager
def open_fmu(
    path,
    kind: str,
    instance_name: Optional[str] = None,
    start_values: Optional[Dict[str, float]] = None,
):
    """Instantiate and initialize an FMU of the body or car interface.

    Parameters
    ----------
    path : str
        ``.fmu`` file.
    kind : str
        ``"body"`` or ``"car"``: the interface it must have.
    instance_name : str, optional
    start_values : dict of str to float, optional
        Real variables (e.g. the FMU's parameters) set after instantiation,
        before initialization: a sweep changes parameters this way without
        rebuilding the FMU.

    Yields
    ------
    Slave

    Raises
    ------
    BodyvibError
        Missing file, not an FMI 2.0 co-simulation FMU, missing interface
        variables, an unknown start variable, no binary for this platform, a
        pythonfmu FMU without its resources, or a failure to instantiate or initialize.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise BodyvibError(f"FMU file '{path}' does not exist")
    # from instantiation to freeInstance, a second Ctrl-C stays deferred too: a
    # KeyboardInterrupt inside the FMU's Python code is fmi2Fatal and a double free
    with interrupts.critical():
        with _instantiated(path, kind, instance_name, start_values) as slave:
            yield slave


@contextlib.contextmanager
def _instantiated(path, kind, instance_name, start_values=None):
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave

    md = _model_description(path, kind)
    refs = {v.name: v.valueReference for v in md.modelVariables}
    unknown = sorted(set(start_values or {}) - set(refs))
    if unknown:
        raise BodyvibError(f"FMU '{path}' has no variable(s) {', '.join(unknown)}")
    unzipdir = extract(path, unzipdir=tempfile.mkdtemp(prefix="bodyvib-fmu-"))
    fmu = None
    try:
        check_extracted_fmu(unzipdir, md, path)
        fmu = FMU2Slave(
            guid=md.guid,
            unzipDirectory=unzipdir,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=instance_name or kind,
        )
        fmu.instantiate()
        if start_values:
            names = list(start_values)
            fmu.setReal([refs[n] for n in names], [float(start_values[n]) for n in names])
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
    except BaseException as exc:
        if fmu is not None:
            with contextlib.suppress(Exception):
                fmu.freeInstance()
        shutil.rmtree(unzipdir, ignore_errors=True)
        if isinstance(exc, BodyvibError) or not isinstance(exc, Exception):
            raise
        raise BodyvibError(f"FMU '{path}' failed to initialize: {exc}") from None
    slave = Slave(fmu, {v.name: v.valueReference for v in md.modelVariables}, path, unzipdir)
    try:
        yield slave
    finally:
        slave.close()


def model_from_fmu(path):
    """The parameter file a bodyvib FMU carries (``resources/bodyvib_model.json``).

    Parameters
    ----------
    path : str
        A ``.fmu`` built by ``build_fmu.py``.

    Returns
    -------
    Network or None
        The model baked into the FMU, or None for an FMU that carries none
        (a foreign FMU: it still co-simulates, but has no monolithic reference).
    """
    import json

    from bodyvib.runtime.modelfile import network_from_dict

    try:
        with zipfile.ZipFile(path) as z:
            data = json.loads(z.read("resources/bodyvib_model.json"))
    except (KeyError, zipfile.BadZipFile, ValueError, OSError):
        return None
    return network_from_dict(data, source=f"{path}:resources/bodyvib_model.json")


class Master:
    """The two-way coupled master, advanced block by block (memory independent of the run).

    One macro-step per road sample, as in the module docstring. :meth:`advance` takes
    the next road samples and returns the signals at those communication points; the
    state between blocks is the master's few numbers and the FMUs' own, so a run of any
    length is the same whatever the block sizes (bit for bit).

    Parameters
    ----------
    car, body : Slave
        Initialized FMUs (:func:`open_fmu`), at rest.
    step : float
        Communication step h, s.
    samples : int
        Communication points of the whole run, ``n``: the last one records the car's
        outputs without a step.
    extrapolate : bool
        Extrapolate the seat force linearly over each step (default); False holds it.
    controller : SkyhookController or FmuController, optional
        Drive the car's actuators (inputs ``actuator_force*``): before each step the
        law's force ``F_k`` from the actuator velocities at ``t_k`` (states, exact after
        the previous step), with the in-step slope ``(2 F_k - 3 F_{k-1} + F_{k-2}) / h``:
        the chord to the quadratic extrapolation of the last three forces (a backward
        difference, the seat force's slope, nearly doubles the skyhook run's coupling error).
    watch : sequence of str
        More car outputs to record, after the wheels' columns (those the car has and the
        columns lack): a linear car's per-wheel tire forces and deflections for its range
        (:class:`bodyvib.vehicle.events.LinearRangeStream`).

    Attributes
    ----------
    k : int
        Communication points recorded so far.
    wall_s : float
        Wall time spent in :meth:`advance`, s.

    Raises
    ------
    BodyvibError
        A step that is not a positive number, fewer than two samples, or a controller
        for a car FMU without actuators.
    """

    def __init__(
        self,
        car: Slave,
        body: Slave,
        step: float,
        samples: int,
        extrapolate: bool = True,
        controller=None,
        watch: Sequence[str] = (),
    ):
        check_step(step, "communication step")
        if int(samples) < 2:
            raise BodyvibError("a co-simulation needs at least 2 communication points")
        self.h = float(step)
        self.n = int(samples)
        self.extrapolate = bool(extrapolate)
        self.k = 0
        self.wall_s = 0.0
        self._car, self._body = car, body
        self._has_rate = "seat_force_rate" in car.vr
        roads = road_pairs(car.vr)
        self.roads = len(roads)
        self._car_in = (
            [car.vr[n] for pair in roads for n in pair]
            + [car.vr["seat_force"]]
            + ([car.vr["seat_force_rate"]] if self._has_rate else [])
        )
        # what is recorded, in the signal table's order (seat motion first: read after a step);
        # a signal the car lacks is recorded as its default (a linear car's contact flag)
        # or NaN (the seat's horizontal accelerations of a car whose body does not roll)
        names = [s.name for s in CAR_SIGNALS]
        has = [car_variable(s, car.vr) in car.vr for s in CAR_SIGNALS]
        lacks = [n for n, h in zip(names, has) if not h]
        if set(lacks) - set(CAR_DEFAULTS) - set(OPTIONAL_CAR_SIGNALS):
            raise BodyvibError(f"car FMU has no output(s) {', '.join(lacks)}")
        self._car_out = [car.vr[car_variable(s, car.vr)] for s, h in zip(CAR_SIGNALS, has) if h]
        self._car_pad = [CAR_DEFAULTS.get(n, math.nan) for n in lacks]
        # a car with several wheels whose tires are contacts: each wheel's signals too
        self.wheels = car_wheels(car.vr)
        extra = list(wheel_columns(self.wheels))
        extra += [c for c in dict.fromkeys(watch) if c in car.vr and c not in names + extra]
        self._car_out += [car.vr[c] for c in extra]
        # read: the present signals, the wheels', then the pads and the body's; recorded:
        # the table's order, then the wheels'
        body_cols = list(MASTER_SIGNALS[len(names) :])
        read = [n for n, h in zip(names, has) if h] + extra + lacks + body_cols
        #: the recorded columns, in order: the master signals and the wheels'
        self.columns: Tuple[str, ...] = MASTER_SIGNALS + tuple(extra)
        self._perm = None if read == list(self.columns) else [read.index(n) for n in self.columns]
        self._control = controller
        self._act_vel, self._act_F = [], ([], [])
        if controller is not None:
            acts = actuator_pairs(car.vr, car.path)
            self._car_in += [car.vr[n] for force, rate, _, _ in acts for n in (force, rate)]
            self._act_vel = [car.vr[n] for _, _, up, low in acts for n in (up, low)]
            self._act_F = ([0.0] * len(acts),) * 2  # the car at rest: no force
            self._act_v = [0.0] * (2 * len(acts))
        self._body_in = [body.vr[k] for k in BODY_INPUTS]
        # F, a1, x1, x2, then the named forces the FMU has (the others are recorded as NaN)
        self._body_out = [body.vr[s.variable] for s in BODY_SIGNALS if s.variable in body.vr]
        missing = [s.name for s in BODY_SIGNALS if s.variable not in body.vr]
        if set(missing) - set(OPTIONAL_SIGNALS):
            raise BodyvibError(f"body FMU has no output(s) {', '.join(missing)}")
        self._pad = [math.nan] * len(missing)
        body.fmu.setReal(self._body_in, [0.0, 0.0])  # the body at rest at t = 0
        self._B = list(body.fmu.getReal(self._body_out)) + self._pad
        self._F_prev = self._B[0]

    def _actuator_forces(self):
        """The controller's force per actuator from the velocities read last."""
        return self._control.forces(self._act_v)

    def _road(self, road_displacement, road_velocity) -> np.ndarray:
        """The car's road inputs at the next points: displacement and velocity of each pair."""
        nr = self.roads
        z, v = road_columns(road_displacement, road_velocity, nr)
        m = z.shape[0]
        if self.k + m > self.n:
            raise BodyvibError(f"the run has {self.n} communication points; {self.k + m} given")
        road = np.empty((m, 2 * nr))
        road[:, 0::2], road[:, 1::2] = z, v
        return road

    def advance(self, road_displacement, road_velocity) -> np.ndarray:
        """Co-simulate the next communication points.

        Parameters
        ----------
        road_displacement, road_velocity : (m,) or (m, wheels) array_like
            Road input at the next ``m`` communication points (m, m/s); a car with
            several road points (a half car) takes a column per point, in the order of
            its road inputs (:func:`road_pairs`).

        Returns
        -------
        (m, len(columns)) ndarray
            The :data:`bodyvib.vehicle.signals.MASTER_SIGNALS` at those points (the car's, then
            the body's), then a car's per-wheel signals (its ``columns``)

        Raises
        ------
        BodyvibError
            Non-finite road, more samples than the run has, or an FMU refusing a step.
        KeyboardInterrupt
            Ctrl-C (:mod:`bodyvib.process.interrupts`), taken between macro-steps.
        """
        road = self._road(road_displacement, road_velocity)
        m = road.shape[0]
        t0 = time.perf_counter()
        rows = [None] * m
        h, last, extrapolate, has_rate = self.h, self.n - 1, self.extrapolate, self._has_rate
        cf, bf = self._car.fmu, self._body.fmu
        car_in, car_out, body_in, body_out = (
            self._car_in,
            self._car_out,
            self._body_in,
            self._body_out,
        )
        car_motion = car_out[:2]
        c_set, c_get, c_step = cf.setReal, cf.getReal, cf.doStep
        b_set, b_get, b_step = bf.setReal, bf.getReal, bf.doStep
        B, F_prev, pad, car_pad = self._B, self._F_prev, self._pad, self._car_pad
        law, act_vel, (Fa, Fa_prev) = self._control, self._act_vel, self._act_F
        act = []  # the actuators' inputs: force and rate of each
        law_step = getattr(law, "advance", None)  # a controller FMU steps with the car
        F = B[0]
        k = self.k
        try:
            for j, rk in enumerate(road.tolist()):
                k = self.k + j
                if law is not None:
                    Fa, Fa_prev, Fa_prev2 = self._actuator_forces(), Fa, Fa_prev
                    act = [
                        x
                        for f, f1, f2 in zip(Fa, Fa_prev, Fa_prev2)
                        for x in (f, (2.0 * f - 3.0 * f1 + f2) / h)
                    ]
                if k == last:  # the last point: the car's outputs, no step
                    c_set(car_in, rk + [F] + ([0.0] if has_rate else []) + act)
                    rows[j] = list(c_get(car_out)) + car_pad + B
                    break
                t = k * h
                dF = (F - F_prev) if extrapolate else 0.0
                if has_rate:
                    c_set(car_in, rk + [F, dF / h] + act)
                else:
                    c_set(car_in, rk + [F + 0.5 * dF])
                # car outputs at t_k with the inputs of t_k (tire force and seat
                # acceleration are feedthrough of road and seat force)
                car_now = list(c_get(car_out))
                xs = car_now[0]
                rows[j] = car_now + car_pad + B
                c_step(t, h)
                xn, vn = c_get(car_motion)  # states only: exact right after the step
                if law is not None:
                    self._act_v = c_get(act_vel)  # states too: the velocities at t_k+1
                    if law_step is not None:
                        law_step(t, h)
                b_set(body_in, [xs, (xn - xs) / h])
                b_step(t, h)
                b_set(body_in, [xn, vn])
                F_prev = F
                B = list(b_get(body_out)) + pad
                F = B[0]
                if interrupts.requested():  # a safe point, every step: no FMU call runs
                    interrupts.check()  # raises: the signal is taken here
        except BodyvibError:
            raise
        except Exception as exc:
            raise BodyvibError(f"co-simulation stopped at t = {k * h:g} s: {exc}") from None
        finally:
            self.wall_s += time.perf_counter() - t0
        self._B, self._F_prev, self._act_F = B, F_prev, (Fa, Fa_prev)
        self.k += m
        out = np.array(rows, dtype=float).reshape(m, len(self.columns))
        return out if self._perm is None else out[:, self._perm]


def cosimulate(
    car: Slave,
    body: Slave,
    road_displacement,
    road_velocity,
    step: float,
    extrapolate: bool = True,
    progress: bool = False,
    block: int = 4096,
    controller=None,
) -> Dict[str, np.ndarray]:
    """Run the two-way coupled co-simulation over a sampled road, keeping every signal.

    :class:`Master` over the whole record; :func:`bodyvib.vehicle.study.run_study` uses the
    master block by block without keeping the histories.

    Parameters
    ----------
    car, body : Slave
        Initialized FMUs (:func:`open_fmu`), at rest.
    road_displacement, road_velocity : (n,) or (n, wheels) array_like
        Road input at ``t_k = k * step``, m and m/s (a column per road input pair of
        the car; the result's road columns are the first pair's).
    step : float
        Communication step h, s.
    extrapolate : bool
        Extrapolate the seat force linearly over each step (default); False
        holds it (the plain master, first order).
    progress : bool
        Show a tqdm progress bar on stderr (hidden when stderr is not a terminal).
    block : int
        Communication points per :meth:`Master.advance` call.
    controller : bodyvib.vehicle.control.SkyhookController, optional
        Drive the car's actuators (:class:`Master`).

    Returns
    -------
    dict of str to ndarray
        The signals of :data:`bodyvib.vehicle.signals.SIGNALS` at the ``n``
        communication points (``seat_acceleration`` is the car's
        ``sprung_acceleration`` output: the seat point's acceleration).

    Raises
    ------
    BodyvibError
        Bad step, non-finite road, or an FMU refusing a step.
    """
    z = np.asarray(road_displacement, dtype=float)
    v = np.asarray(road_velocity, dtype=float)
    check_step(step, "communication step")
    if z.shape != v.shape or z.ndim not in (1, 2) or z.shape[0] < 2:
        raise BodyvibError(
            "road displacement and velocity must be arrays of equal length (and shape), >= 2 samples"
        )
    n = z.shape[0]
    master = Master(car, body, step, n, extrapolate, controller)
    bar = progress_bar(n - 1, progress, "co-simulation")
    parts = []
    try:
        for a in range(0, n, block):
            parts.append(master.advance(z[a : a + block], v[a : a + block]))
            if bar is not None:
                bar.update(min(block, n - 1 - a))
    finally:
        if bar is not None:
            bar.close()
    out = np.concatenate(parts)
    front = (z, v) if z.ndim == 1 else (z[:, 0], v[:, 0])
    signals = {"time": np.arange(n) * master.h, "road_displacement": front[0]}
    signals["road_velocity"] = front[1]
    signals.update(zip(master.columns, out.T))
    return {s.name: signals[s.name] for s in SIGNALS}


class CsvStream:
    """Time histories written to CSV block by block (header ``name [unit]``), placed at the end.

    The rows go to a temporary file beside ``path`` (:class:`bodyvib.process.outputs.PendingFile`),
    so a run of any length keeps no history in memory; :meth:`place` puts the file at
    ``path`` (with the other outputs, inside :func:`bodyvib.process.outputs.staged_writes`);
    an error or Ctrl-C before that leaves ``path`` as it was.

    Parameters
    ----------
    path : str
        The CSV file; left as it was until :meth:`place`.
    """

    def __init__(self, path):
        self._file = PendingFile(path)
        self.names = None

    def write(self, columns: Dict[str, np.ndarray]) -> None:
        """Append rows.

        Parameters
        ----------
        columns : dict of str to ndarray
            Equal-length columns by name; the same names, in the same order, every block
            (the first block writes the header).

        Raises
        ------
        BodyvibError
            Other column names than the first block's.
        """
        names = list(columns)
        if self.names is None:
            self.names = names
            self._file.file.write(",".join(header(k) for k in names) + "\n")
        elif names != self.names:
            raise BodyvibError("CSV columns changed between blocks")
        cols = np.column_stack([np.asarray(columns[k], dtype=float) for k in names])
        self._file.file.write(
            "".join(",".join(f"{x:.10g}" for x in row) + "\n" for row in cols.tolist())
        )

    def place(self) -> None:
        """Put the file at its path (or stage it)."""
        self._file.place()

    def discard(self) -> None:
        """Delete the unfinished file."""
        self._file.discard()


def write_csv(path, result: Dict[str, np.ndarray]) -> None:
    """Write a run as CSV (header ``name [unit]``), atomically.

    Parameters
    ----------
    path : str
        The CSV file, replaced whole or left as it was.
    result : dict of str to ndarray
        Equal-length columns (:func:`cosimulate`, :func:`bodyvib.vehicle.reference.reference_run`).
    """
    out = CsvStream(path)
    try:
        out.write(result)
        out.place()
    except BaseException:
        out.discard()
        raise
