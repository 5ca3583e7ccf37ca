"""The FMU contract: variable names, causality, units, value references, parameters.

Every FMU of this project (``HumanBody3DOF``, ``HumanBodyISO7962``, ``QuarterCar``)
declares the variables defined here, in this order, whatever its kind (pythonfmu
or native): the value reference of a variable is its position in
:func:`fmu_variables`. The pythonfmu slaves, the native build, the co-simulation
master and the tests import these definitions; nobody restates them
(docs/architecture.md, "The FMU contract").

Interfaces (SI units; ``vr`` = value reference = position in the ``variables`` of :class:`bodyvib.runtime.engine.FmuCore`):

* body (``kind="body"``): inputs ``seat_displacement`` [m], ``seat_velocity``
  [m/s], ``seat_acceleration`` [m/s2] (optional, start 0: the seat velocity
  rises at it over the coming step; 0 keeps the seat motion linear); outputs ``head_acceleration`` [m/s2] (absolute), ``head_displacement``
  [m], ``torso_displacement`` [m], ``seat_force`` [N] (force the body exerts on
  the seat, positive in compression), ``seat_force_rate`` [N/s] (its exact time
  derivative, for a master that feeds the car's ``seat_force_rate``);
  parameters: the model's named parameters.
* car (``kind="car"``): inputs ``road_displacement`` [m], ``road_velocity``
  [m/s] (a car driven at several points, a half car, takes a pair per point:
  ``road_displacement_front``, ``road_velocity_front``, ``..._rear``; see
  :func:`road_inputs`), ``seat_force`` [N] (the occupant's, positive in compression: it enters
  the car's ``<seat>.force`` input as ``-seat_force``), ``seat_force_rate``
  [N/s] (optional, start 0: slope of ``seat_force`` over the coming step; 0 =
  hold); outputs ``seat_displacement`` [m] and ``seat_velocity`` [m/s] (the
  point with role ``seat``); parameters: the car's named parameters.

Either kind then declares the extra outputs its parameter file lists in
``fmu_outputs`` (name, model signal, unit, description), in that order: the
shipped cars list ``sprung_acceleration`` (``seat.a``), ``suspension_deflection``
(``suspension.deflection``) and ``tire_force`` (``tire.force``), so the contract
itself names no car part. Last come one output ``<name>_force`` [N] per named
internal force of the file's ``forces``, in its order (the body models'
``neck_force`` and ``lumbar_force``, positive in compression).

A car whose parameter file declares ``actuators`` takes, per actuator named
``<a>`` (suffix ``_<a>``, none for an unnamed one), the inputs
``actuator_force_<a>`` [N] (positive pushes the actuator's ``to`` point up and its
``from`` point down: the two apart) and ``actuator_force_rate_<a>`` [N/s]
(optional, start 0: its slope over the coming step), after ``seat_force_rate``;
and, after all other outputs, ``actuator_upper_velocity_<a>`` and
``actuator_lower_velocity_<a>`` [m/s], the absolute vertical velocities of the
``to`` and ``from`` points, what a skyhook or groundhook controller reads, and
``actuator_upper_acceleration_<a>``, ``actuator_lower_acceleration_<a>`` [m/s2], their
accelerations (for a controller's force rate). Start value 0 leaves the actuator
passive.

Numpy only, relative imports only: the FMUs ship this module under a private
package name (``build_fmu.py``).
"""

import math
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np

from .errors import BodyvibError
from .network import Network, split_position

__all__ = [
    "Variable",
    "Interface",
    "body_interface",
    "car_interface",
    "seat_point",
    "parameter_variables",
    "BODY_INPUTS",
    "BODY_OUTPUTS",
    "CAR_INPUTS",
    "CAR_OUTPUTS",
    "fmu_variables",
    "actuator_variables",
    "rate_signal",
    "road_inputs",
    "KINDS",
    "MODEL_FILE",
    "PARAMETER_LIMITS",
    "PARAMETER_UNITS",
    "RATE_PREFIX",
    "UNITS",
]

#: Names of the body interface's inputs, in value-reference order.
BODY_INPUTS = ("seat_displacement", "seat_velocity", "seat_acceleration")
#: Names of the body interface's outputs, in value-reference order.
BODY_OUTPUTS = (
    "head_acceleration",
    "head_displacement",
    "torso_displacement",
    "seat_force",
    "seat_force_rate",
)
#: Names of the car interface's inputs, in value-reference order.
CAR_INPUTS = ("road_displacement", "road_velocity", "seat_force", "seat_force_rate")
#: Names of the car interface's fixed outputs (the parameter file's ``fmu_outputs``
#: follow them), in value-reference order.
CAR_OUTPUTS = ("seat_displacement", "seat_velocity")

#: Where the build puts the parameter file, inside the FMU's resources.
MODEL_FILE = "bodyvib_model.json"

#: Prefix of an output signal that is the time derivative of a model output
#: (``"d/dt seat_force"``): the engine derives its row from the same state space,
#: ``d/dt (C x + D u) = C (A x + B u) + D du``.
RATE_PREFIX = "d/dt "

#: Unit of a network parameter by the element field (or mass) that uses it.
PARAMETER_UNITS = {
    "mass": "kg",
    "inertia": "kg.m2",
    "position": "m",
    "k": "N/m",
    "k_series": "N/m",
    "c": "N.s/m",
    "gap_compression": "m",
    "gap_rebound": "m",
    "c_compression": "N.s/m",
    "c_rebound": "N.s/m",
    "roll_stiffness": "N.m/rad",
    "track": "m",
}

#: Parameter values a model accepts (SI: kg, N/m, N s/m), the loader's range
#: (:data:`bodyvib.runtime.modelfile.PARAMETER_RANGE`) and the ``min``/``max`` the FMUs
#: declare; the smallest is also the ``min`` of a source FMU's speed (m/s).
PARAMETER_LIMITS = (1e-6, 1e12)

#: SI units used by the FMUs, as exponents of the FMI base units.
UNITS = {
    "1": {},
    "m": {"m": 1},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N/s": {"kg": 1, "m": 1, "s": -3},
    "kg": {"kg": 1},
    "kg.m2": {"kg": 1, "m": 2},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "N/m": {"kg": 1, "s": -2},
    "N.s/m": {"kg": 1, "s": -1},
    "N.m/rad": {"kg": 1, "m": 2, "s": -2, "rad": -1},
}


@dataclass(frozen=True)
class Variable:
    """One FMU variable.

    Attributes
    ----------
    name : str
        Its name in the model description (``seat_displacement``, ``tire_force``).
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

    def check_positive(self, owner: str, value: float, what: Optional[str] = None) -> None:
        """Refuse a value of this parameter that is not a positive finite number.

        Parameters
        ----------
        owner : str
            The FMU instance, for the message.
        value : float
            The value set.
        what : str, optional
            The subject of the message (default: the description, lower-cased).

        Raises
        ------
        BodyvibError
            Naming the parameter, its value and unit, and the fix.

        Examples
        --------
        >>> Variable("m1", "parameter", "fixed", "kg", "Head mass", 5.3).check_positive("b", -1)
        Traceback (most recent call last):
        ...
        bodyvib.runtime.errors.BodyvibError: b: parameter m1 = -1.0 kg is invalid: head mass must be a positive finite number; set a value > 0 (the FMU's default is 5.3 kg)
        """
        if not (math.isfinite(value) and value > 0):
            what = what or self.description[:1].lower() + self.description[1:]
            raise BodyvibError(
                f"{owner}: parameter {self.name} = {float(value)!r} {self.unit} is invalid: "
                f"{what} must be a positive finite number; set a value > 0 (the FMU's "
                f"default is {self.start:g} {self.unit})"
            )


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
        :meth:`bodyvib.runtime.network.SignalNames.output_index`; ``RATE_PREFIX + name``
        (:func:`rate_signal`) is the exact time derivative of that output.
    slope_fallback : tuple of (int, int)
        The rate pairs of a displacement and its velocity input: if the
        velocity is never set to a non-zero value while the displacement
        moves, the engine takes the slope of successive displacements as the
        in-step rate and logs one warning (an unconnected velocity).
    """

    kind: str
    inputs: Tuple[Variable, ...]
    outputs: Tuple[Variable, ...]
    input_map: np.ndarray
    rate_pairs: Tuple[Tuple[int, int], ...]
    output_signals: Tuple[str, ...]
    slope_fallback: Tuple[Tuple[int, int], ...] = ()

    def rate_matrix(self) -> np.ndarray:
        """``R`` with ``ds/dt = R s`` over a step (FMU input space)."""
        n = len(self.inputs)
        R = np.zeros((n, n))
        for i, j in self.rate_pairs:
            R[i, j] = 1.0
        return R


def rate_signal(signal: str) -> str:
    """The output signal that is the exact time derivative of ``signal``.

    Parameters
    ----------
    signal : str
        A model output (or role) name, e.g. ``"seat_force"``.

    Returns
    -------
    str
        ``RATE_PREFIX + signal``.

    Examples
    --------
    >>> rate_signal("seat_force")
    'd/dt seat_force'
    """
    return RATE_PREFIX + signal


def _inputs(names: Sequence[str], specs: Sequence[Tuple[str, str]]) -> Tuple[Variable, ...]:
    """Input variables named ``names``, ``specs`` = ((unit, description), ...)."""
    return tuple(
        Variable(n, "input", "continuous", u, d, start=0.0)
        for n, (u, d) in zip(names, specs, strict=True)
    )


def _outputs(names: Sequence[str], specs: Sequence[Tuple[str, str]]) -> Tuple[Variable, ...]:
    """Output variables named ``names``, ``specs`` = ((unit, description), ...)."""
    return tuple(
        Variable(n, "output", "continuous", u, d) for n, (u, d) in zip(names, specs, strict=True)
    )


def _with_extra_outputs(
    network: Network, outputs: Tuple[Variable, ...], signals: Sequence[str]
) -> Tuple[Tuple[Variable, ...], Tuple[str, ...]]:
    """Append the parameter file's ``fmu_outputs``, then its named ``forces``, to an interface."""
    extra = list(network.fmu_outputs) + [
        {
            "name": f"{name}_force",
            "signal": f"{name}_force",
            "unit": "N",
            "description": f"{name.capitalize()} force: the force of element '{element}', "
            "positive in compression",
        }
        for name, element in network.forces.items()
    ]
    outputs = outputs + _outputs(
        [o["name"] for o in extra], [(o["unit"], o["description"]) for o in extra]
    )
    return outputs, tuple(signals) + tuple(o["signal"] for o in extra)


def body_interface(network: Network) -> Interface:
    """The interface of a human-body FMU (docs/architecture.md, "The FMU contract").

    Parameters
    ----------
    network : Network
        A body model: base ``seat``, roles ``head`` and ``torso``.

    Returns
    -------
    Interface
        Inputs :data:`BODY_INPUTS` (seat motion), outputs :data:`BODY_OUTPUTS` (head,
        torso, seat force and its rate) and then the model's ``fmu_outputs``.

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
    head, torso = network.point("head"), network.point("torso")
    inputs = _inputs(
        BODY_INPUTS,
        (
            ("m", "Seat vertical displacement xr (z up, about static equilibrium)"),
            (
                "m/s",
                "Seat vertical velocity; also the slope of seat_displacement over the coming "
                "step (in-step extrapolation)",
            ),
            (
                "m/s2",
                "Optional seat vertical acceleration: the slope of seat_velocity over the "
                "coming step, so the seat follows a parabola (0, the default, keeps the seat motion "
                "linear over the step)",
            ),
        ),
    )
    outputs = _outputs(
        BODY_OUTPUTS,
        (
            ("m/s2", f"Head ({head}) absolute vertical acceleration"),
            ("m", f"Head ({head}) vertical displacement"),
            ("m", f"Torso ({torso}) vertical displacement"),
            (
                "N",
                "Force the body exerts on the seat, positive in compression "
                "(body pushing down); perturbation about the static load",
            ),
            (
                "N/s",
                "Exact time derivative of seat_force (from the model's state equations and the "
                "input rates); connect it to QuarterCar's seat_force_rate",
            ),
        ),
    )
    outputs, signals = _with_extra_outputs(
        network,
        outputs,
        ("head.a", "head.x", "torso.x", f"{base}_force", rate_signal(f"{base}_force")),
    )
    return Interface(
        kind="body",
        inputs=inputs,
        outputs=outputs,
        input_map=np.eye(2, 3),  # the model's inputs: seat displacement and velocity
        rate_pairs=((0, 1), (1, 2)),
        slope_fallback=((0, 1),),
        output_signals=signals,
    )


def actuator_variables(network: Network) -> Tuple[Tuple[str, str, str, str, str, str], ...]:
    """FMU variable names of each actuator of a car model, in the file's order.

    Parameters
    ----------
    network : Network
        A vehicle model (its ``actuators``, none for a passive car).

    Returns
    -------
    tuple of (str, str, str, str, str, str)
        Per actuator: its force input, force-rate input, upper-point and lower-point
        velocity outputs, upper-point and lower-point acceleration outputs.

    Examples
    --------
    >>> from bodyvib.runtime.modelfile import network_from_dict
    >>> car = network_from_dict({"name": "two-mass", "base": "road",
    ...     "parameters": {"m": 40.0, "k": 2e5}, "masses": {"w": "m", "b": "m"},
    ...     "elements": [{"name": "t", "kind": "spring", "from": "road", "to": "w", "k": "k"},
    ...                  {"name": "s", "kind": "spring", "from": "w", "to": "b", "k": "k"}],
    ...     "force_inputs": ["w", "b"],
    ...     "actuators": [{"name": "", "from": "w", "to": "b"}]})
    >>> actuator_variables(car)[0][:4]
    ('actuator_force', 'actuator_force_rate', 'actuator_upper_velocity', 'actuator_lower_velocity')
    """
    out: List[Tuple[str, str, str, str, str, str]] = []
    for act in network.actuators:
        sfx = f"_{act['name']}" if act["name"] else ""
        out.append(
            (
                f"actuator_force{sfx}",
                f"actuator_force_rate{sfx}",
                f"actuator_upper_velocity{sfx}",
                f"actuator_lower_velocity{sfx}",
                f"actuator_upper_acceleration{sfx}",
                f"actuator_lower_acceleration{sfx}",
            )
        )
    return tuple(out)


def seat_point(network: Network, what: str = "vehicle model") -> str:
    """The mass a vehicle (or seat) model seats the occupant on: its ``seat`` role.

    Parameters
    ----------
    network : Network
        A vehicle model, or a seat model.
    what : str
        What the model is, for the message.

    Returns
    -------
    str
        The mass with role ``seat``.

    Raises
    ------
    BodyvibError
        No ``seat`` role, or its mass takes no force input (``force_inputs``).
    """
    seat = network.roles.get("seat")
    if seat is None or seat not in network.force_inputs:
        raise BodyvibError(
            f"{what} '{network.name}' needs a 'seat' role naming the mass the occupant "
            "sits on, listed in force_inputs (the occupant's seat force acts there)"
        )
    return seat


def car_interface(network: Network) -> Interface:
    """The interface of the quarter-car FMU (docs/architecture.md, "The FMU contract").

    Parameters
    ----------
    network : Network
        A vehicle model: a ``seat`` role naming a mass in ``force_inputs``;
        its ``fmu_outputs`` become further outputs.

    Returns
    -------
    Interface
        Inputs :data:`CAR_INPUTS` (road motion, the occupant's seat force), outputs
        :data:`CAR_OUTPUTS` (seat point motion) and then the model's ``fmu_outputs``.

    Raises
    ------
    BodyvibError
        What :func:`seat_point` refuses.
    """
    seat = seat_point(network)
    roads = road_inputs(network)
    road_specs = []
    for j in range(0, len(roads), 2):
        axle = roads[j][len("road_displacement_") :]
        under = f"the {axle} tire" if axle else "the tire"
        road_specs += [
            ("m", f"Road profile height under {under}"),
            (
                "m/s",
                f"Road profile vertical velocity{f' under {under}' if axle else ''}; also the "
                f"slope of {roads[j]} over the coming step",
            ),
        ]
    inputs = _inputs(
        roads + CAR_INPUTS[2:],
        (
            *road_specs,
            (
                "N",
                "Force the occupant exerts on the seat, positive in compression (pushes the car "
                "body down)",
            ),
            (
                "N/s",
                "Optional slope of seat_force over the coming step (0, the default, holds "
                "seat_force)",
            ),
        ),
    )
    outputs = _outputs(
        CAR_OUTPUTS,
        (
            ("m", f"Seat point ({seat}) vertical displacement"),
            ("m/s", f"Seat point ({seat}) vertical velocity"),
        ),
    )
    outputs, signals = _with_extra_outputs(network, outputs, ("seat.x", "seat.v"))
    actuators = actuator_variables(network)
    act_inputs, act_outputs = _actuator_variables_described(network, actuators)
    inputs += _inputs([n for n, _ in act_inputs], [spec for _, spec in act_inputs])
    outputs += _outputs([n for n, _, _ in act_outputs], [spec for _, spec, _ in act_outputs])
    signals += tuple(sig for _, _, sig in act_outputs)
    nb = len(network.bases)
    m = 2 * nb + len(network.force_inputs)
    input_map = np.zeros((m, 2 * nb + 2 + 2 * len(actuators)))
    input_map[: 2 * nb, : 2 * nb] = np.eye(2 * nb)  # each base's displacement and velocity
    forces = list(network.force_inputs)
    # <seat>.force = -seat_force
    input_map[2 * nb + forces.index(seat), 2 * nb] = -1.0
    act_pairs = []
    for j, act in enumerate(network.actuators):
        col = 2 * nb + 2 + 2 * j
        # <to>.force += F, <from>.force -= F: the pair pushes the two points apart
        input_map[2 * nb + forces.index(act["to"]), col] += 1.0
        input_map[2 * nb + forces.index(act["from"]), col] -= 1.0
        act_pairs.append((col, col + 1))
    road_pairs = tuple((2 * j, 2 * j + 1) for j in range(nb))
    return Interface(
        kind="car",
        inputs=inputs,
        outputs=outputs,
        input_map=input_map,
        rate_pairs=road_pairs + ((2 * nb, 2 * nb + 1),) + tuple(act_pairs),
        slope_fallback=road_pairs,  # not the seat force: seat_force_rate 0 means hold
        output_signals=signals,
    )


def _actuator_variables_described(network: Network, actuators: Sequence) -> tuple:
    """The car's actuator inputs ``(name, (unit, text))`` and outputs (with their signal)."""
    act_inputs, act_outputs = [], []
    for act, names in zip(network.actuators, actuators, strict=True):
        force, rate = names[:2]
        pair = f"from {act['from']} to {act['to']}"
        act_inputs += [
            (
                force,
                (
                    "N",
                    f"Actuator force {pair}; positive pushes {act['to']} up and "
                    f"{act['from']} down (0, the default, leaves the car passive)",
                ),
            ),
            (rate, ("N/s", f"Optional slope of {force} over the coming step (0 holds it)")),
        ]
        points = ((act["to"], "upper"), (act["from"], "lower"))
        for name, ((point, which), (unit, quantity, q)) in zip(
            names[2:],
            [
                (p, m)
                for m in (("m/s", "velocity", "v"), ("m/s2", "acceleration", "a"))
                for p in points
            ],
            strict=True,
        ):
            text = f"Absolute vertical {quantity} of {point} (the actuator's {which} point)"
            act_outputs.append((name, (unit, text), f"{point}.{q}"))
    return act_inputs, act_outputs


def road_inputs(network: Network) -> Tuple[str, ...]:
    """Names of a car FMU's road inputs: a displacement and a velocity per driven point.

    A car driven at one point ``road`` takes ``road_displacement`` and
    ``road_velocity``; one driven at ``road_front`` and ``road_rear`` (a half car)
    takes ``road_displacement_front``, ``road_velocity_front``,
    ``road_displacement_rear`` and ``road_velocity_rear``.

    Parameters
    ----------
    network : Network
        A vehicle model; its base points are ``road`` or ``road_<axle>``.

    Returns
    -------
    tuple of str
        Displacement and velocity input of each base, in the model's input order.

    Raises
    ------
    BodyvibError
        A base point not named ``road`` or ``road_<axle>``.

    Examples
    --------
    >>> from bodyvib.runtime.modelfile import network_from_dict
    >>> car = network_from_dict({"name": "two-wheel", "base": ["road_front", "road_rear"],
    ...     "parameters": {"m": 40.0, "k": 2e5}, "masses": {"wf": "m", "wr": "m"},
    ...     "elements": [{"name": "tf", "kind": "spring", "from": "road_front", "to": "wf", "k": "k"},
    ...                  {"name": "tr", "kind": "spring", "from": "road_rear", "to": "wr", "k": "k"}]})
    >>> road_inputs(car)[:2], road_inputs(car)[2:]
    (('road_displacement_front', 'road_velocity_front'), ('road_displacement_rear', 'road_velocity_rear'))
    """
    names = []
    for base in network.bases:
        if base != "road" and not base.startswith("road_"):
            raise BodyvibError(
                f"vehicle model '{network.name}': base '{base}' must be named 'road' or "
                "'road_<axle>' (road_front, road_rear), the names of the car FMU's road inputs"
            )
        suffix = base[len("road") :]
        names += [f"road_displacement{suffix}", f"road_velocity{suffix}"]
    return tuple(names)


#: Interface builders by FMU kind.
KINDS = {"body": body_interface, "car": car_interface}


def parameter_variables(network: Network) -> Tuple[Variable, ...]:
    """Parameters as FMU variables, with unit and description read off the topology."""
    roles_of: dict[str, list[str]] = {}
    for role, point in network.roles.items():
        roles_of.setdefault(point, []).append(role)
    use: dict[str, tuple[str, str]] = {}
    for mass, ref in network.masses.items():
        if isinstance(ref, str):
            label = f"{mass} ({', '.join(roles_of[mass])})" if mass in roles_of else mass
            use.setdefault(ref, ("mass", f"Mass of {label}"))
    for body_name, body in network.bodies.items():
        if isinstance(body.mass, str):
            use.setdefault(body.mass, ("mass", f"Mass of rigid body {body_name}"))
        if isinstance(body.inertia, str):
            use.setdefault(
                body.inertia,
                ("inertia", f"Pitch moment of inertia of rigid body {body_name}"),
            )
        if isinstance(body.roll_inertia, str):
            use.setdefault(
                body.roll_inertia,
                ("inertia", f"Roll moment of inertia of rigid body {body_name}"),
            )
        for point, place in body.points.items():
            refs = place if isinstance(place, tuple) else (place,)
            for ref, sides in zip(
                refs, (("behind", "ahead of"), ("right of", "left of"), ("below", "above"))
            ):
                if isinstance(ref, str):
                    sign, factor, name = split_position(ref)
                    side = sides[0] if sign < 0 else sides[1]
                    times = "" if factor == 1.0 else f"{1 / factor:g} times the "
                    text = f"istance of point {point} {side} the centre of mass of {body_name}"
                    use.setdefault(name, ("position", f"{times}d{text}" if times else f"D{text}"))
    for point, ref in network.static_loads.items():
        if isinstance(ref, str):
            use.setdefault(ref, ("mass", f"Static mass resting on {point} (its weight only)"))
    field_words = {
        "k": "stiffness",
        "k_series": "series stiffness",
        "c": "damping",
        "gap_compression": "gap in compression",
        "gap_rebound": "gap in rebound",
        "c_compression": "damping in compression",
        "c_rebound": "damping in rebound",
        "track": "track width",
    }
    for el in network.elements:
        for fieldname, ref in el.values.items():
            if isinstance(ref, str):
                kind = (
                    "roll_stiffness"
                    if el.kind == "anti_roll_bar" and fieldname == "k"
                    else fieldname
                )
                word = "roll stiffness" if kind == "roll_stiffness" else field_words[fieldname]
                use.setdefault(
                    ref,
                    (kind, f"{word.capitalize()} of element '{el.name}' ({el.a} to {el.b})"),
                )
    out = []
    for name, value in network.parameters.items():
        kind, text = use.get(name, ("mass", name))
        out.append(
            Variable(
                name,
                "parameter",
                "fixed",
                PARAMETER_UNITS[kind],
                text,
                start=float(value),
                min=PARAMETER_LIMITS[0],
                max=PARAMETER_LIMITS[1],
            )
        )
    return tuple(out)


def fmu_variables(
    kind: str, network: Network
) -> Tuple[Interface, Tuple[Variable, ...], Tuple[Variable, ...]]:
    """Interface, parameters and all variables of an FMU, in value-reference order.

    Parameters
    ----------
    kind : str
        ``"body"`` or ``"car"`` (:data:`KINDS`).
    network : Network
        The model baked into the FMU.

    Returns
    -------
    interface : Interface
    parameters : tuple of Variable
    variables : tuple of Variable
        Inputs, then outputs, then parameters: the value reference of a
        variable is its index here.

    Raises
    ------
    BodyvibError
        An unknown kind, a model that lacks what the kind needs, or a parameter
        named like an interface variable.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> _, _, variables = fmu_variables("body", load_model("reduced-paper"))
    >>> [v.name for v in variables[:4]]
    ['seat_displacement', 'seat_velocity', 'seat_acceleration', 'head_acceleration']
    """
    if kind not in KINDS:
        raise BodyvibError(f"unknown FMU kind '{kind}'; kinds are {', '.join(KINDS)}")
    interface = KINDS[kind](network)
    parameters = parameter_variables(network)
    variables = interface.inputs + interface.outputs + parameters
    taken = {v.name for v in interface.inputs + interface.outputs}
    clash = [p.name for p in parameters if p.name in taken]
    if clash:
        raise BodyvibError(
            f"model '{network.name}': parameter name(s) {', '.join(clash)} are "
            f"variables of the {kind} FMU's interface; rename the parameter(s)"
        )
    seen = set()
    for v in variables:
        if v.name in seen:
            raise BodyvibError(
                f"model '{network.name}': FMU variable '{v.name}' is declared "
                "twice (an fmu_outputs name clashes with the interface or a "
                "parameter); rename it"
            )
        seen.add(v.name)
    return interface, parameters, variables
