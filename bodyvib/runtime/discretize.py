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

import math
from typing import TYPE_CHECKING, Any, Callable, List, Optional, Tuple, Union

import numpy as np

from .errors import BodyvibError
from .network import LinearModel, Network, as_linear_model
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

# Pade(13) coefficients and the scaling threshold of Higham (2005).
_B13 = (
    64764752532480000.0,
    32382376266240000.0,
    7771770303897600.0,
    1187353796428800.0,
    129060195264000.0,
    10559470521600.0,
    670442572800.0,
    33522128640.0,
    1323241920.0,
    40840800.0,
    960960.0,
    16380.0,
    182.0,
    1.0,
)
_THETA13 = 5.371920351148152


@renamed_parameters(h="step")
def check_step(step: float, what: str = "step size") -> None:
    """Refuse a step that is not a positive finite number of seconds.

    Raises
    ------
    BodyvibError
        ``"<what> must be a positive finite number of seconds, got <step>"``.
    """
    if not (isinstance(step, (int, float, np.floating)) and math.isfinite(step) and step > 0):
        raise BodyvibError(f"{what} must be a positive finite number of seconds, got {step!r}")


def expm(M: np.ndarray) -> np.ndarray:
    """Matrix exponential by scaling and squaring with a degree-13 Pade approximant.

    Parameters
    ----------
    M : (n, n) ndarray
        Real square matrix.

    Returns
    -------
    (n, n) ndarray

    References
    ----------
    N. J. Higham, "The scaling and squaring method for the matrix exponential
    revisited", SIAM J. Matrix Anal. Appl. 26(4), 2005.
    A. H. Al-Mohy, N. J. Higham, "A new scaling and squaring algorithm for the
    matrix exponential", SIAM J. Matrix Anal. Appl. 31(3), 2009.
    """
    M = np.asarray(M, dtype=float)
    # Scaling from norms of powers (Al-Mohy & Higham 2009, eta_5): for the
    # non-normal, stiff matrices of massless-node models ||M|| overstates the
    # needed scaling by orders of magnitude, and every extra squaring costs
    # accuracy. The matrices are small, so the powers are formed exactly.
    M2 = M @ M
    M4 = M2 @ M2
    M6 = M4 @ M2
    d6 = np.linalg.norm(M6, 1) ** (1 / 6)
    d8 = np.linalg.norm(M4 @ M4, 1) ** (1 / 8)
    d10 = np.linalg.norm(M4 @ M6, 1) ** (1 / 10)
    eta = min(max(d6, d8), max(d8, d10))
    s = max(0, int(math.ceil(math.log2(eta / _THETA13)))) if eta > 0 else 0
    A = M / (2.0**s)
    b = _B13
    ident = np.eye(A.shape[0])
    A2, A4, A6 = M2 / 4.0**s, M4 / 16.0**s, M6 / 64.0**s
    U = A @ (
        A6 @ (b[13] * A6 + b[11] * A4 + b[9] * A2)
        + b[7] * A6
        + b[5] * A4
        + b[3] * A2
        + b[1] * ident
    )
    V = (
        A6 @ (b[12] * A6 + b[10] * A4 + b[8] * A2)
        + b[6] * A6
        + b[4] * A4
        + b[2] * A2
        + b[0] * ident
    )
    E = np.linalg.solve(V - U, V + U)
    for _ in range(s):
        E = E @ E
    return E


@renamed_parameters(h="step")
def discretize(
    A: np.ndarray, B: np.ndarray, step: float
) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact step matrices ``Phi, Gamma0, Gamma1`` for input ``u_k + du_k tau``.

    Parameters
    ----------
    A : (n, n) ndarray
        State matrix of ``x' = A x + B u`` (1/s).
    B : (n, m) ndarray
        Input matrix (state units per input unit and second).
    step : float
        Step length ``h`` in seconds, positive and finite.

    Returns
    -------
    Phi : (n, n) ndarray
        State transition ``e^{A h}``.
    Gamma0 : (n, m) ndarray
        Zero-order-hold input matrix.
    Gamma1 : (n, m) ndarray
        Input-rate matrix (multiplies ``du_k``).

    Raises
    ------
    BodyvibError
        If ``step`` is not a positive finite number.
    """
    Phi, (Gamma0, Gamma1) = _input_blocks(A, B, step, 2)
    return Phi, Gamma0, Gamma1


def _input_blocks(
    A: np.ndarray, B: np.ndarray, h: float, blocks: int
) -> Tuple[np.ndarray, List[np.ndarray]]:
    """``Phi`` and ``[Gamma_0, .., Gamma_{blocks-1}]`` from one exponential of :func:`_augmented`."""
    check_step(h)
    n, m = B.shape
    E = expm(_augmented(A, B, blocks) * h)
    return E[:n, :n], [E[:n, n + j * m : n + (j + 1) * m] for j in range(blocks)]


def _augmented(A: np.ndarray, B: np.ndarray, blocks: int) -> np.ndarray:
    """``[[A, B, 0, ..], [0, 0, I, ..], .., [0, .., 0]]`` with ``blocks`` input blocks.

    Its exponential times ``h`` holds ``Phi`` and, in the first block row,
    ``Gamma_j = int_0^h e^{A (h - tau)} B tau^j / j! dtau`` for ``j < blocks``:
    the input and each of its chained rates are states whose derivative is the next.
    """
    n, m = B.shape
    M = np.zeros((n + blocks * m, n + blocks * m))
    M[:n, :n] = A
    M[:n, n : n + m] = B
    for j in range(1, blocks):
        M[n + (j - 1) * m : n + j * m, n + j * m : n + (j + 1) * m] = np.eye(m)
    return M


@renamed_parameters(h="step")
def discretize_quadratic(A: np.ndarray, B: np.ndarray, step: float) -> np.ndarray:
    """The step matrix ``Gamma2`` of an input's curvature: input ``u_k + du_k tau + d2u_k tau^2 / 2``.

    ``Gamma2 = int_0^h e^{A (h - tau)} B tau^2 / 2 dtau`` (multiplies ``d2u_k``),
    read off the matrix exponential of ``[[A, B, 0, 0], [0, 0, I, 0],
    [0, 0, 0, I], [0, 0, 0, 0]] h``; with :func:`discretize`'s matrices the update
    ``x_{k+1} = Phi x_k + Gamma0 u_k + Gamma1 du_k + Gamma2 d2u_k`` is exact for a
    quadratic input.

    Parameters
    ----------
    A, B, step
        As in :func:`discretize`.

    Returns
    -------
    (n, m) ndarray
        ``Gamma2``.

    Raises
    ------
    BodyvibError
        If ``step`` is not a positive finite number (:func:`check_step`).
    """
    return _input_blocks(A, B, step, 3)[1][2]


class StepCache:
    """Matrices computed once per step size, memory bounded: the run-time's one cache.

    A run steps at one or a few sizes; a host that varies its step without end would grow
    a plain dict, so past ``limit`` entries the cache starts over.

    Parameters
    ----------
    compute : callable
        ``compute(h)`` gives the value for step ``h``.
    limit : int
        Most entries kept.

    Examples
    --------
    >>> c = StepCache(lambda h: 2 * h)
    >>> c.get(1e-3), len(c)
    (0.002, 1)
    """

    def __init__(self, compute: Callable[[float], Any], limit: int = 64):
        self._compute = compute
        self._limit = int(limit)
        self._values: dict = {}

    def __len__(self) -> int:
        return len(self._values)

    @renamed_parameters(h="step")
    def get(self, step: float) -> Any:
        """The value for ``step``, computed on first use."""
        value = self._values.get(step)
        if value is None:
            value = self._compute(step)
            if len(self._values) > self._limit:
                self._values.clear()
            self._values[step] = value
        return value

    @renamed_parameters(h="step")
    def discard(self, step: float) -> None:
        """Forget the value of ``step`` (e.g. one found unusable)."""
        self._values.pop(step, None)


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
    d = model if isinstance(model, Discretization) else Discretization(model)
    lm = d.model
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
    du = input_rates(lm, u) if du is None else np.asarray(du, dtype=float)
    x = np.zeros((t.size, lm.A.shape[0]))
    x[0] = d.zero_state() if x0 is None else x0
    for k in range(t.size - 1):
        x[k + 1] = d.step(x[k], u[k], du[k], float(h[k]))
    y = x @ lm.C.T + u @ lm.D.T
    return x, y
