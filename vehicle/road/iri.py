"""International Roughness Index of a longitudinal profile (Sayers 1986, ASTM E1926).

The IRI is the accumulated suspension travel of a reference quarter car, the
*Golden Car*, driven over the profile at 80 km/h, per distance travelled. Its
parameters are per unit sprung mass (:data:`GOLDEN_CAR`):
``k_t/m_s = 653 s^-2``, ``k_s/m_s = 63.3 s^-2``, ``c_s/m_s = 6.0 s^-1``,
``m_u/m_s = 0.15``. With ``z_s, z_u`` the sprung and unsprung heights and
``z_r`` the profile under the tire::

    z_s'' = -k_s/m_s (z_s - z_u) - c_s/m_s (z_s' - z_u')
    m_u/m_s z_u'' = k_s/m_s (z_s - z_u) + c_s/m_s (z_s' - z_u') - k_t/m_s (z_u - z_r)

    IRI = 1/L int_0^{L/V} |z_s' - z_u'| dt      (m/m; x 1000 for m/km)

(evaluated as ASTM E1926 evaluates it, the mean over the samples; see below).

Before the car sees it the profile is smoothed by a 250 mm moving average
(the tire's enveloping; ``round(0.25 m / dx)`` samples, none when the spacing
is 0.25 m or coarser). The car is then simulated exactly: its state space is
discretized by :func:`bodyvib.runtime.exact.discretize` with the profile
*linear between samples* (at 80 km/h a straight line in distance is one in
time), so the suspension velocity at the samples carries no integration
error (the recursion runs mode by mode in compiled code: 10 km at 25 mm in
under a second). The IRI is the standard's average of the rectified slope: the plain
mean of ``|z_s' - z_u'| / V`` at the ends of the ``n - 1`` steps. The car starts as ASTM E1926
starts it: both masses at the profile's first height, moving with the mean
slope of the first 11 m.

For a sinusoidal profile ``a sin(2 pi x / lambda)`` (at steady state) the
suspension velocity is a sine of amplitude ``a M |H(2 pi V / lambda)|``, with
``H`` the Golden Car's response from ``z_r`` to ``z_s' - z_u'`` and
``M = sin(pi b / lambda) / (pi b / lambda)`` the moving average's attenuation
(``b = 0.25 m``), so ``IRI = 2/pi a M |H| / V``; tests check that.
"""

import math
from dataclasses import dataclass
from typing import Dict, Tuple

import numpy as np

from bodyvib.runtime.discretize import discretize
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.renames import renamed_fields

from ..records import Record

__all__ = [
    "GOLDEN_CAR",
    "IRI_SPEED_M_S",
    "SMOOTHING_BASE_M",
    "START_BASE_M",
    "golden_car",
    "moving_average",
    "IriResult",
    "international_roughness_index",
]

#: The Golden Car per unit sprung mass (Sayers 1986; ASTM E1926): tire and
#: suspension stiffness [s^-2], suspension damping [s^-1], mass ratio [-].
GOLDEN_CAR: Dict[str, float] = {"kt": 653.0, "ks": 63.3, "cs": 6.0, "mu": 0.15}
#: Simulated speed, m/s (80 km/h).
IRI_SPEED_M_S = 80.0 / 3.6
#: Base length of the moving average that stands for the tire's enveloping, m.
SMOOTHING_BASE_M = 0.25
#: Distance over which ASTM E1926 takes the car's initial slope, m.
START_BASE_M = 11.0


def golden_car() -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """State space of the Golden Car: ``x' = A x + B z_r``, suspension velocity ``C x``.

    Returns
    -------
    A : (4, 4) ndarray
        States ``[z_s, z_s', z_u, z_u']`` (m, m/s).
    B : (4, 1) ndarray
        Input: profile height under the tire, m.
    C : (1, 4) ndarray
        Output: suspension velocity ``z_s' - z_u'``, m/s.

    Examples
    --------
    >>> A, B, C = golden_car()
    >>> A.shape, B.shape, C.shape
    ((4, 4), (4, 1), (1, 4))
    """
    g = GOLDEN_CAR
    A = np.array(
        [
            [0.0, 1.0, 0.0, 0.0],
            [-g["ks"], -g["cs"], g["ks"], g["cs"]],
            [0.0, 0.0, 0.0, 1.0],
            [
                g["ks"] / g["mu"],
                g["cs"] / g["mu"],
                -(g["ks"] + g["kt"]) / g["mu"],
                -g["cs"] / g["mu"],
            ],
        ]
    )
    B = np.array([[0.0], [0.0], [0.0], [g["kt"] / g["mu"]]])
    C = np.array([[0.0, 1.0, 0.0, -1.0]])
    return A, B, C


def _recursion(Phi, forcing, x0):
    """States of ``x_{j+1} = Phi x_j + f_j`` from ``x_0``, as ``(n, steps + 1)``.

    Evaluated in Phi's eigenvector basis: each mode is the first-order recursion
    ``q_{j+1} = lambda q_j + (V^-1 f)_j``, which :func:`scipy.signal.lfilter` runs
    in compiled code (the Golden Car's four eigenvalues are distinct and its
    eigenvector matrix well conditioned, cond < 1e2, so this loses nothing
    measurable against stepping ``Phi`` directly: 1e-13 relative).
    """
    from scipy.signal import lfilter

    lam, V = np.linalg.eig(Phi)
    Vinv = np.linalg.inv(V)
    q0 = Vinv @ x0
    f = Vinv @ forcing
    q = np.empty((lam.size, forcing.shape[1] + 1), dtype=complex)
    q[:, 0] = q0
    for i, li in enumerate(lam):
        q[:, 1:][i] = lfilter([1.0], [1.0, -li], f[i], zi=[li * q0[i]])[0]
    return np.real(V @ q)


def _check_profile(distance, elevation):
    x = np.asarray(distance, dtype=float)
    z = np.asarray(elevation, dtype=float)
    if x.ndim != 1 or z.shape != x.shape:
        raise BodyvibError(
            f"distance and elevation must be 1-D arrays of one length, got {x.shape} and {z.shape}"
        )
    if x.size < 3:
        raise BodyvibError("a profile needs at least 3 samples")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(z))):
        raise BodyvibError("the profile holds NaN or infinite values; fill or cut the gaps")
    dx = np.diff(x)
    if np.any(dx <= 0):
        k = int(np.argmax(dx <= 0))
        raise BodyvibError(f"profile distances must increase; they do not at {x[k + 1]:g} m")
    spacing = (x[-1] - x[0]) / (x.size - 1)
    if np.max(np.abs(dx - spacing)) > 1e-6 * spacing + 1e-9:
        raise BodyvibError(
            "profile distances are not uniformly spaced (spacing varies from "
            f"{dx.min():g} to {dx.max():g} m); resample it to a constant spacing"
        )
    return x, z, float(spacing)


def moving_average(elevation, spacing: float, base: float = SMOOTHING_BASE_M) -> np.ndarray:
    """The profile smoothed by a moving average of ``base`` metres (ASTM E1926).

    Parameters
    ----------
    elevation : (n,) array_like
        Heights, m, every ``spacing`` metres.
    spacing : float
        Sample spacing, m.
    base : float
        Base length, m (0.25 m: the tire's enveloping).

    Returns
    -------
    ndarray
        Means of ``k = round(base / spacing)`` consecutive samples (``n - k + 1``
        values); the profile unchanged if ``k <= 1``.

    Examples
    --------
    >>> moving_average([0.0, 1.0, 2.0, 3.0], 0.125)
    array([0.5, 1.5, 2.5])
    """
    z = np.asarray(elevation, dtype=float)
    k = int(round(base / spacing))
    if k <= 1:
        return z.copy()
    if k > z.size:
        raise BodyvibError(
            f"the profile ({z.size} samples) is shorter than the {base:g} m moving average"
        )
    c = np.concatenate([[0.0], np.cumsum(z)])
    return (c[k:] - c[:-k]) / k


@renamed_fields(speed_m_s="speed")
@dataclass(frozen=True)
class IriResult(Record):
    """The International Roughness Index of a profile.

    Attributes
    ----------
    iri_m_per_km : float
        IRI, m/km (= mm/m).
    length_m : float
        Distance over which the suspension travel was accumulated, m.
    speed : float
        Simulated speed, m/s (``speed_m_s`` still works for one release, with a
        ``DeprecationWarning``).
    smoothing_samples : int
        Samples of the 250 mm moving average (1: none).
    """

    iri_m_per_km: float
    length_m: float
    speed: float
    smoothing_samples: int


def international_roughness_index(
    distance, elevation, speed: float = IRI_SPEED_M_S, smooth: bool = True, initial_state=None
) -> IriResult:
    """IRI of a uniformly spaced profile: the Golden Car simulated exactly over it.

    Parameters
    ----------
    distance : (n,) array_like
        Distances, m, increasing at a constant spacing.
    elevation : (n,) array_like
        Profile heights, m.
    speed : float
        Simulated speed, m/s (80 km/h by definition; other speeds for study).
    smooth : bool
        Apply the 250 mm moving average first (the standard does).
    initial_state : (4,) array_like, optional
        ``[z_s, z_s', z_u, z_u']`` at the first (smoothed) sample; by default
        ASTM E1926's start: both masses at the first height with the mean slope
        of the first 11 m times the speed.

    Returns
    -------
    IriResult

    Raises
    ------
    BodyvibError
        Fewer than 3 samples, NaN, distances that do not increase or are not
        uniform, a non-positive speed, a profile shorter than the moving average.

    Examples
    --------
    >>> x = np.arange(0, 200, 0.05)
    >>> round(international_roughness_index(x, 0 * x).iri_m_per_km, 6)
    0.0
    """
    x, z, dx = _check_profile(distance, elevation)
    if not (isinstance(speed, (int, float)) and math.isfinite(speed) and speed > 0):
        raise BodyvibError(f"speed must be a positive number of m/s, got {speed!r}")
    zr = moving_average(z, dx) if smooth else z.copy()
    k = int(round(SMOOTHING_BASE_M / dx)) if smooth else 1
    A, B, C = golden_car()
    h = dx / speed
    Phi, G0, G1 = discretize(A, B, h)
    g0, g1 = G0[:, 0], G1[:, 0]
    rate = np.diff(zr) / h  # profile linear between samples: dz_r/dt
    if initial_state is None:
        m = min(zr.size - 1, max(1, int(round(START_BASE_M / dx))))
        v0 = (zr[m] - zr[0]) / (m * dx) * speed
        state = np.array([zr[0], v0, zr[0], v0])
    else:
        state = np.asarray(initial_state, dtype=float).reshape(4)
    rel = C[0] @ _recursion(Phi, np.outer(g0, zr[:-1]) + np.outer(g1, rate), state)
    # ASTM E1926: the mean of the rectified slope (z_s' - z_u') / V at the ends of the
    # n - 1 steps, each with the same weight
    slope = np.abs(rel[1:]) / speed
    length = (zr.size - 1) * dx
    return IriResult(
        iri_m_per_km=float(1000.0 * slope.mean()),
        length_m=float(length),
        speed=float(speed),
        smoothing_samples=k,
    )
