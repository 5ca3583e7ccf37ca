"""The stepping engine of the bodyvib FMUs: state, exact stepping, state snapshots.

Every FMU of this project is a thin slave over one :class:`FmuCore`, which
holds the instance's state and declares the variables of
:mod:`bodyvib.runtime.contract`. The engine holds no equation of its own: the
matrices come from :func:`bodyvib.runtime.network.linear_model` and the step
matrices from :class:`bodyvib.runtime.discretize.Discretization`
(docs/architecture.md, "Exact stepping").

Stepping: over a communication step ``h`` each input is extrapolated linearly
from its value and its rate (a displacement rises at its velocity input, the
seat force at ``seat_force_rate``, every other input is held), and the state is
advanced exactly: ``x <- Phi x + Gamma0 u + Gamma1 du``. A rate that itself has
a rate (a body's ``seat_velocity`` rising at ``seat_acceleration``) makes the
input a parabola over the step, advanced exactly with ``Gamma2 d2u``
(:func:`bodyvib.runtime.exact.discretize_quadratic`). At the end of the step
the inputs are set to their extrapolated values, so outputs read right after
``do_step`` (before the host sets new inputs) are those of the step's end;
outputs are ``C x + D u`` computed when read, so feedthrough outputs follow a
newly set input at once. An output declared as the rate of a model output
(:data:`bodyvib.runtime.contract.RATE_PREFIX`) is its exact time derivative
from the same state space, ``C (A x + B u) + D du``, with ``du`` the input
rates of the in-step extrapolation (``seat_force_rate`` of a body FMU).

Unconnected velocity (:attr:`bodyvib.runtime.contract.Interface.slope_fallback`):
for a displacement input paired with a velocity input, if the velocity has
never been set to a non-zero value since instantiation (or reset) and a
``do_step`` sees the displacement differ from its value at the previous
``do_step``, the engine switches, for the rest of the run or until a non-zero
velocity is set, to the slope ``(x_now - x_prev) / h_prev`` as the in-step
rate, and logs one warning naming the input. Before that first detected move
the velocity (0) is used. A master that leaves ``seat_velocity`` unconnected
then gets a first-order coupling instead of a held (and silently wrong) seat.


Numpy only, relative imports only: the FMUs ship this module under a private
package name.
"""

import math
from typing import Callable, List, Optional, Sequence

import numpy as np

from .contract import RATE_PREFIX, fmu_variables
from .discretize import Discretization, StepCache, discretize_quadratic
from .errors import BodyvibError
from .lifecycle import Lifecycle
from .network import LinearModel, Network, linear_model
from .regimes import EventStepper, PiecewiseModel

__all__ = ["FmuCore"]


class FmuCore(Lifecycle):
    """State and stepping of one FMU instance; plain Python, no pythonfmu.

    Parameters
    ----------
    kind : str
        ``"body"`` or ``"car"`` (:data:`bodyvib.runtime.contract.KINDS`).
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
    >>> len(core.get_real([3, 4, 5, 6, 7]))
    5
    """

    def __init__(
        self,
        kind: str,
        network: Network,
        name: str = "FMU",
        log: Optional[Callable[[str, str], None]] = None,
    ):
        self.kind = kind
        self.name = name
        self.network = network
        self.interface, self.parameters, self.variables = fmu_variables(kind, network)
        self._log = log
        iface = self.interface
        self._ni, self._no, self._np = len(iface.inputs), len(iface.outputs), len(self.parameters)
        self._pnames = [p.name for p in self.parameters]
        # value reference -> 0 input, 1 output, 2 parameter
        self._kind_of = [0] * self._ni + [1] * self._no + [2] * self._np
        self._R = iface.rate_matrix()
        self._not_initialized()
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
        self._fallback = list(iface.slope_fallback)
        nf = len(self._fallback)
        self._velocity_of = {j: p for p, (_, j) in enumerate(self._fallback)}
        self._vel_seen = [False] * nf  # a non-zero velocity was set
        self._slope_on = [False] * nf  # the slope replaces the velocity
        self._warned = [False] * nf
        self._x_prev: List[Optional[float]] = [None] * nf  # displacement at the previous do_step
        self._h_prev: List[Optional[float]] = [None] * nf

    # -- set-up ------------------------------------------------------------
    def _views(self) -> None:
        n, ni = self._n, self._ni
        self._z = self._buf[: n + ni]  # [x | s], what the step and outputs multiply
        self._x = self._buf[:n]
        self._s = self._buf[n : n + ni]
        self._y = self._buf[n + ni :]
        self._znew = np.empty(n + ni)
        self._zdot = self._znew.dot  # the after-step check: z.z is finite iff z is (no overflow)
        # value reference -> index into _buf (parameters are kept apart)
        self._pos = [n + i for i in range(self._ni + self._no)]

    def _build(self, params: np.ndarray) -> None:
        """Model, output matrix and step cache for a parameter vector."""
        net = self.network.with_parameters(**dict(zip(self._pnames, params.tolist())))
        iface = self.interface
        U = iface.input_map
        self._U = U
        self._dU = U @ self._R  # du = dU @ s
        self._stepper: Optional[EventStepper] = None
        self._y0: Optional[np.ndarray] = None
        if net.nonlinear_elements:  # a piecewise-affine model: regimes, located events
            if (self._R @ self._R).any():
                raise BodyvibError(
                    f"{self.name}: nonlinear elements are stepped with inputs that rise "
                    "linearly over a step; this FMU's inputs rise quadratically (a body "
                    "with seat_acceleration): use a linear model"
                )
            self._stepper = EventStepper(PiecewiseModel(net))
            pw = self._stepper.model
            self._Gz = np.hstack([pw.Gx, pw.Gu @ U])  # the functions on [x | s]
            self._last: tuple = (None, None, None, None)  # step, regime, M, affine column
            self._regimes: dict = {}
            reg = self._stepper.regime
            lm = reg.model
            self._Y, self._y0 = self._output_rows(lm, reg.b, reg.d)
            self._state_built = self._stepper.state
        else:
            lm = linear_model(net)
            self._Y = self._output_rows(lm)[0]
        self._n = lm.A.shape[0]
        self._disc = Discretization(lm)
        self._steps = StepCache(self._step_matrix)
        self._h: Optional[float] = None
        self._M: Optional[np.ndarray] = None
        self._built_params = params.copy()

    def _output_rows(
        self, lm: LinearModel, b: Optional[np.ndarray] = None, d: Optional[np.ndarray] = None
    ) -> "tuple[np.ndarray, Optional[np.ndarray]]":
        """``Y`` with ``y = Y @ [x | s] (+ y0)`` for a (regime's) state space."""
        U, rows, const = self._U, [], []
        for sig in self.interface.output_signals:
            if sig.startswith(RATE_PREFIX):  # d/dt (C x + D u) = C (A x + B u + b) + D du
                i = lm.output_index(sig[len(RATE_PREFIX) :])
                rows.append(
                    np.concatenate([lm.C[i] @ lm.A, lm.C[i] @ lm.B @ U + lm.D[i] @ self._dU])
                )
                const.append(0.0 if b is None else float(lm.C[i] @ b))
            else:
                i = lm.output_index(sig)
                rows.append(np.concatenate([lm.C[i], lm.D[i] @ U]))
                const.append(0.0 if d is None else float(d[i]))
        return np.array(rows), (None if b is None else np.array(const))

    def _regime_step(self, h: float) -> "tuple[np.ndarray, np.ndarray]":
        """``M`` and the affine column of the regime in force, for a step ``h``."""
        st = self._stepper
        assert st is not None
        key = (st.state, float(f"{h:.12g}"))
        got = self._regimes.get(key)
        if got is None:
            reg = st.regime
            Phi, G0, G1, gb = reg.matrices(h)
            n, ni = self._n, self._ni
            M = np.zeros((n + ni, n + ni))
            M[:n, :n] = Phi
            M[:n, n:] = G0 @ self._U + G1 @ self._dU
            M[n:, n:] = np.eye(ni) + h * self._R
            if len(self._regimes) > 256:
                self._regimes.clear()
            got = self._regimes[key] = (M, np.concatenate([gb, np.zeros(ni)]))
        return got

    def _step_matrix(self, h: float) -> np.ndarray:
        """``[x | s]`` at the step's end ``= M @ [x | s]``: exact state update, inputs extrapolated."""
        Phi, G0, G1 = self._disc.matrices(h)
        n, ni = self._n, self._ni
        M = np.zeros((n + ni, n + ni))
        M[:n, :n] = Phi
        M[:n, n:] = G0 @ self._U + G1 @ self._dU
        M[n:, n:] = np.eye(ni) + h * self._R
        R2 = self._R @ self._R  # a rate that itself rises (seat velocity at seat_acceleration)
        if R2.any():
            lm = self._disc.model
            M[:n, n:] += discretize_quadratic(lm.A, lm.B, float(f"{h:.12g}")) @ self._U @ R2
            M[n:, n:] += 0.5 * h * h * R2
        return M

    def setup_experiment(self, start_time: float) -> None:
        """Start time of the run (``fmi2SetupExperiment``); the state is not touched."""
        self.time = float(start_time)

    # -- parameters ----------------------------------------------------------
    def check_parameters(self, params: Optional[np.ndarray] = None) -> None:
        """Refuse non-finite or non-positive parameters.

        Raises
        ------
        BodyvibError
            Naming the parameter, its value and unit, and the fix.
        """
        params = self._params if params is None else params
        for var, value in zip(self.parameters, params):
            var.check_positive(self.name, value)

    def initialize(self) -> None:
        """Validate the parameters and prepare the model (``fmi2ExitInitializationMode``).

        Raises
        ------
        BodyvibError
            An invalid parameter (see :meth:`check_parameters`) or a model the
            builder refuses.
        """
        self._initialize(self._prepare, "set valid parameters")
        self._stale = False
        self._dirty = True

    def _prepare(self) -> None:
        self.check_parameters()
        if not np.array_equal(self._params, self._built_params):
            self._build(self._params)

    # -- variables -----------------------------------------------------------
    def get_real(self, vrs: Sequence[int]) -> List[float]:
        """Values of variables by value reference (outputs computed on read)."""
        if self._dirty:
            self._outputs()
        values = self._values
        return [values[vr] for vr in vrs]

    def _outputs(self) -> None:
        if self._stale:  # parameters changed before initialization: follow them if valid
            try:
                self.check_parameters()
                self._build(self._params)
            except BodyvibError:
                pass
            self._stale = False
        np.dot(self._Y, self._z, out=self._y)
        if self._y0 is not None:
            self._y += self._y0
        self._values[: self._ni + self._no] = self._buf[self._n :].tolist()
        for p, (_, j) in enumerate(self._fallback):
            if self._slope_on[p]:  # an input reads back as set (never non-zero), not the slope
                self._values[j] = 0.0
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
                p = self._velocity_of.get(vr)
                if p is not None and v != 0.0:
                    self._vel_seen[p] = True
                    self._slope_on[p] = False
            elif k == 2:
                if self._initialized:
                    self._message(
                        f"{self.name}: parameter {self.variables[vr].name} is fixed after "
                        "initialization; set it before fmi2ExitInitializationMode (ignored)"
                    )
                else:
                    self._params[vr - self._ni - self._no] = v
                    self._values[vr] = float(v)
                    self._stale = True
            else:
                self._message(
                    f"{self.name}: {self.variables[vr].name} is an output and cannot be "
                    "set (ignored)"
                )
        self._dirty = True

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
            self._refuse_step_size(h)
        if True in self._bad:
            bad = [
                f"{v.name} = {float(self._s[i])!r}"
                for i, v in enumerate(self.interface.inputs)
                if self._bad[i]
            ]
            raise BodyvibError(
                f"{self.name}: input {', '.join(bad)} at t = {current_time:g} s is "
                "not finite; step refused, state unchanged (set a finite value "
                "and step again)"
            )
        if not self._initialized:
            self._refuse_step()
        if False not in self._vel_seen:  # no fallback pair, or every velocity connected:
            self._advance(current_time, h)  # the rule below would change nothing
            return
        # the unconnected-velocity bookkeeping moves before the step is known to be
        # possible: a refused step puts it back (a continuation equals an undisturbed run)
        saved = (
            list(self._slope_on),
            list(self._warned),
            list(self._x_prev),
            list(self._h_prev),
            [float(self._s[j]) for _, j in self._fallback],
        )
        self._slope_fallback(current_time, h)
        try:
            self._advance(current_time, h)
        except BodyvibError:
            self._slope_on, self._warned, self._x_prev, self._h_prev, rates = saved
            for (_, j), v in zip(self._fallback, rates):
                self._s[j] = v
            raise

    def _advance(self, current_time: float, h: float) -> None:
        """The exact step itself: refused (BodyvibError) with the state unchanged if not finite."""
        if self._stepper is not None:
            self._advance_regimes(current_time, h)
            return
        M = self._M
        if h != self._h or M is None:
            with np.errstate(all="ignore"):  # an overflow is refused below, not warned about
                M = self._steps.get(h)
            if not np.all(np.isfinite(M)):
                self._steps.discard(h)
                raise BodyvibError(
                    f"{self.name}: a step of {h!r} s overflows the exact "
                    "discretization (not finite); step refused, state unchanged "
                    "(use shorter steps)"
                )
            self._M = M
            self._h = h
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is refused below
            np.dot(M, self._z, out=self._znew)  # state and inputs at the step's end
            finite = math.isfinite(self._zdot(self._znew))
        if not finite:  # NaN or overflow: keep the old state
            raise BodyvibError(
                f"{self.name}: the state after the step from t = "
                f"{current_time:g} s is not finite (inputs or state too large); "
                "step refused, state unchanged"
            )
        self._z[:] = self._znew
        self._dirty = True
        self.time = current_time + h

    def _advance_regimes(self, current_time: float, h: float) -> None:
        """:meth:`_advance` of a piecewise-affine model: the regime's step, events located."""
        st = self._stepper
        assert st is not None
        n = self._n
        last = self._last
        if last[0] == h and last[1] == st.state:
            M, m = last[2], last[3]
        else:
            M, m = self._regime_step(h)
            self._last = (h, st.state, M, m)
        with np.errstate(over="ignore", invalid="ignore"):
            np.dot(M, self._z, out=self._znew)
            if st.regime.affine:
                self._znew += m
            finite = math.isfinite(self._zdot(self._znew))
        if not finite:
            raise BodyvibError(
                f"{self.name}: the state after the step from t = "
                f"{current_time:g} s is not finite (inputs or state too large); "
                "step refused, state unchanged"
            )
        ge = (self._Gz @ self._znew + st.model.g0).tolist()  # the switching functions
        if st.clear(ge):  # nothing switches: one sign test each
            st.accept(ge, current_time + h)
        else:
            s = self._s
            u, du = self._U @ s, self._dU @ s
            saved = st.to_state()
            try:
                xe = st.finish(self._x, u, du, h, current_time, self._znew[:n])
            except BodyvibError as exc:
                st.from_state(saved)
                raise BodyvibError(f"{self.name}: {exc}; step refused, state unchanged") from None
            self._znew[:n] = xe
        self._z[:] = self._znew
        if st.state != self._state_built:
            reg = st.regime
            self._Y, self._y0 = self._output_rows(reg.model, reg.b, reg.d)
            self._state_built = st.state
        self._dirty = True
        self.time = current_time + h

    def events(self) -> dict:
        """What the nonlinear elements did so far (:meth:`bodyvib.runtime.regimes.EventLog.summary`); ``{}`` if none.

        Returns
        -------
        dict
            Element name -> its figures.
        """
        return {} if self._stepper is None else self._stepper.log.summary()

    def _slope_fallback(self, current_time: float, h: float) -> None:
        """The unconnected-velocity rule (module docstring), before a step."""
        s = self._s
        for p, (i, j) in enumerate(self._fallback):
            if self._vel_seen[p]:
                continue
            x, x_prev = float(s[i]), self._x_prev[p]
            if x_prev is not None and x != x_prev and not self._slope_on[p]:
                self._slope_on[p] = True
                if not self._warned[p]:
                    self._warned[p] = True
                    names = self.interface.inputs
                    self._message(
                        f"{self.name}: {names[i].name} moves (t = {current_time:g} s) but "
                        f"{names[j].name} was never set: using the slope of successive "
                        f"{names[i].name} values as its in-step rate; connect {names[j].name} "
                        "for the exact coupling",
                        "warning",
                    )
            h_prev = self._h_prev[p]
            if self._slope_on[p] and x_prev is not None and h_prev is not None:
                s[j] = (x - x_prev) / h_prev
            self._x_prev[p], self._h_prev[p] = x, float(h)

    # -- snapshots -------------------------------------------------------------
    def get_state(self) -> dict:
        """A JSON-serializable snapshot of everything that evolves (``fmi2GetFMUstate``)."""
        return {
            "kind": self.kind,
            "parameter_names": list(self._pnames),
            "buf": self._buf.tolist(),
            "params": self._params.tolist(),
            "bad": list(self._bad),
            "initialized": self._initialized,
            "time": self.time,
            **({"regimes": self._stepper.to_state()} if self._stepper is not None else {}),
            "fallback": {
                "seen": list(self._vel_seen),
                "on": list(self._slope_on),
                "warned": list(self._warned),
                "x_prev": list(self._x_prev),
                "h_prev": list(self._h_prev),
            },
        }

    def check_state(self, state: dict) -> None:
        """Refuse a snapshot that is not one of this FMU's, or holds invalid values.

        Raises
        ------
        BodyvibError
            Not a snapshot of :meth:`get_state`, another FMU kind, other
            parameter names, sizes that differ from this model's, a non-finite
            value, or invalid parameters (:meth:`check_parameters`).
        """
        where = f"{self.name}: FMU state refused, state unchanged"
        fields = ("kind", "parameter_names", "buf", "params", "bad", "initialized", "time")
        if not isinstance(state, dict) or any(k not in state for k in fields):
            raise BodyvibError(
                f"{where}: not a state of a bodyvib FMU (fields {', '.join(fields)} expected)"
            )
        if state["kind"] != self.kind or list(state["parameter_names"]) != self._pnames:
            raise BodyvibError(
                f"{where}: it belongs to another FMU (kind {state['kind']!r}, "
                f"parameters {state['parameter_names']!r}; this one is "
                f"{self.kind!r} with {self._pnames!r})"
            )
        try:
            buf = np.array(state["buf"], dtype=float)
            params = np.array(state["params"], dtype=float)
            t = float(state["time"])
        except (TypeError, ValueError):
            raise BodyvibError(f"{where}: non-numeric values") from None
        sizes = ((buf, self._buf.size, "buf"), (params, self._np, "params"))
        for arr, size, name in sizes:
            if arr.shape != (size,):
                raise BodyvibError(
                    f"{where}: {name} has shape {arr.shape}, this model needs ({size},)"
                )
        bad = state["bad"]
        if (
            not isinstance(bad, list)
            or len(bad) != self._ni
            or not all(isinstance(b, bool) for b in bad)
            or not isinstance(state["initialized"], bool)
        ):
            raise BodyvibError(f"{where}: malformed input flags")
        # inputs flagged bad may hold NaN (refused at the next step); nothing else may
        finite = np.isfinite(buf)
        finite[self._n : self._n + self._ni] |= np.array(bad, dtype=bool)
        if not (finite.all() and math.isfinite(t)):
            raise BodyvibError(f"{where}: it holds values that are not finite")
        try:
            self.check_parameters(params)
        except BodyvibError as exc:
            raise BodyvibError(f"{where}: {exc}") from None

    def set_state(self, state: dict) -> None:
        """Restore a snapshot from :meth:`get_state` (``fmi2SetFMUstate``).

        Raises
        ------
        BodyvibError
            A snapshot :meth:`check_state` refuses; nothing is changed.
        """
        self.check_state(state)
        params = np.array(state["params"], dtype=float)
        self._params = params
        self._values[self._ni + self._no :] = params.tolist()
        if state["initialized"] and not np.array_equal(params, self._built_params):
            self._build(params)
        self._stale = not state["initialized"] and not np.array_equal(params, self._built_params)
        self._buf[:] = state["buf"]
        self._bad = list(state["bad"])
        self._initialized = bool(state["initialized"])
        self.time = float(state["time"])
        if self._stepper is not None and "regimes" in state:
            self._stepper.from_state(state["regimes"])
            reg = self._stepper.regime
            self._Y, self._y0 = self._output_rows(reg.model, reg.b, reg.d)
            self._state_built = self._stepper.state
        fb = state.get("fallback")
        if fb is not None:
            self._vel_seen, self._slope_on = list(fb["seen"]), list(fb["on"])
            self._warned, self._x_prev, self._h_prev = (
                list(fb["warned"]),
                list(fb["x_prev"]),
                list(fb["h_prev"]),
            )
        self._dirty = True

    # -- introspection ---------------------------------------------------------
    def output_dependencies(self) -> List[List[int]]:
        """For each output, the input value references it depends on directly (feedthrough)."""
        D = self._Y[:, self._n :]
        return [[i for i in range(self._ni) if D[j, i] != 0.0] for j in range(self._no)]
