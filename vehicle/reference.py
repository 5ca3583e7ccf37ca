"""The monolithic reference: car and occupant as one network, discretized exactly.

The co-simulation splits the seated car into two FMUs that exchange seat
motion and seat force only at communication points. The same coupled system
assembled in one piece (:func:`bodyvib.vehicle.quarter_car.seated_system`, built by
:func:`bodyvib.runtime.network.mount`) and stepped by the exact discretization of
:mod:`bodyvib.runtime.discretize` has no coupling error; with the same road samples and
the same in-step road extrapolation (``z_k + v_k tau``) the difference between
the two runs is the coupling error alone.

Coupling error (NRMSE, a fraction; reported in %)::

    NRMSE = rms(a_cosim - a_ref) / rms(a_ref)

over all communication points, for the head acceleration.
"""

import warnings
from typing import Dict, Sequence

import numpy as np

from bodyvib.process import interrupts
from bodyvib.runtime.contract import actuator_variables
from bodyvib.runtime.discretize import Discretization, check_step, input_rates
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.network import Network, linear_model, linearized
from bodyvib.runtime.regimes import EventStepper

from .control import ClosedLoopPiecewise, closed_loop_model
from .events import LinearRangeStream, LinearRangeWarning, linear_ranges
from .quarter_car import seated_system
from .road.driven import road_columns
from .signals import (
    BODY_SIGNALS,
    CAR_DEFAULTS,
    CAR_SIGNALS,
    OPTIONAL_CAR_SIGNALS,
    OPTIONAL_SIGNALS,
    car_variable,
)
from .signals import SIGNALS as _SIGNALS

__all__ = ["SIGNALS", "reference_run", "ReferenceStream", "seat_force_weights", "nrmse"]

#: Names of the signals of a run (reference or co-simulation), in column order; units,
#: meanings and sources in :data:`bodyvib.vehicle.signals.SIGNALS`.
SIGNALS = tuple(s.name for s in _SIGNALS)


def seat_force_weights(lm, body: Network, seat: str, prefix: str = "body.") -> np.ndarray:
    """Row combining outputs of the seated system into the occupant's seat force.

    The occupant's own state space (:func:`bodyvib.runtime.network.linear_model`) has the
    seat force as its output ``<base>_force`` (+ in compression, the occupant
    pushing the seat down): a row of C over the occupant's states plus a row of D
    over the seat's displacement and velocity. In the seated system every one of
    those is an output (the occupant's states under ``prefix``, the seat as
    ``<seat>.x`` and ``<seat>.v``), so the same row, moved onto ``lm.outputs``,
    gives the seat force; the rule that defines it stays in one place, the builder.

    Parameters
    ----------
    lm : LinearModel
        The monolithic car-plus-occupant model.
    body : Network
        The occupant.
    seat : str
        The car point the occupant sits on.
    prefix : str
        Prefix of the occupant's names in ``lm`` (see :func:`bodyvib.runtime.network.mount`).

    Returns
    -------
    (n_outputs,) ndarray
        Weights on ``lm.outputs``.

    Raises
    ------
    BodyvibError
        The occupant's seat force depends on an input other than the seat motion.
    """
    own = linear_model(body)
    row = own.output_index(f"{body.base}_force")
    w = np.zeros(len(lm.outputs))
    for j, state in enumerate(own.states):
        w[lm.output_index(prefix + state)] += own.C[row, j]
    seat_motion = {f"{body.base}_displacement": f"{seat}.x", f"{body.base}_velocity": f"{seat}.v"}
    for j, name in enumerate(own.inputs):
        if name in seat_motion:
            w[lm.output_index(seat_motion[name])] += own.D[row, j]
        elif (
            own.D[row, j] != 0.0
        ):  # pragma: no cover - a force on a mass never reaches the seat directly
            raise BodyvibError(f"body '{body.name}': the seat force depends on input '{name}'")
    return w


def reference_run(
    car: Network,
    body: Network,
    road_displacement,
    road_velocity,
    step: float,
    controller=None,
    linear: bool = False,
) -> Dict[str, np.ndarray]:
    """Simulate the seated car monolithically on a uniform time grid.

    Parameters
    ----------
    car : Network
        From :func:`bodyvib.vehicle.quarter_car.load_car`.
    body : Network
        A body model (base ``seat``, roles ``head`` and ``torso``).
    road_displacement, road_velocity : (n,) or (n, wheels) array_like
        Road input at ``t_k = k * step`` (m, m/s); over each step the road is
        ``z_k + v_k tau``, as in the co-simulation. A car with several road points
        (a half car) takes a column per point; the result's road columns are the
        first point's.
    step : float
        Time step in s.
    controller : bodyvib.vehicle.control.SkyhookController, optional
        Drive the car's actuators by this linear law (the closed loop).
    linear : bool
        Run the car linearized about static equilibrium
        (:func:`bodyvib.runtime.network.linearized`: the tire never leaves the road, no
        stops) instead of stepping its nonlinear elements; a ``UserWarning`` says where
        the run leaves the linear model's range
        (:class:`bodyvib.vehicle.events.LinearRangeStream`).

    Returns
    -------
    dict of str to ndarray
        The :data:`SIGNALS` at the ``n`` grid times.

    Raises
    ------
    BodyvibError
        Non-finite road input, mismatched lengths, a bad step, or a body
        without head/torso roles.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> z = np.full(100, 0.01); v = np.zeros(100)
    >>> r = reference_run(load_car(), load_model("reduced-paper"), z, v, 1e-3)
    >>> r["head_acceleration"].shape
    (100,)
    """
    z = np.asarray(road_displacement, dtype=float)
    v = np.asarray(road_velocity, dtype=float)
    if z.shape != v.shape or z.ndim not in (1, 2) or z.shape[0] < 2:
        raise BodyvibError(
            "road displacement and velocity must be arrays of equal length (and shape), >= 2 samples"
        )
    rng = LinearRangeStream(step, linear_ranges(car, body.total_mass())) if linear else None
    extra = rng.columns if rng is not None else ()  # each wheel's tire force and travel
    signals = ReferenceStream(car, body, step, controller, linear=linear, extra=extra).advance(z, v)
    if rng is not None:  # where the linear car leaves its range, at each wheel: a warning each
        rng.update_columns(signals)
        for line in rng.warnings():
            warnings.warn(line, LinearRangeWarning, stacklevel=2)
    n = z.shape[0]
    front = (z, v) if z.ndim == 1 else (z[:, 0], v[:, 0])
    signals.update(time=np.arange(n) * float(step), road_displacement=front[0])
    signals.update(road_velocity=front[1])
    return {name: signals[name] for name in SIGNALS}


class ReferenceStream:
    """The monolithic reference advanced block by block (memory independent of the run).

    :func:`reference_run` is one block of it; carrying the state from one block to the
    next, the signals of each block equal the matching rows of :func:`reference_run`.

    Parameters
    ----------
    car, body : Network
        The quarter car and the body model, as :func:`reference_run` takes them.
    step : float
        Time step, s.
    controller : bodyvib.vehicle.control.SkyhookController, optional
        Drive the car's actuators by this (linear) law: the closed loop
        (:func:`bodyvib.vehicle.control.closed_loop_model`; of each regime of a car with
        contacts and stops, :class:`bodyvib.vehicle.control.ClosedLoopPiecewise`);
        :meth:`advance` then also
        returns each actuator's force under its FMU input name (``actuator_force``).
    linear : bool
        Run the car linearized (:func:`reference_run`).
    extra : sequence of str
        More of the car's outputs to return, by their names in its ``fmu_outputs`` (e.g.
        ``tire_force_rear``).

    Attributes
    ----------
    stepper : bodyvib.runtime.regimes.EventStepper or None
        Steps a car with nonlinear elements (exact steps, located events); its ``log``
        holds what they did. None for a linear car.

    Raises
    ------
    BodyvibError
        A body without head/torso roles, a step that is not a positive number, or a
        semi-active controller.
    """

    def __init__(
        self,
        car: Network,
        body: Network,
        step: float,
        controller=None,
        linear: bool = False,
        extra: Sequence[str] = (),
    ):
        for role in ("head", "torso"):
            if role not in body.roles:
                raise BodyvibError(f"body model '{body.name}' has no '{role}' role")
        check_step(step)
        seated = seated_system(linearized(car) if linear else car, body)
        self.stepper = None
        self._forces = {}
        self._act = np.zeros((0, 0))  # a controlled car's actuator forces of the last block
        names = [v[0] for v in actuator_variables(car)] if controller is not None else []
        if seated.nonlinear_elements:  # each regime's (closed) loop, stepped with events
            model = None if controller is None else ClosedLoopPiecewise(seated, car, controller)
            self.stepper = EventStepper(seated if model is None else model)
            lm = self.stepper.regime.model
            self._forces = {name: i for i, name in enumerate(names)}
        else:
            lm = linear_model(seated)
            if controller is not None:
                lm, forces = closed_loop_model(lm, car, controller)
                self._forces = dict(zip(names, forces, strict=True))
        self._lm = lm
        self._disc = Discretization(lm)
        self._h = float(step)
        self._x = self._disc.zero_state()
        self._k = 0  # samples advanced
        seat = car.roles["seat"]
        self._bases = len(car.bases)
        # the car signals the car FMU gives as its parameter file's fmu_outputs
        fmu_outputs = {o["name"]: o["signal"] for o in car.fmu_outputs}
        # the signal table's car and body signals: an output row each, or (the seat
        # force) a combination of outputs
        self._rows = {}
        for s in CAR_SIGNALS + BODY_SIGNALS:
            variable = car_variable(s, fmu_outputs)
            if s.name in CAR_DEFAULTS and s.seated_output(seat) not in lm.outputs:
                self._rows[s.name] = CAR_DEFAULTS[s.name]  # a linear car's: constant
            elif (
                s.name in OPTIONAL_SIGNALS + OPTIONAL_CAR_SIGNALS
                and s.seated_output(seat) not in lm.outputs
            ):
                self._rows[s.name] = None  # a body without this named force: NaN
            elif variable in fmu_outputs:
                self._rows[s.name] = lm.output_index(fmu_outputs[variable])
            elif s.seated is not None:
                self._rows[s.name] = lm.output_index(s.seated_output(seat))
            else:
                self._rows[s.name] = seat_force_weights(lm, body, seat)
        for name in extra:  # more of the car's outputs by their FMU names (per wheel)
            if name not in self._rows:
                self._rows[name] = lm.output_index(fmu_outputs[name])

    def advance(self, road_displacement, road_velocity) -> Dict[str, np.ndarray]:
        """The reference at the next samples of the road.

        Parameters
        ----------
        road_displacement, road_velocity : (m,) or (m, wheels) array_like
            m, m/s; over each step the road is ``z_k + v_k tau``. A car driven at
            several road points (a half car) takes a column per point, in the order of
            its bases (:func:`bodyvib.vehicle.road.driven.wheel_inputs`).

        Returns
        -------
        dict of str to ndarray
            The :data:`SIGNALS` but time and road, at those samples, in that order.

        Raises
        ------
        BodyvibError
            Non-finite road input or mismatched lengths.
        """
        nb = self._bases
        z, v = road_columns(road_displacement, road_velocity, nb)
        lm, d, h = self._lm, self._disc, self._h
        u = np.zeros((z.shape[0], len(lm.inputs)))
        u[:, 0 : 2 * nb : 2], u[:, 1 : 2 * nb : 2] = z, v
        du = input_rates(lm, u)
        x = np.empty((z.shape[0], lm.A.shape[0]))
        xk = self._x
        if self.stepper is not None:
            y = self._advance_regimes(x, u, du)
        else:
            for k in range(z.shape[0]):
                if not k & 4095:
                    interrupts.check()  # a long block (reference_run's whole run): a safe point
                x[k] = xk
                xk = d.step(xk, u[k], du[k], h)
            self._x = xk
            y = x @ lm.C.T + u @ lm.D.T
        self._k += z.shape[0]
        out = {name: _row(y, i) for name, i in self._rows.items()}
        if self.stepper is None:
            out.update({name: x @ row for name, row in self._forces.items()})
        elif self._forces:
            out.update({name: self._act[:, i] for name, i in self._forces.items()})
        return out

    def _advance_regimes(self, x: np.ndarray, u: np.ndarray, du: np.ndarray) -> np.ndarray:
        """Step a piecewise-affine car (x filled in); the outputs of each sample's regime."""
        st, h, xk = self.stepper, self._h, self._x
        nominal = st.model.initial  # static equilibrium's regime: the linear outputs
        first = st.model.regime(nominal)
        states = []
        for k in range(u.shape[0]):
            if not k & 4095:
                interrupts.check()  # a long block (reference_run's whole run): a safe point
            x[k] = xk
            states.append(st.state)
            xk = st.step(xk, u[k], du[k], h, (self._k + k) * h)
        self._x = xk
        lm = first.model
        y = x @ lm.C.T + u @ lm.D.T + first.d
        closed = st.model if isinstance(st.model, ClosedLoopPiecewise) else None
        if closed is not None:  # each actuator's force: the law in each sample's regime
            F = closed.forces[nominal][0]  # no constant at static equilibrium
            self._act = np.column_stack([x @ F[i] for i in range(F.shape[0])])
        for k, state in enumerate(states):
            if state != nominal:
                reg = st.model.regime(state)
                y[k] = reg.model.C @ x[k] + reg.model.D @ u[k] + reg.d
                if closed is not None:
                    self._act[k] = closed.force(state, x[k])
        return y

    def events(self) -> dict:
        """What the car's nonlinear elements did so far (``{}`` for a linear car).

        Returns
        -------
        dict
            Element name -> figures (:meth:`bodyvib.runtime.regimes.EventLog.summary`).
        """
        return {} if self.stepper is None else self.stepper.log.summary()


def _row(y, i):
    """A signal from the outputs ``y``: a weighted sum, one column, NaN (``i`` None) or a
    constant (``i`` a float)."""
    if i is None:
        return np.full(y.shape[0], np.nan)
    if isinstance(i, float):
        return np.full(y.shape[0], i)
    return y @ i if isinstance(i, np.ndarray) else y[:, i]


def nrmse(estimate, reference) -> float:
    """Normalized r.m.s. error ``rms(estimate - reference) / rms(reference)`` (a fraction).

    Parameters
    ----------
    estimate, reference : array_like
        Signals of the same shape.

    Returns
    -------
    float
        The error as a fraction of the reference's r.m.s. (0.01: 1 %); 0 for equal signals.

    Raises
    ------
    BodyvibError
        Different lengths, or a reference that is zero throughout.

    Examples
    --------
    >>> round(nrmse([1.0, -1.0], [1.0, -0.9]), 4)
    0.0743
    """
    e = np.asarray(estimate, dtype=float)
    r = np.asarray(reference, dtype=float)
    if e.shape != r.shape:
        raise BodyvibError(f"cannot compare signals of shapes {e.shape} and {r.shape}")
    den = np.sqrt(np.mean(r**2))
    if den == 0:
        raise BodyvibError("reference signal is zero throughout; NRMSE undefined")
    return float(np.sqrt(np.mean((e - r) ** 2)) / den)
