"""Frequency responses of networks: transmissibility, apparent mass, peaks.

For harmonic base motion ``x_b = X_b e^{j w t}`` the base velocity input is
``j w X_b``, so the response of output ``y`` per unit base displacement is

    H(jw) = C (jw I - A)^{-1} (B_x + jw B_v) + D_x + jw D_v

where ``B_x, B_v`` (``D_x, D_v``) are the displacement and velocity columns.
The seat-to-head *transmissibility* is ``T = X_head / X_seat = A_head / A_seat``.
"""

from dataclasses import asdict, dataclass
from typing import Dict, List, Sequence

import numpy as np

from ..process import interrupts
from ..runtime.errors import BodyvibError
from ..runtime.network import as_linear_model

__all__ = [
    "control_labels",
    "to_statespace",
    "frequency_response",
    "transmissibility",
    "apparent_mass",
    "Peak",
    "find_peaks",
    "displacement_input_matrices",
    "displacement_input_statespace",
]


def control_labels(names) -> list:
    """Signal names as python-control accepts them ('.' replaced by '_').

    Parameters
    ----------
    names : sequence of str
        Signal names of a model (``"m1.x"``, ``"seat_displacement"``).

    Returns
    -------
    list of str
        The same names with ``.`` as ``_`` (``"m1_x"``), in the same order.
    """
    return [n.replace(".", "_") for n in names]


def to_statespace(model):
    """A model as a python-control ``StateSpace`` with named signals.

    Parameters
    ----------
    model : Network or LinearModel
        The model to name; a network is assembled first.

    Returns
    -------
    control.StateSpace
        All inputs (base displacement, base velocity, forces) and outputs;
        python-control forbids '.' in signal names, so ``m1.x`` is labelled
        ``m1_x`` there.

    Notes
    -----
    For a transmissibility, the base velocity input must be driven by ``s``
    times the displacement; see :func:`displacement_input_statespace`.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> to_statespace(load_model("reduced-paper")).nstates
    5
    """
    import control

    lm = as_linear_model(model)
    return control.ss(
        lm.A,
        lm.B,
        lm.C,
        lm.D,
        inputs=control_labels(lm.inputs),
        outputs=control_labels(lm.outputs),
        states=control_labels(lm.states),
        name=lm.network.name,
    )


def frequency_response(model, frequencies_hz, output, delays=None, gains=None) -> np.ndarray:
    """Complex response of one output (or several) per unit base displacement.

    Parameters
    ----------
    model : Network or LinearModel
        The model.
    frequencies_hz : array_like
        Frequencies in Hz.
    output : str or sequence of str
        Output name, e.g. ``"head.x"`` (a role may replace the mass name),
        ``"m2.a"`` or ``"seat_force"``; a list of names shares one solve.
    delays : sequence of float, optional
        A model driven at several base points (a half car): the delay of each
        base's motion behind the first's, s, one per base (the rear wheel of a
        car at speed ``v``: wheelbase / ``v``). By default every base moves
        together.
    gains : sequence of float, optional
        The amplitude of each base's motion relative to the first's, one per base (0
        leaves a base still: the left wheels of a car alone, for a cross-spectrum of its
        two tracks). By default 1 for every base.

    Raises
    ------
    BodyvibError
        ``delays`` or ``gains`` not one number per base.

    Returns
    -------
    ndarray of complex
        Output amplitude per metre of base displacement (output unit per m):
        ``(nf,)`` for one name, ``(len(output), nf)`` for a list.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> T = frequency_response(load_model("reduced-paper"), [0.0], "head.x")
    >>> float(round(abs(T[0]), 12))
    1.0
    """
    lm = as_linear_model(model)
    f = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    one = isinstance(output, str)
    idx = [lm.output_index(o) for o in ([output] if one else output)]
    nb = len(lm.network.bases)
    tau = np.zeros(nb) if delays is None else np.asarray(delays, dtype=float)
    if tau.shape != (nb,):
        raise BodyvibError(
            f"delays: give one delay (s) per base point of '{lm.network.name}' "
            f"({', '.join(lm.network.bases)}), got {tau.size}"
        )
    g = np.ones(nb) if gains is None else np.asarray(gains, dtype=float)
    if g.shape != (nb,):
        raise BodyvibError(
            f"gains: give one gain per base point of '{lm.network.name}' "
            f"({', '.join(lm.network.bases)}), got {g.size}"
        )
    s = 2j * np.pi * f
    n = lm.A.shape[0]
    out = np.empty((len(idx), s.size), dtype=complex)
    for a in range(0, s.size, _CHUNK):  # (chunk, n, n) at a time: memory independent of nf
        interrupts.check()
        sc = s[a : a + _CHUNK]
        # base j moves as the first, delayed by tau[j] and scaled by g[j]: its inputs
        # weighted by g[j] exp(-s tau[j])
        lags = [gj * (np.exp(-sc * t)[:, None] if t else 1.0) for t, gj in zip(tau, g)]
        rhs = sum(
            lag * (lm.B[:, 2 * j][None, :] + sc[:, None] * lm.B[:, 2 * j + 1][None, :])
            for j, lag in enumerate(lags)
        )  # (nf, n)
        lhs = sc[:, None, None] * np.eye(n)[None] - lm.A[None]
        x = np.linalg.solve(lhs, rhs[..., None])[..., 0]
        for r, i in enumerate(idx):
            y = x @ lm.C[i]
            for j, lag in enumerate(lags):
                lag = lag if np.isscalar(lag) else lag[:, 0]
                y = y + lag * lm.D[i, 2 * j] + lag * sc * lm.D[i, 2 * j + 1]
            out[r, a : a + _CHUNK] = y
    return out[0] if one else out


#: Frequencies solved at once by :func:`frequency_response`.
_CHUNK = 4096


def transmissibility(model, frequencies_hz, point: str = "head") -> np.ndarray:
    """Seat-to-point transmissibility ``X_point / X_base`` (dimensionless, complex).

    Parameters
    ----------
    model : Network or LinearModel
        A body model (or a car, with a point on it).
    frequencies_hz : array_like
        Frequencies in Hz.
    point : str
        Role or mass name; the head by default.

    Returns
    -------
    ndarray of complex
    """
    return frequency_response(model, frequencies_hz, f"{point}.x")


def apparent_mass(model, frequencies_hz) -> np.ndarray:
    """Apparent mass ``F_base / A_base`` in kg (complex), for frequencies > 0 Hz.

    As the frequency goes to 0 it tends to the total mass (the static
    apparent mass).

    Parameters
    ----------
    model : Network or LinearModel
        A body model on its base (the seat).
    frequencies_hz : array_like
        Frequencies in Hz, all above 0.

    Returns
    -------
    ndarray of complex
        Base force per base acceleration, kg.

    Raises
    ------
    BodyvibError
        If a frequency is not positive.
    """
    f = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    if np.any(f <= 0):
        raise BodyvibError("apparent mass needs frequencies above 0 Hz")
    lm = as_linear_model(model)
    w = 2 * np.pi * f
    return frequency_response(lm, f, f"{lm.network.base}_force") / (-(w**2))


@dataclass(frozen=True)
class Peak:
    """A peak of a modulus curve: where (``frequency_hz``, Hz) and how high (``modulus``, the
    curve's value: dimensionless for a transmissibility, kg for an apparent mass)."""

    frequency_hz: float
    modulus: float

    def to_dict(self) -> Dict[str, float]:
        """``{"frequency_hz", "modulus"}`` for JSON."""
        return asdict(self)


def find_peaks(
    frequencies_hz: Sequence[float], modulus: Sequence[float], min_prominence: float = 0.01
) -> List[Peak]:
    """Local maxima of a modulus curve, refined by a parabola through 3 points.

    Parameters
    ----------
    frequencies_hz : sequence of float
        Increasing frequencies in Hz.
    modulus : sequence of float
        ``|T|`` at those frequencies.
    min_prominence : float
        A maximum counts when it stands this much (absolute) above the lowest
        value between it and the next higher ground on either side.

    Returns
    -------
    list of Peak
        In increasing frequency.

    Examples
    --------
    >>> f = np.linspace(0.0, 2.0, 21)
    >>> [(round(p.frequency_hz, 6), round(p.modulus, 6)) for p in find_peaks(f, 1 - (f - 1) ** 2)]
    [(1.0, 1.0)]
    """
    f = np.asarray(frequencies_hz, dtype=float)
    m = np.asarray(modulus, dtype=float)
    peaks = []
    for i in range(1, len(m) - 1):
        if not (m[i] > m[i - 1] and m[i] >= m[i + 1]):
            continue
        left = m[: i + 1]
        higher_left = np.nonzero(left > m[i])[0]
        lmin = left[higher_left[-1] :].min() if higher_left.size else left.min()
        right = m[i:]
        higher_right = np.nonzero(right > m[i])[0]
        rmin = right[: higher_right[0] + 1].min() if higher_right.size else right.min()
        if m[i] - max(lmin, rmin) < min_prominence:
            continue
        # parabolic refinement (uniform or not: fit through the three points)
        x, y = f[i - 1 : i + 2], m[i - 1 : i + 2]
        a, b, c = np.polyfit(x - f[i], y, 2)
        if a < 0:
            dx = -b / (2 * a)
            fp, mp = f[i] + dx, c - b * b / (4 * a)
            if not (x[0] <= fp <= x[2]):
                fp, mp = f[i], m[i]
        else:
            fp, mp = f[i], m[i]
        peaks.append(Peak(frequency_hz=float(fp), modulus=float(mp)))
    return peaks


def displacement_input_matrices(model):
    """State-space matrices of a model driven by base displacement alone (numpy only).

    Eliminates the base-velocity input by the state change
    ``w = x - B_v x_b``: ``w' = A w + (A B_v + B_x) x_b``,
    ``y = C w + (C B_v + D_x) x_b``. Exact when ``D_v = 0`` (no damper from
    the base straight into an acceleration or force output).

    Parameters
    ----------
    model : Network or LinearModel
        A model with a base (displacement and velocity inputs).

    Returns
    -------
    A : ndarray, shape (n, n)
    B : ndarray, shape (n, 1)
    C : ndarray, shape (p, n)
        All outputs, in the model's output order.
    D : ndarray, shape (p, 1)

    Raises
    ------
    BodyvibError
        If some output depends on base velocity directly (improper in x_b).
    """
    lm = as_linear_model(model)
    Bx, Bv = lm.B[:, 0], lm.B[:, 1]
    if np.any(lm.D[:, 1] != 0):
        bad = [lm.outputs[i] for i in np.nonzero(lm.D[:, 1])[0]]
        raise BodyvibError(
            "outputs " + ", ".join(bad) + " depend on base velocity directly; "
            "use frequency_response() instead"
        )
    return lm.A, (lm.A @ Bv + Bx)[:, None], lm.C, (lm.C @ Bv + lm.D[:, 0])[:, None]


def displacement_input_statespace(model):
    """Single-input python-control ``StateSpace`` driven by base displacement.

    The matrices of :func:`displacement_input_matrices`, named.

    Parameters
    ----------
    model : Network or LinearModel
        As in :func:`displacement_input_matrices`.

    Returns
    -------
    control.StateSpace
        One input (base displacement), all outputs, named.

    Raises
    ------
    BodyvibError
        If some output depends on base velocity directly (improper in x_b).
    """
    import control

    lm = as_linear_model(model)
    A, B, C, D = displacement_input_matrices(lm)
    return control.ss(
        A,
        B,
        C,
        D,
        inputs=control_labels(lm.inputs[:1]),
        outputs=control_labels(lm.outputs),
        name=lm.network.name,
    )
