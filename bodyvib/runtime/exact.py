"""The exact step's numerics: the matrix exponential and the step matrices, cached.

For a step ``h`` with the input ``u_k + du_k tau`` the update of ``x' = A x + B u`` is
``x_{k+1} = Phi x_k + Gamma0 u_k + Gamma1 du_k``, read off one matrix exponential of an
augmented matrix (:func:`discretize`). :mod:`bodyvib.runtime.discretize` steps linear
models with it, :mod:`bodyvib.runtime.regimes` each regime of a piecewise-affine one.

Numpy only (no scipy): this module runs inside the FMUs.
"""

import math
from typing import Any, Callable, List, Tuple

import numpy as np

from .errors import BodyvibError
from .renames import renamed_parameters

__all__ = ["check_step", "expm", "discretize", "discretize_quadratic", "StepCache"]

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
