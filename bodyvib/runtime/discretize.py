"""Exact discretization of linear models with in-step linear input extrapolation.

Over a step of length ``h`` the input is taken as ``u(t_k + tau) = u_k + du_k tau``
(its value and its rate at the step start; for a seat, the displacement's
rate is the seat velocity). For an LTI system the update is then exact:

    x_{k+1} = Phi x_k + Gamma0 u_k + Gamma1 du_k

with ``Phi = e^{A h}``, ``Gamma0 = int_0^h e^{A s} ds B`` and
``Gamma1 = int_0^h e^{A (h - tau)} B tau dtau``, read off one matrix
exponential of the augmented matrix ``[[A, B, 0], [0, 0, I], [0, 0, 0]] h``.
Compared with a zero-order hold this cuts the error about 100-fold at 1 ms
(docs/architecture.md, "Exact stepping"). It is also what the stiff ISO 7962 model needs: its
fastest pole is near -1.1e8 1/s, which any explicit integrator would follow.

Numpy only (no scipy): this module runs inside the FMUs.
"""

from typing import TYPE_CHECKING, Callable, Optional, Tuple, Union

import numpy as np

from .errors import BodyvibError
from .exact import StepCache, check_step, discretize, discretize_quadratic, expm
from .network import LinearModel, Network, as_linear_model
from .regimes import EventStepper
from .renames import renamed_parameters

if TYPE_CHECKING:  # for annotations only: the FMU run-time does not import it
    from numpy.typing import ArrayLike

__all__ = [
    "check_step",
    "expm",
    "discretize",
    "discretize_quadratic",
    "Discretization",
    "StepCache",
    "input_rates",
    "simulate",
]


class Discretization:
    """Exact discrete-time stepping of a linear model, cached per step size.

    Parameters
    ----------
    model : Network or LinearModel
        The continuous-time model.
    cache_digits : int
        Step sizes are compared rounded to this many significant digits, since
        communication steps computed by hosts are rarely bit-equal.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> d = Discretization(load_model("reduced-paper"))
    >>> x = d.step(d.zero_state(), [0.01, 0.0], [0.0, 0.0], 1e-3)
    >>> x.shape
    (5,)
    """

    def __init__(self, model: Union[Network, LinearModel], cache_digits: int = 12):
        self.model: LinearModel = as_linear_model(model)
        self._digits = cache_digits
        self._cache = StepCache(lambda key: discretize(self.model.A, self.model.B, key))

    def zero_state(self) -> np.ndarray:
        """The equilibrium state (all zeros)."""
        return np.zeros(self.model.A.shape[0])

    @renamed_parameters(h="step")
    def matrices(self, step: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(Phi, Gamma0, Gamma1)`` for ``step`` (computed once per rounded step)."""
        check_step(step)
        return self._cache.get(float(f"{step:.{self._digits}g}"))

    @renamed_parameters(h="step")
    def step(self, x: "ArrayLike", u: "ArrayLike", du: "ArrayLike", step: float) -> np.ndarray:
        """State after one step of length ``step`` from ``x`` with input ``u + du tau``."""
        Phi, G0, G1 = self.matrices(step)
        return Phi @ x + G0 @ np.asarray(u, float) + G1 @ np.asarray(du, float)

    @renamed_parameters(h="step")
    def run(
        self,
        u: np.ndarray,
        du: np.ndarray,
        step: float,
        safe_point: Optional[Callable[[], None]] = None,
    ) -> np.ndarray:
        """States over a uniform grid from the zero state: ``x[k+1] = Phi x[k] + G0 u[k] + G1 du[k]``.

        Parameters
        ----------
        u, du : (samples, inputs) ndarray
            Inputs at each sample and their rate over the step that starts there (the
            last row's rate is unused), in the model's input units.
        step : float
            The grid's step, s.
        safe_point : callable, optional
            Called with no argument every 4096 samples (a few tens of ms): where a
            command may stop a long run on a signal, by raising
            (:func:`bodyvib.process.interrupts.check`).

        Returns
        -------
        (samples, states) ndarray
            ``x[0] = 0``; the forcing of 4096 steps is formed at once, so a sample costs
            one state-matrix product.
        """
        Phi, G0, G1 = self.matrices(step)
        x = np.zeros((u.shape[0], Phi.shape[0]))
        for a in range(0, u.shape[0] - 1, 4096):  # the forcing of 4096 steps at once
            if safe_point is not None:
                safe_point()
            forcing = u[a : a + 4096] @ G0.T + du[a : a + 4096] @ G1.T
            for k in range(a, min(a + 4096, u.shape[0] - 1)):
                x[k + 1] = Phi @ x[k] + forcing[k - a]
        return x


def input_rates(model: LinearModel, u: np.ndarray) -> np.ndarray:
    """Default in-step input rates: each base displacement rises at its base velocity.

    Parameters
    ----------
    model : LinearModel
        Names the inputs (``<base>_displacement``, ``<base>_velocity``).
    u : (n, m) ndarray
        Input samples, columns as ``model.inputs``.

    Returns
    -------
    (n, m) ndarray
        Rate of each input over the step that starts at each sample: the base
        velocity for the base displacement, zero for the others.
    """
    du = np.zeros_like(u)
    for base in model.network.bases:
        du[:, model.input_index(f"{base}_displacement")] = u[
            :, model.input_index(f"{base}_velocity")
        ]
    return du


def simulate(
    model: Union[Network, LinearModel, "Discretization"],
    t: "ArrayLike",
    u: "ArrayLike",
    du: Optional["ArrayLike"] = None,
    x0: Optional["ArrayLike"] = None,
) -> Tuple[np.ndarray, np.ndarray]:
    """Exact discrete simulation on a time grid (uniform or not).

    Parameters
    ----------
    model : Network or LinearModel
        The model to simulate, from rest unless ``x0`` is given.
    t : (n,) array_like
        Strictly increasing times in s.
    u : (n, m) array_like
        Inputs at those times, columns as ``model.inputs`` (base displacement
        in m, base velocity in m/s, forces in N).
    du : (n, m) array_like, optional
        In-step input rates; by default the base velocity drives the base
        displacement and the other inputs are held (:func:`input_rates`).
    x0 : (ns,) array_like, optional
        Initial state (zero by default).

    Returns
    -------
    x : (n, ns) ndarray
        States at the grid times.
    y : (n, no) ndarray
        Outputs at the grid times (with the inputs at those times).

    Raises
    ------
    BodyvibError
        Non-finite input, a grid that does not increase, or mismatched shapes.
    """
    if isinstance(model, Network) and model.nonlinear_elements:
        return _simulate_regimes(model, t, u, du, x0)
    d = model if isinstance(model, Discretization) else Discretization(model)
    lm = d.model
    t, u, h = _checked_grid(lm, t, u)
    du = input_rates(lm, u) if du is None else np.asarray(du, dtype=float)
    x = np.zeros((t.size, lm.A.shape[0]))
    x[0] = d.zero_state() if x0 is None else x0
    for k in range(t.size - 1):
        x[k + 1] = d.step(x[k], u[k], du[k], float(h[k]))
    y = x @ lm.C.T + u @ lm.D.T
    return x, y


def _checked_grid(
    lm: LinearModel, t: "ArrayLike", u: "ArrayLike"
) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The time grid, the inputs and the steps of :func:`simulate`, checked."""
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float)
    if u.ndim != 2 or u.shape != (t.size, len(lm.inputs)):
        raise BodyvibError(
            f"inputs must have shape ({t.size}, {len(lm.inputs)}) for inputs "
            f"{', '.join(lm.inputs)}; got {u.shape}"
        )
    if not np.all(np.isfinite(u)):
        k = int(np.argwhere(~np.isfinite(u))[0, 0])
        raise BodyvibError(f"input is not finite at t = {t[k]:g} s; clean the input signal")
    h = np.diff(t)
    if np.any(~(h > 0)):
        raise BodyvibError("time grid must be strictly increasing")
    return t, u, h


def _simulate_regimes(
    network: Network,
    t: "ArrayLike",
    u: "ArrayLike",
    du: Optional["ArrayLike"],
    x0: Optional["ArrayLike"],
) -> Tuple[np.ndarray, np.ndarray]:
    """:func:`simulate` of a network with nonlinear elements: exact steps, located events.

    The outputs are those of the regime in force at each time (the linear model's, then
    a flag ``"<contact>.contact"`` per contact).
    """
    stepper = EventStepper(network)
    lm = stepper.regime.model
    t, u, h = _checked_grid(lm, t, u)
    du = input_rates(lm, u) if du is None else np.asarray(du, dtype=float)
    x = np.zeros((t.size, lm.A.shape[0]))
    if x0 is not None:
        x[0] = x0
    stepper.start(x[0], u[0])
    states = [stepper.state]
    for k in range(t.size - 1):
        x[k + 1] = stepper.step(x[k], u[k], du[k], float(h[k]), float(t[k]))
        states.append(stepper.state)
    first = stepper.model.regime(stepper.model.initial)
    y = x @ first.model.C.T + u @ first.model.D.T + first.d
    for k, state in enumerate(states):
        if state != stepper.model.initial:
            reg = stepper.model.regime(state)
            y[k] = reg.model.C @ x[k] + reg.model.D @ u[k] + reg.d
    return x, y
