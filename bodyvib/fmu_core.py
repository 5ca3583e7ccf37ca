"""The run-time core of the bodyvib FMUs: interface, state, exact stepping, state snapshots.

Every FMU of this project (``HumanBody3DOF``, ``HumanBodyISO7962``, ``QuarterCar``)
is a thin pythonfmu slave that declares the variables listed here and delegates
everything else to one :class:`FmuCore`. The core holds no equation of its own:
the matrices come from :func:`bodyvib.network.linear_model` and the step
matrices from :class:`bodyvib.discretize.Discretization` (DESIGN.md sections 6-7).

Interfaces (SI units; ``vr`` = value reference = position in :attr:`FmuCore.variables`):

* body (``kind="body"``): inputs ``seat_displacement`` [m], ``seat_velocity``
  [m/s]; outputs ``head_acceleration`` [m/s2] (absolute), ``head_displacement``
  [m], ``torso_displacement`` [m], ``seat_force`` [N] (force the body exerts on
  the seat, positive in compression); parameters: the model's named parameters.
* car (``kind="car"``): inputs ``road_displacement`` [m], ``road_velocity``
  [m/s], ``seat_force`` [N] (the occupant's, positive in compression: it enters
  the car's ``<seat>.force`` input as ``-seat_force``), ``seat_force_rate``
  [N/s] (optional, start 0: slope of ``seat_force`` over the coming step; 0 =
  hold); outputs ``seat_displacement`` [m] and ``seat_velocity`` [m/s] (the
  point with role ``seat``), ``sprung_acceleration`` [m/s2] (its absolute
  acceleration), ``suspension_deflection`` [m] (output
  ``suspension.deflection``: sprung minus unsprung displacement, positive in
  extension), ``tire_force`` [N] (output ``tire.force``: positive in
  compression); parameters: the car's named parameters.

Stepping: over a communication step ``h`` each input is extrapolated linearly
from its value and its rate (a displacement rises at its velocity input, the
seat force at ``seat_force_rate``, every other input is held), and the state is
advanced exactly: ``x <- Phi x + Gamma0 u + Gamma1 du``. At the end of the step
the inputs are set to their extrapolated values, so outputs read right after
``do_step`` (before the host sets new inputs) are those of the step's end;
outputs are ``C x + D u`` computed when read, so feedthrough outputs follow a
newly set input at once.

Numpy only, relative imports only: the FMUs ship this module under a private
package name (``build_fmu.py``).
"""

import math
from dataclasses import dataclass
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np

from .discretize import Discretization
from .errors import BodyvibError
from .network import Network, linear_model

__all__ = ["Variable", "Interface", "body_interface", "car_interface", "FmuCore", "KINDS",
           "MODEL_FILE", "PARAMETER_UNITS", "POSITIVE_MIN"]

#: Where the build puts the parameter file, inside the FMU's resources.
MODEL_FILE = "bodyvib_model.json"

#: Unit of a network parameter by the element field (or mass) that uses it.
PARAMETER_UNITS = {"mass": "kg", "k": "N/m", "k_series": "N/m", "c": "N.s/m"}

#: Smallest positive normal double: the ``min`` written for strictly positive
#: parameters (FMI's ``min`` is inclusive, so ``0`` would admit a zero mass).
POSITIVE_MIN = 2.2250738585072014e-308


@dataclass(frozen=True)
class Variable:
    """One FMU variable.

    Attributes
    ----------
    name : str
    causality : str
        ``"input"``, ``"output"`` or ``"parameter"``.
    variability : str
        ``"continuous"`` (inputs, outputs) or ``"fixed"`` (parameters).
    unit : str
        SI unit (``m``, ``m/s``, ``m/s2``, ``N``, ``N/s``, ``kg``, ``N/m``, ``N.s/m``).
    description : str
    start : float or None
        Start value (inputs and parameters; outputs are calculated).
    min, max : float or None
        Physical bounds, if any.
    """

    name: str
    causality: str
    variability: str
    unit: str
    description: str
    start: Optional[float] = None
    min: Optional[float] = None
    max: Optional[float] = None


@dataclass(frozen=True)
class Interface:
    """How an FMU's inputs and outputs map onto a network's state space.

    Attributes
    ----------
    kind : str
        ``"body"`` or ``"car"``.
    inputs : tuple of Variable
    outputs : tuple of Variable
    input_map : (m, ni) ndarray
        Model inputs ``u = input_map @ s`` from the FMU inputs ``s``.
    rate_pairs : tuple of (int, int)
        ``(i, j)``: FMU input ``i`` rises at FMU input ``j`` over a step; every
        other input is held.
    output_signals : tuple of str
        Model output (or role) name of each FMU output, for
        :meth:`bodyvib.network.LinearModel.output_index`.
    """

    kind: str
    inputs: Tuple[Variable, ...]
    outputs: Tuple[Variable, ...]
    input_map: np.ndarray
    rate_pairs: Tuple[Tuple[int, int], ...]
    output_signals: Tuple[str, ...]

    def rate_matrix(self) -> np.ndarray:
        """``R`` with ``ds/dt = R s`` over a step (FMU input space)."""
        n = len(self.inputs)
        R = np.zeros((n, n))
        for i, j in self.rate_pairs:
            R[i, j] = 1.0
        return R


def _input(name, unit, description):
    return Variable(name, "input", "continuous", unit, description, start=0.0)


def _output(name, unit, description):
    return Variable(name, "output", "continuous", unit, description)


def body_interface(network: Network) -> Interface:
    """The interface of a human-body FMU (DESIGN.md section 7).

    Parameters
    ----------
    network : Network
        A body model: base ``seat``, roles ``head`` and ``torso``.

    Returns
    -------
    Interface

    Raises
    ------
    BodyvibError
        If the model lacks a ``head`` or ``torso`` role.
    """
    for role in ("head", "torso"):
        if role not in network.roles:
            raise BodyvibError(
                f"model '{network.name}' has no '{role}' role; a body FMU needs roles "
                "head and torso (add them to the parameter file's 'roles')"
            )
    base = network.base
    inputs = (
        _input("seat_displacement", "m", "Seat vertical displacement xr (z up, about static equilibrium)"),
        _input("seat_velocity", "m/s", "Seat vertical velocity; also the slope of "
               "seat_displacement over the coming step (in-step extrapolation)"),
    )
    outputs = (
        _output("head_acceleration", "m/s2", f"Head ({network.point('head')}) absolute vertical acceleration"),
        _output("head_displacement", "m", f"Head ({network.point('head')}) vertical displacement"),
        _output("torso_displacement", "m", f"Torso ({network.point('torso')}) vertical displacement"),
        _output("seat_force", "N", "Force the body exerts on the seat, positive in compression "
                "(body pushing down); perturbation about the static load"),
    )
    return Interface(
        kind="body", inputs=inputs, outputs=outputs,
        input_map=np.eye(2),
        rate_pairs=((0, 1),),
        output_signals=("head.a", "head.x", "torso.x", f"{base}_force"),
    )


def car_interface(network: Network) -> Interface:
    """The interface of the quarter-car FMU (DESIGN.md section 7).

    Parameters
    ----------
    network : Network
        A vehicle model: a ``seat`` role naming a mass in ``force_inputs``,
        elements named ``suspension`` and ``tire``.

    Returns
    -------
    Interface

    Raises
    ------
    BodyvibError
        If the model lacks the seat role, its force input, or the elements.
    """
    seat = network.roles.get("seat")
    if seat is None or seat not in network.force_inputs:
        raise BodyvibError(
            f"vehicle model '{network.name}' needs a 'seat' role naming a mass listed in "
            "force_inputs (the occupant's seat force acts there)"
        )
    names = {el.name for el in network.elements}
    missing = [e for e in ("suspension", "tire") if e not in names]
    if missing:
        raise BodyvibError(
            f"vehicle model '{network.name}' has no element(s) {', '.join(missing)}; the "
            "QuarterCar FMU reports suspension.deflection and tire.force"
        )
    base = network.base
    inputs = (
        _input("road_displacement", "m", "Road profile height under the tire"),
        _input("road_velocity", "m/s", "Road profile vertical velocity; also the slope of "
               "road_displacement over the coming step"),
        _input("seat_force", "N", "Force the occupant exerts on the seat, positive in "
               "compression (pushes the car body down)"),
        _input("seat_force_rate", "N/s", "Optional slope of seat_force over the coming step "
               "(0, the default, holds seat_force)"),
    )
    outputs = (
        _output("seat_displacement", "m", f"Seat point ({seat}) vertical displacement"),
        _output("seat_velocity", "m/s", f"Seat point ({seat}) vertical velocity"),
        _output("sprung_acceleration", "m/s2", f"Absolute vertical acceleration of the mass "
                f"under the seat ({seat})"),
        _output("suspension_deflection", "m", "Suspension deflection, sprung minus unsprung "
                "displacement (positive in extension)"),
        _output("tire_force", "N", "Dynamic tire force, positive in compression "
                "(perturbation about the static wheel load)"),
    )
    m = 2 + len(network.force_inputs)
    input_map = np.zeros((m, 4))
    input_map[0, 0] = 1.0
    input_map[1, 1] = 1.0
    input_map[2 + list(network.force_inputs).index(seat), 2] = -1.0  # sprung.force = -seat_force
    return Interface(
        kind="car", inputs=inputs, outputs=outputs, input_map=input_map,
        rate_pairs=((0, 1), (2, 3)),
        output_signals=("seat.x", "seat.v", "seat.a", "suspension.deflection", "tire.force"),
    )


#: Interface builders by FMU kind.
KINDS = {"body": body_interface, "car": car_interface}


def _parameter_variables(network: Network) -> Tuple[Variable, ...]:
    """Parameters as FMU variables, with unit and description read off the topology."""
    roles_of = {}
    for role, point in network.roles.items():
        roles_of.setdefault(point, []).append(role)
    use = {}
    for mass, ref in network.masses.items():
        if isinstance(ref, str):
            label = f"{mass} ({', '.join(roles_of[mass])})" if mass in roles_of else mass
            use.setdefault(ref, ("mass", f"Mass of {label}"))
    field_words = {"k": "stiffness", "k_series": "series stiffness", "c": "damping"}
    for el in network.elements:
        for fieldname, ref in el.values.items():
            if isinstance(ref, str):
                use.setdefault(ref, (fieldname, f"{field_words[fieldname].capitalize()} of element "
                                                f"'{el.name}' ({el.a} to {el.b})"))
    out = []
    for name, value in network.parameters.items():
        kind, text = use.get(name, ("mass", name))
        out.append(Variable(name, "parameter", "fixed", PARAMETER_UNITS[kind],
                            text,
                            start=float(value), min=POSITIVE_MIN))
    return tuple(out)


class FmuCore:
    """State and stepping of one FMU instance; plain Python, no pythonfmu.

    Parameters
    ----------
    kind : str
        ``"body"`` or ``"car"`` (:data:`KINDS`).
    network : Network
        The model with the parameter values baked into the FMU.
    name : str
        FMU name for messages (``"HumanBody3DOF"``).
    log : callable, optional
        ``log(message, level)`` with level ``"warning"`` or ``"error"``; the
        slave forwards it to the FMU logger. Messages are dropped if None.

    Attributes
    ----------
    variables : tuple of Variable
        Inputs, then outputs, then parameters; the index is the value reference.
    time : float
        Communication time reached (s).

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> core = FmuCore("body", load_model("reduced-paper"), "HumanBody3DOF")
    >>> core.initialize()
    >>> core.set_real([0, 1], [0.0, 0.01])
    >>> core.do_step(0.0, 1e-3)
    >>> len(core.get_real([2, 3, 4, 5]))
    4
    """

    def __init__(self, kind: str, network: Network, name: str = "FMU",
                 log: Optional[Callable[[str, str], None]] = None):
        if kind not in KINDS:
            raise BodyvibError(f"unknown FMU kind '{kind}'; kinds are {', '.join(KINDS)}")
        self.kind = kind
        self.name = name
        self.network = network
        self.interface = KINDS[kind](network)
        self._log = log
        iface = self.interface
        self.parameters = _parameter_variables(network)
        self.variables = iface.inputs + iface.outputs + self.parameters
        self._ni, self._no, self._np = len(iface.inputs), len(iface.outputs), len(self.parameters)
        self._pnames = [p.name for p in self.parameters]
        # value reference -> 0 input, 1 output, 2 parameter
        self._kind_of = [0] * self._ni + [1] * self._no + [2] * self._np
        self._R = iface.rate_matrix()
        self._initialized = False
        self._init_error = None
        self._build(np.array([p.start for p in self.parameters]))
        # one buffer [x | s | y] so the step and the outputs are single products
        self._buf = np.zeros(self._n + self._ni + self._no)
        self._params = np.array([p.start for p in self.parameters])
        self._bad = [False] * self._ni
        self._values = [0.0] * (self._ni + self._no) + self._params.tolist()  # by value reference
        self._dirty = True
        self._stale = False
        self.time = 0.0
        self._views()

    # -- set-up ------------------------------------------------------------
    def _views(self):
        n, ni = self._n, self._ni
        self._z = self._buf[:n + ni]        # [x | s], what the step and outputs multiply
        self._x = self._buf[:n]
        self._s = self._buf[n:n + ni]
        self._y = self._buf[n + ni:]
        self._znew = np.empty(n + ni)
        # value reference -> index into _buf (parameters are kept apart)
        self._pos = [n + i for i in range(self._ni + self._no)]

    def _build(self, params: np.ndarray):
        """Model, output matrix and step cache for a parameter vector."""
        net = self.network.with_parameters(**dict(zip(self._pnames, params.tolist())))
        lm = linear_model(net)
        iface = self.interface
        U = iface.input_map
        idx = [lm.output_index(sig) for sig in iface.output_signals]
        self._n = lm.A.shape[0]
        self._disc = Discretization(lm)
        self._U = U
        self._dU = U @ self._R                      # du = dU @ s
        self._Y = np.hstack([lm.C[idx], lm.D[idx] @ U])  # y = Y @ [x | s]
        self._steps = {}
        self._h = None
        self._M = None
        self._built_params = params.copy()

    def _step_matrix(self, h: float) -> np.ndarray:
        """``[x | s]`` at the step's end ``= M @ [x | s]``: exact state update, inputs extrapolated."""
        M = self._steps.get(h)
        if M is None:
            Phi, G0, G1 = self._disc.matrices(h)
            n, ni = self._n, self._ni
            M = np.zeros((n + ni, n + ni))
            M[:n, :n] = Phi
            M[:n, n:] = G0 @ self._U + G1 @ self._dU
            M[n:, n:] = np.eye(ni) + h * self._R
            if len(self._steps) > 64:
                self._steps.clear()
            self._steps[h] = M
        return M

    # -- parameters ----------------------------------------------------------
    def check_parameters(self, params=None) -> None:
        """Refuse non-finite or non-positive parameters.

        Raises
        ------
        BodyvibError
            Naming the parameter, its value and unit, and the fix.
        """
        params = self._params if params is None else params
        for var, value in zip(self.parameters, params):
            if not (math.isfinite(value) and value > 0):
                raise BodyvibError(
                    f"{self.name}: parameter {var.name} = {float(value)!r} {var.unit} is invalid: "
                    f"{var.description[0].lower() + var.description[1:]} must be a positive finite "
                    f"number; set a value > 0 (the FMU's default is {var.start:g} {var.unit})"
                )

    def initialize(self) -> None:
        """Validate the parameters and prepare the model (``fmi2ExitInitializationMode``).

        Raises
        ------
        BodyvibError
            An invalid parameter (see :meth:`check_parameters`) or a model the
            builder refuses.
        """
        self._initialized = False
        try:
            self.check_parameters()
            if not np.array_equal(self._params, self._built_params):
                self._build(self._params)
        except BodyvibError as exc:
            self._init_error = f"{exc}; the instance refuses to step (reset and set valid parameters)"
            raise
        self._init_error = None
        self._stale = False
        self._initialized = True
        self._dirty = True

    # -- variables -----------------------------------------------------------
    def get_real(self, vrs: Sequence[int]) -> List[float]:
        """Values of variables by value reference (outputs computed on read)."""
        if self._dirty:
            self._outputs()
        values = self._values
        return [values[vr] for vr in vrs]

    def _outputs(self):
        if self._stale:  # parameters changed before initialization: follow them if valid
            try:
                self.check_parameters()
                self._build(self._params)
            except BodyvibError:
                pass
            self._stale = False
        np.dot(self._Y, self._z, out=self._y)
        self._values[:self._ni + self._no] = self._buf[self._n:].tolist()
        self._dirty = False

    def set_real(self, vrs: Sequence[int], values: Sequence[float]) -> None:
        """Set inputs (any time) or parameters (before initialization).

        A non-finite input is stored and refused by the next :meth:`do_step`;
        setting an output, or a parameter after initialization, is ignored
        with a logged error. Never raises for a bad value.
        """
        kind, buf, pos = self._kind_of, self._buf, self._pos
        for vr, v in zip(vrs, values):
            k = kind[vr]
            if k == 0:
                buf[pos[vr]] = v
                self._bad[vr] = not math.isfinite(v)
            elif k == 2:
                if self._initialized:
                    self._message(f"{self.name}: parameter {self.variables[vr].name} is fixed after "
                                  "initialization; set it before fmi2ExitInitializationMode (ignored)")
                else:
                    self._params[vr - self._ni - self._no] = v
                    self._values[vr] = float(v)
                    self._stale = True
            else:
                self._message(f"{self.name}: {self.variables[vr].name} is an output and cannot be "
                              "set (ignored)")
        self._dirty = True

    def _message(self, text: str, level: str = "error"):
        if self._log is not None:
            self._log(text, level)

    # -- stepping ------------------------------------------------------------
    def do_step(self, current_time: float, step_size: float) -> None:
        """Advance one communication step with in-step input extrapolation.

        Parameters
        ----------
        current_time : float
            Start of the step, s.
        step_size : float
            Step length, s (positive, finite; may change from step to step).

        Raises
        ------
        BodyvibError
            Not initialized, a non-positive or non-finite step, or a
            non-finite input; the state is left unchanged.
        """
        h = step_size
        if not 0.0 < h < math.inf:
            raise BodyvibError(f"{self.name}: communication step size must be positive and "
                               f"finite, got {h!r} s")
        if True in self._bad:
            bad = [f"{v.name} = {float(self._s[i])!r}" for i, v in enumerate(self.interface.inputs)
                   if self._bad[i]]
            raise BodyvibError(f"{self.name}: input {', '.join(bad)} at t = {current_time:g} s is "
                               "not finite; step refused, state unchanged (set a finite value "
                               "and step again)")
        if not self._initialized:
            raise BodyvibError(self._init_error or f"{self.name}: do_step before initialization; "
                               "call fmi2ExitInitializationMode first")
        if h != self._h:
            self._M = self._step_matrix(h)
            self._h = h
        np.dot(self._M, self._z, out=self._znew)  # state and inputs at the step's end
        self._z[:] = self._znew
        self._dirty = True
        self.time = current_time + h

    # -- snapshots -------------------------------------------------------------
    def get_state(self) -> dict:
        """A JSON-serializable snapshot of everything that evolves (``fmi2GetFMUstate``)."""
        return {
            "buf": self._buf.tolist(),
            "params": self._params.tolist(),
            "bad": list(self._bad),
            "initialized": self._initialized,
            "time": self.time,
        }

    def set_state(self, state: dict) -> None:
        """Restore a snapshot from :meth:`get_state` (``fmi2SetFMUstate``)."""
        params = np.array(state["params"], dtype=float)
        self._params = params
        self._values[self._ni + self._no:] = params.tolist()
        if state["initialized"] and not np.array_equal(params, self._built_params):
            self._build(params)
        self._stale = not state["initialized"] and not np.array_equal(params, self._built_params)
        self._buf[:] = state["buf"]
        self._bad = list(state["bad"])
        self._initialized = bool(state["initialized"])
        self.time = float(state["time"])
        self._dirty = True

    # -- introspection ---------------------------------------------------------
    def output_dependencies(self) -> List[List[int]]:
        """For each output, the input value references it depends on directly (feedthrough)."""
        D = self._Y[:, self._n:]
        return [[i for i in range(self._ni) if D[j, i] != 0.0] for j in range(self._no)]

    @property
    def state(self) -> np.ndarray:
        """The model state vector (a copy)."""
        return self._x.copy()
