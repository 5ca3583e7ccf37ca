"""Skyhook and groundhook control of a car's actuators, and the closed loop it makes.

A car parameter file may declare ``actuators``: force pairs between a wheel and the
body point above it (:mod:`bodyvib.runtime.modelfile`; a positive force pushes the
two apart). A controller reads the absolute vertical velocities of each actuator's
upper point ``v_u`` (the body) and lower point ``v_l`` (the wheel) and sets its force

.. math::

    F = -c_{sky} v_u + c_{gnd} v_l ,

the ideal (active) skyhook law (a damper ``c_sky`` from the body to a fixed point in
the sky) plus the groundhook law (a damper ``c_gnd`` from the wheel to the ground),
after D. Karnopp, M. J. Crosby and R. A. Harwood, "Vibration control using
semi-active force generators", ASME J. Eng. Ind. 96(2), 619-626, 1974. The
*semi-active* (on-off) variant clips the force a damper cannot give: a passive
damper's force opposes the relative velocity ``v_u - v_l``, so a demand with
``F (v_u - v_l) > 0`` is set to 0.

The ideal law is linear in the car's states, so the closed loop is again a linear
model: substituting ``u_act = G C_v x`` into ``x' = A x + B u`` gives
``A + B G C_v`` (:func:`closed_loop_model`), discretized exactly like any other
model; that is the monolithic reference of a controlled co-simulation. A car whose tires
are contacts and whose suspensions have stops is linear within each regime of those
elements (:mod:`bodyvib.runtime.regimes`): the law closes each regime's loop the same way
(:class:`ClosedLoopPiecewise`), and the closed loop is stepped exactly with located events.
"""

import math
from dataclasses import dataclass, replace
from typing import Tuple

import numpy as np

from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.network import LinearModel, Network, regime_model
from bodyvib.runtime.regimes import PiecewiseModel, Regime

__all__ = [
    "LAWS",
    "SkyhookController",
    "skyhook",
    "parse_control",
    "describe",
    "controller_from_fmu",
    "default_gains",
    "actuator_gain_matrix",
    "closed_loop_model",
    "ClosedLoopPiecewise",
    "check_coupling",
    "step_gain",
    "MAX_GAIN",
    "MAX_STEP_GAIN",
]

#: Control laws by name: which of the two gains a law uses by default.
LAWS = ("skyhook", "groundhook", "hybrid")

#: Largest controller gain, N s/m (chosen): 20,000 times the quarter car's default skyhook
#: gain (4416 N s/m). At 1e8 the skyhook already holds the quarter car's body still (head
#: Wk r.m.s. 0.000 m/s2 to three digits, its figures within 0.02 % of those at 1e15); above
#: it the closed loop's rates only spread over more decades, until at 1e18 its exact
#: discretization loses the figures (5 % off) and at 1e50 overflows.
MAX_GAIN = 1e8

#: Largest change a co-simulated controller may make to the velocities it reads within one
#: communication step, per unit velocity: ``gain x step / effective mass`` (the spectral
#: radius of ``step C B G``, :func:`check_coupling`). Chosen below the onset of divergence
#: measured at a 1 ms step with the extrapolating master: on the quarter car 0.51 for the
#: groundhook on the wheel (0.42 ran), 0.59 for the skyhook on the body (0.48 ran), 0.53
#: for the hybrid law (0.38 ran); on the half car 0.63 and 0.67 (0.5 ran).
MAX_STEP_GAIN = 0.4


@dataclass(frozen=True)
class SkyhookController:
    """Settings of a skyhook/groundhook controller, the same for every actuator.

    Parameters
    ----------
    c_sky : float
        Skyhook gain, N s/m: the force per unit absolute velocity of the upper point.
    c_ground : float
        Groundhook gain, N s/m: the force per unit absolute velocity of the lower point.
    semi_active : bool
        Clip the force to what a passive damper can give (on-off law).

    Raises
    ------
    BodyvibError
        A negative or non-finite gain.

    Examples
    --------
    >>> SkyhookController(c_sky=4000.0).force(0.1, 0.0)
    -400.0
    """

    c_sky: float = 0.0
    c_ground: float = 0.0
    semi_active: bool = False

    def __post_init__(self):
        for name in ("c_sky", "c_ground"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise BodyvibError(
                    f"controller gain {name} = {value!r} must be a finite number >= 0 (N s/m)"
                )
            if value > MAX_GAIN:
                raise BodyvibError(
                    f"controller gain {name} = {value:g} N s/m is beyond {MAX_GAIN:g} N s/m, "
                    "where a skyhook already holds the body still and the closed loop's "
                    "figures stop changing; use a gain of at most that"
                )

    def force(self, upper_velocity, lower_velocity):
        """Actuator force for the given point velocities (:func:`skyhook`)."""
        return skyhook(upper_velocity, lower_velocity, self.c_sky, self.c_ground, self.semi_active)

    def forces(self, velocities):
        """Force per actuator from ``[upper_0, lower_0, upper_1, lower_1, ...]``, N."""
        v = list(velocities)
        return [float(self.force(v[i], v[i + 1])) for i in range(0, len(v), 2)]

    @property
    def linear(self) -> bool:
        """True for the ideal (active) law, linear in the velocities."""
        return not self.semi_active


def skyhook(upper_velocity, lower_velocity, c_sky, c_ground=0.0, semi_active=False):
    """Skyhook (and groundhook) actuator force, positive pushing the two points apart.

    Parameters
    ----------
    upper_velocity, lower_velocity : float or array_like
        Absolute vertical velocities of the actuator's upper (body) and lower (wheel)
        points, m/s, positive up.
    c_sky, c_ground : float
        Gains, N s/m.
    semi_active : bool
        Set to 0 a force a passive damper cannot give (same sign as the relative
        velocity ``upper - lower``).

    Returns
    -------
    float or ndarray
        ``-c_sky * upper + c_ground * lower`` (N), clipped if ``semi_active``.

    Examples
    --------
    >>> skyhook(0.1, 0.0, 4000.0)
    -400.0
    >>> skyhook(0.1, 0.2, 4000.0, semi_active=True)  # body and wheel close in: a damper pushes
    0.0
    """
    vu = np.asarray(upper_velocity, dtype=float)
    vl = np.asarray(lower_velocity, dtype=float)
    force = -c_sky * vu + c_ground * vl
    if semi_active:
        force = np.where(force * (vu - vl) > 0.0, 0.0, force)
    return float(force) if force.ndim == 0 else force


def default_gains(car: Network) -> Tuple[float, float]:
    """Default gains per actuator: the body's critical damping, the passive damper's size.

    ``c_sky = 2 sqrt(K_s M_s) / n``: the critical damping of the body (all its mass
    ``M_s`` bouncing on the ``n`` suspension springs, stiffness sum ``K_s``, tires
    rigid), shared equally by the ``n`` actuators. ``c_ground = C_s / n``: the mean of the
    passive suspension dampers beside the actuators, so that the groundhook adds a damper
    of the passive one's size between wheel and ground. (At the wheels' critical damping
    on the tires, 6696 N s/m for the quarter car, a wheel hooked to the ground no longer
    follows the road and the dynamic tire load rises instead of falling; at the passive
    damper's 1000 N s/m it falls by 17 % on a class C road at 20 m/s.) For the quarter
    car: 4416 and 1000 N s/m.

    Parameters
    ----------
    car : Network
        A car with ``actuators`` between its wheels and body points.

    Returns
    -------
    (float, float)
        ``c_sky``, ``c_ground`` in N s/m.

    Raises
    ------
    BodyvibError
        A car without actuators, or one whose actuators span no spring.

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> [round(c) for c in default_gains(load_car("quarter-car-active"))]
    [4416, 1000]
    """
    check_actuated(car)
    pairs = {frozenset((a["from"], a["to"])) for a in car.actuators}
    wheels = {a["from"] for a in car.actuators}
    k_s = c_s = 0.0
    for el in car.elements:
        if el.kind != "stop" and frozenset((el.a, el.b)) in pairs:  # stops: 0 within the gaps
            k_s += car.value(el.values["k"]) if "k" in el.values else 0.0
            c_s += car.value(el.values["c"]) if "c" in el.values else 0.0
    if k_s <= 0.0 or c_s <= 0.0:
        raise BodyvibError(
            f"car '{car.name}': no suspension spring and damper parallel to its actuators; "
            "give the gains explicitly (c=..., g=...)"
        )
    m_s = car.total_mass() - sum(car.value(car.masses[w]) for w in wheels)
    n = len(car.actuators)
    return 2.0 * math.sqrt(k_s * m_s) / n, c_s / n


def check_actuated(car: Network) -> None:
    """Refuse a car without actuators (nothing for a controller to drive)."""
    if not car.actuators:
        raise BodyvibError(
            f"car '{car.name}' has no actuators for the controller to drive; use a car "
            "with 'actuators' in its parameter file (quarter-car-active, half-car-active, "
            "full-car-active)"
        )


def parse_control(text: str, car: Network) -> SkyhookController:
    """A controller from its command-line form ``LAW[:c=...,g=...,semi]``.

    ``skyhook`` uses ``c`` (default: the body's critical damping, :func:`default_gains`),
    ``groundhook`` uses ``g`` (default: the passive suspension damper's coefficient),
    ``hybrid`` both; ``semi`` clips to what a damper can give.

    Parameters
    ----------
    text : str
        E.g. ``"skyhook"``, ``"skyhook:c=3000"``, ``"groundhook:g=5000,semi"``.
    car : Network
        The car the controller drives (for the default gains).

    Returns
    -------
    SkyhookController

    Raises
    ------
    BodyvibError
        An unknown law or option, a gain that is not a number >= 0, or a car without
        actuators.

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> parse_control("skyhook:c=3000", load_car("quarter-car-active"))
    SkyhookController(c_sky=3000.0, c_ground=0.0, semi_active=False)
    """
    law, _, rest = text.partition(":")
    if law not in LAWS:
        raise BodyvibError(f"unknown controller '{law}'; controllers are {', '.join(LAWS)}")
    check_actuated(car)
    c_sky, c_ground = default_gains(car)
    gains = {
        "c": c_sky if law in ("skyhook", "hybrid") else 0.0,
        "g": c_ground if law in ("groundhook", "hybrid") else 0.0,
    }
    semi = False
    seen = set()
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, value = (p.strip() for p in item.partition("="))
        if key in seen:
            raise BodyvibError(f"controller '{text}' gives {key} twice; give each option once")
        seen.add(key)
        if item == "semi":
            semi = True
            continue
        if key in gains and not (eq and value):
            raise BodyvibError(f"controller option '{key}' needs a value, e.g. {key}=3000 (N s/m)")
        if key not in gains or not eq:
            raise BodyvibError(
                f"controller option '{item}' not understood; use c=<N s/m>, g=<N s/m> or semi"
            )
        try:
            gains[key] = float(value)
        except ValueError:
            raise BodyvibError(f"controller option {key}={value!r} is not a number") from None
    return SkyhookController(c_sky=gains["c"], c_ground=gains["g"], semi_active=semi)


def controller_from_fmu(path) -> SkyhookController:
    """The law a ``SkyhookController.fmu`` declares: its gains' and switch's start values.

    Parameters
    ----------
    path : str
        A controller FMU (:func:`bodyvib.fmu.controller.build_controller_fmu`).

    Returns
    -------
    SkyhookController
        The gains and the semi-active switch the FMU starts with.

    Raises
    ------
    BodyvibError
        An FMU without the parameters ``c_sky``, ``c_ground`` and ``semi_active``.
    """
    from fmpy import read_model_description

    try:
        md = read_model_description(str(path))
    except Exception as exc:
        raise BodyvibError(f"'{path}' is not a readable FMU: {exc}") from None
    start = {v.name: v.start for v in md.modelVariables if v.causality == "parameter"}
    if not {"c_sky", "c_ground", "semi_active"} <= set(start):
        raise BodyvibError(
            f"controller FMU '{path}' has no parameters c_sky, c_ground and semi_active "
            "(build it with build_active_ssp)",
            parameters=("build_active_ssp",),
        )
    semi = str(start["semi_active"]).lower() in ("true", "1")
    return SkyhookController(float(start["c_sky"]), float(start["c_ground"]), semi)


def describe(controller: SkyhookController) -> str:
    """The controller in words, for reports.

    Examples
    --------
    >>> describe(SkyhookController(c_sky=4416.1))
    'skyhook c_sky = 4416 N s/m'
    """
    parts = []
    if controller.c_sky:
        parts.append(f"skyhook c_sky = {controller.c_sky:.0f} N s/m")
    if controller.c_ground:
        parts.append(f"groundhook c_ground = {controller.c_ground:.0f} N s/m")
    text = " + ".join(parts) or "no gain (passive)"
    return text + (", semi-active (on-off)" if controller.semi_active else "")


def actuator_gain_matrix(
    model: LinearModel, car: Network, controller: SkyhookController
) -> Tuple[np.ndarray, np.ndarray]:
    """The ideal law as matrices: model force inputs ``u_f = G y_v`` from velocity outputs.

    Parameters
    ----------
    model : LinearModel
        The car's (or the seated car's) state space: it has the force inputs
        ``<point>.force`` and velocity outputs ``<point>.v`` of each actuator point.
    car : Network
        The car (its ``actuators``).
    controller : SkyhookController
        A linear (not semi-active) controller.

    Returns
    -------
    G : (n_inputs, n_outputs) ndarray
        Model inputs from model outputs.
    F : (n_actuators, n_outputs) ndarray
        Each actuator's force from the model outputs.

    Raises
    ------
    BodyvibError
        A semi-active controller (not linear), or a car without actuators.
    """
    check_actuated(car)
    if not controller.linear:
        raise BodyvibError("the semi-active law is not linear: it has no closed-loop matrices")
    F = np.zeros((len(car.actuators), len(model.outputs)))
    G = np.zeros((len(model.inputs), len(model.outputs)))
    for i, act in enumerate(car.actuators):
        F[i, model.output_index(f"{act['to']}.v")] -= controller.c_sky
        F[i, model.output_index(f"{act['from']}.v")] += controller.c_ground
        G[model.input_index(f"{act['to']}.force")] += F[i]
        G[model.input_index(f"{act['from']}.force")] -= F[i]
    return G, F


def step_gain(controller: SkyhookController, car: Network, step: float) -> float:
    """How much a controller changes the velocities it reads within one step, per unit.

    The spectral radius of ``step C B G``: the law's gains ``G``
    (:func:`actuator_gain_matrix`, the semi-active law as its ideal law) through the
    car's instantaneous response ``C B`` of velocities to forces.

    Parameters
    ----------
    controller : SkyhookController
    car : Network
        The car with actuators.
    step : float
        Communication step, s.

    Returns
    -------
    float
        ``gain x step / mass`` of the point an actuator drives, for one law alone.

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> car = load_car("quarter-car-active")  # the skyhook on the 290 kg body
    >>> round(step_gain(SkyhookController(c_sky=2900.0), car, 1e-3), 6)
    0.01
    """
    from bodyvib.runtime.network import linear_model

    lm = linear_model(car)
    G, _ = actuator_gain_matrix(lm, car, replace(controller, semi_active=False))
    return float(step) * float(np.max(np.abs(np.linalg.eigvals(lm.C @ lm.B @ G))))


def check_coupling(controller: SkyhookController, car: Network, step: float) -> None:
    """Refuse gains an explicitly coupled co-simulation cannot follow at this step.

    A co-simulation master reads the velocities at a communication point and applies the
    controller's force over the step: a gain that changes those velocities by more than
    :data:`MAX_STEP_GAIN` of themselves within one step makes the loop diverge (the run
    then stops with a step the FMUs discard). The change is :func:`step_gain`, ``gain x
    step / mass`` of the point the actuator drives. The semi-active law is checked as
    its ideal law (it gives the ideal force or none).

    Parameters
    ----------
    controller, car, step
        As :func:`step_gain`.

    Raises
    ------
    BodyvibError
        The gains or the step too large, naming the largest gains at this step and the
        longest step at these gains.

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> check_coupling(SkyhookController(c_sky=4416.0), load_car("quarter-car-active"), 1e-3)
    """
    change = step_gain(controller, car, step)
    if change > MAX_STEP_GAIN:
        scale = MAX_STEP_GAIN / change
        raise BodyvibError(
            f"controller {describe(controller)} changes the velocities it reads by "
            f"{change:.3g} times themselves within one {step:g} s communication step "
            f"(gain x step / mass), above the {MAX_STEP_GAIN:g} a co-simulation follows (it "
            f"diverges from about 0.5): "
            f"use gains of at most {scale:.3g} times these or a step of at most "
            f"{scale * step:.3g} s"
        )


def closed_loop_model(
    model: LinearModel, car: Network, controller: SkyhookController
) -> Tuple[LinearModel, np.ndarray]:
    """The state space with the ideal law substituted: ``A + B G C``, ``C + D G C``.

    The law reads velocities, which are states (their rows of ``D`` are zero), so
    the substitution has no algebraic loop.

    Parameters
    ----------
    model : LinearModel
        State space with the car's actuator inputs and point velocities.
    car : Network
        The car.
    controller : SkyhookController
        A linear controller.

    Returns
    -------
    LinearModel
        Same states, inputs and outputs; the actuator inputs now add to the law.
    (n_actuators, n_states) ndarray
        Each actuator force from the states.

    Raises
    ------
    BodyvibError
        What :func:`actuator_gain_matrix` refuses.

    Examples
    --------
    >>> from bodyvib.runtime.network import linear_model
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> car = load_car("quarter-car-active")
    >>> lm = linear_model(car)
    >>> closed, _ = closed_loop_model(lm, car, SkyhookController(c_sky=1000.0))
    >>> i = lm.states.index("sprung.v")
    >>> round(float(closed.A[i, i] - lm.A[i, i]) * car.parameters["ms"], 6)  # a damper to the sky
    -1000.0
    """
    G, F = actuator_gain_matrix(model, car, controller)
    used = np.any(G != 0.0, axis=0)
    if np.any(model.D[used] != 0.0):  # pragma: no cover - velocities are states
        raise BodyvibError("the controller reads an output with direct feedthrough")
    Cv = model.C
    closed = replace(model, A=model.A + model.B @ G @ Cv, C=model.C + model.D @ G @ Cv)
    return closed, F @ Cv


class ClosedLoopPiecewise(PiecewiseModel):
    """A car with contacts and stops under a linear law: each regime's closed loop.

    Within a regime the car is affine, ``x' = A x + B u + b``, ``y = C x + D u + d``, and
    the law ``u_f = G y`` reads velocities, which are states: the regime's closed loop is
    ``A + B G C``, ``C + D G C`` (:func:`closed_loop_model`) with the constants
    ``b + B G d`` and ``d + D G d``. The switching functions are the open loop's (they
    read displacements and velocities, which no force input reaches directly). Where
    nothing switches the regime in force is static equilibrium's, whose closed loop is
    that of the linearized car, matrix for matrix.

    Parameters
    ----------
    network : Network
        The seated car (or the car) with its nonlinear elements.
    car : Network
        The car (its ``actuators``).
    controller : SkyhookController
        A linear (not semi-active) controller.

    Attributes
    ----------
    forces : dict of tuple of bool to ndarray
        Per regime built: each actuator's force from the states, ``(F, f0)`` with
        ``force = F x + f0``.

    Raises
    ------
    BodyvibError
        A semi-active controller, a car without actuators.

    Examples
    --------
    >>> from bodyvib.runtime.regimes import EventStepper
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> car = load_car("quarter-car-active")
    >>> model = ClosedLoopPiecewise(car, car, SkyhookController(c_sky=1000.0))
    >>> reg = EventStepper(model).regime
    >>> i = reg.model.states.index("sprung.v")
    >>> round(float(reg.model.A[i, i] - model.linear.A[i, i]) * car.parameters["ms"], 6)
    -1000.0
    """

    def __init__(self, network: Network, car: Network, controller: SkyhookController):
        check_actuated(car)
        if not controller.linear:
            raise BodyvibError("the semi-active law is not linear: it has no closed-loop matrices")
        super().__init__(network)
        self.car, self.controller = car, controller
        self.forces: dict = {}

    def regime(self, state: Tuple[bool, ...]) -> Regime:
        """The closed loop of a state of the switching functions (built once)."""
        reg = self._regimes.get(state)
        if reg is None:
            lm, b, d = regime_model(self.network, self.modes(state), self.preloads)
            closed, forces = closed_loop_model(lm, self.car, self.controller)
            G, F = actuator_gain_matrix(lm, self.car, self.controller)
            gd = G @ d
            if np.any(gd):  # a constant the law reads (none where the velocities are states)
                b, d = b + lm.B @ gd, d + lm.D @ gd
            self.forces[state] = (forces, F @ d)
            reg = self._regimes[state] = Regime(closed, b, d)
        return reg

    def force(self, state: Tuple[bool, ...], x: np.ndarray) -> np.ndarray:
        """Each actuator's force at states ``x`` (rows) in regime ``state``, N."""
        self.regime(state)
        F, f0 = self.forces[state]
        return x @ F.T + f0 if np.any(f0) else x @ F.T
