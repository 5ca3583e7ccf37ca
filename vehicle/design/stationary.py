"""Stationary r.m.s. response of a linear car model on an ISO 8608 road, without simulation.

An ISO 8608 road of waviness ``w = 2`` has the displacement PSD
``Gd(n) = Gd(n0) (n / n0)^-2`` (``n0 = 0.1`` cycle/m). Driven at speed ``V`` its
*velocity* in time is white: the one-sided PSD of ``dz/dt`` is

    ``G_v = (2 pi n0)^2 Gd(n0) V``  [m^2/s^2/Hz],

the same at every frequency. A white noise ``w(t)`` with
``E[w(t) w(t + tau)] = W delta(tau)`` has the two-sided PSD ``W`` over
``-inf < f < inf``, so its one-sided PSD is ``2 W``: the noise intensity of the road
velocity is ``W = G_v / 2 = 2 pi^2 n0^2 Gd(n0) V`` (:func:`road_velocity_intensity`).

The road displacement is the integral of that noise, a random walk, and a car
follows it at zero frequency. The states are therefore taken relative to the
static response to the road: with ``x' = A x + B_z z + B_v z'`` and
``e = -A^-1 B_z`` (the state of the car lifted by a unit road step, at rest),
``x~ = x - e z`` obeys ``x~' = A x~ + (B_v - e) w``, driven by the white noise
alone. An output ``y = C x + D_z z + D_v z'`` is ``C x~ + (C e + D_z) z + D_v w``;
its variance is finite when it does not follow the road statically
(``C e + D_z = 0``: accelerations, deflections, element forces, not absolute
displacements) and has no direct white-noise term (``D_v = 0``).

The ISO 2631-1 Wk weighting (:func:`bodyvib.comfort.wk_statespace`, Annex A) is a
rational filter: the weighted outputs are filters appended to the state, fed by
``y``. The stationary covariance of the whole state solves the Lyapunov equation

    ``A_a P + P A_a^T + B_a W B_a^T = 0``

and an output row ``c`` has the mean square ``c P c^T``. Every output scales with
``sqrt(W)``, i.e. with ``sqrt(Gd(n0) V)``: the r.m.s. on class C at 20 m/s is twice
that on class B (or on class C at 5 m/s). The road is the ideal one, without the band
limits (0.011-2.83 cycle/m) of the synthesized roads of ``bodyvib cosim``: the
Wk-weighted head and seat accelerations differ by less than 2e-4 from 10 m/s up
(5e-6 at 20 m/s), by 0.4 % (head) and 0.9 % (seat) at 5 m/s, where the band ends
at 14 Hz. Unweighted accelerations and forces with content above the band differ
more.
"""

import math
from dataclasses import dataclass
from typing import Sequence, Tuple

import numpy as np
import scipy.linalg

from bodyvib.comfort import wk_statespace
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.network import LinearModel

from ..road.synthetic import N0, class_psd_n0

__all__ = [
    "GRAVITY",
    "RandomResponse",
    "road_velocity_intensity",
    "static_wheel_load",
    "random_response",
    "unit_rms",
    "unit_mean_product",
    "stationary_outputs",
]

#: Standard gravity, m/s2 (for the static wheel load).
GRAVITY = 9.80665


def road_velocity_intensity(road_class: str, speed: float) -> float:
    """Intensity ``W`` of the white road velocity of an ISO 8608 class at a speed.

    Parameters
    ----------
    road_class : str
        ``"A"`` ... ``"H"``.
    speed : float
        m/s, positive.

    Returns
    -------
    float
        ``W = 2 pi^2 n0^2 Gd(n0) V`` in m^2/s^3: half the one-sided PSD of the road
        velocity (``E[w(t) w(t + tau)] = W delta(tau)``).

    Raises
    ------
    BodyvibError
        A class other than ``"A"`` to ``"H"``, or a speed that is not positive.

    Examples
    --------
    >>> round(road_velocity_intensity("C", 20.0), 9)  # 2 pi^2 0.01 256e-6 20
    0.001010647
    """
    v = float(speed)
    if not (math.isfinite(v) and v > 0):
        raise BodyvibError(f"speed must be a positive number of m/s, not {speed!r}")
    return 2.0 * math.pi**2 * N0**2 * class_psd_n0(road_class) * v


def static_wheel_load(lm: LinearModel) -> float:
    """Static load on the wheel of a quarter car, ``g`` times the mass it carries (N).

    Parameters
    ----------
    lm : LinearModel
        A quarter car with or without occupant: every mass of the network rests on
        its one tire (sprung, unsprung and the occupant's masses).

    Returns
    -------
    float

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> from bodyvib.runtime.network import linear_model
    >>> round(static_wheel_load(linear_model(load_car())), 3)  # (290 + 59) g
    3422.521
    """
    return lm.network.total_mass() * GRAVITY


def stationary_outputs(lm: LinearModel) -> Tuple[bool, ...]:
    """Which outputs have a finite stationary variance on a white-velocity road.

    Parameters
    ----------
    lm : LinearModel
        Inputs ``road_displacement`` and ``road_velocity``.

    Returns
    -------
    tuple of bool
        Per output: it does not follow the road statically and has no direct
        road-velocity term (module docstring). Absolute displacements are not.

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> from bodyvib.runtime.network import linear_model
    >>> lm = linear_model(load_car())
    >>> dict(zip(lm.outputs, stationary_outputs(lm)))["sprung.x"]
    False
    """
    if len(lm.network.bases) > 1:
        # the road points' heights differ by stationary amounts (a delay, the other
        # track): an output is stationary when the road's common rise leaves it as it
        # was (its static gains sum to zero) and no road velocity enters it directly
        gains = [_relative(lm, iz, iv)[1:] for iz, iv in road_inputs(lm)]
        total = sum(K for K, _ in gains)
        scale = sum(np.abs(K) for K, _ in gains)
        ok = np.abs(total) <= 1e-9 * np.maximum(scale, 1e-300)
        for _, Dv in gains:
            ok &= Dv == 0
        return tuple(bool(v) for v in ok)
    _, K, Dv = _relative(lm)
    return tuple(bool(k == 0 and d == 0) for k, d in zip(K, Dv))


def _relative(lm, iz=None, iv=None):
    """``(Bw, K, Dv)``: noise column of the relative state, static road gains, direct terms
    (of the road point whose inputs are ``iz``, ``iv``; by default the one road)."""
    if iz is None:
        iz, iv = lm.input_index("road_displacement"), lm.input_index("road_velocity")
    A = lm.A
    try:
        e = -np.linalg.solve(A, lm.B[:, iz])
    except np.linalg.LinAlgError:
        raise BodyvibError(
            "the model has a free rigid mode (singular A): it does not rest on the road"
        ) from None
    K = lm.C @ e + lm.D[:, iz]
    scale = np.abs(lm.C).sum(axis=1) * np.abs(e).max() + np.abs(lm.D[:, iz])
    K = np.where(np.abs(K) <= 1e-9 * np.maximum(scale, 1e-300), 0.0, K)
    Dv = np.where(np.abs(lm.D[:, iv]) <= 1e-12 * np.abs(lm.D).max(initial=1.0), 0.0, lm.D[:, iv])
    return lm.B[:, iv] - e, K, Dv


_WK = []


def _wk():
    """Wk's ``(A, B, C)``, built once (its ``D`` is zero: the low pass is strictly proper)."""
    if not _WK:
        A, B, C, _ = wk_statespace()
        _WK.extend((A, B, C))
    return _WK


def unit_rms(lm: LinearModel, rows: Sequence[int], weighted_rows: Sequence[int] = ()):
    """R.m.s. of outputs for a unit road-velocity intensity (``W = 1``).

    The kernel of :func:`random_response`: one Lyapunov solve; multiply by
    ``sqrt(W)`` (:func:`road_velocity_intensity`) for a road and speed.

    Parameters
    ----------
    lm : LinearModel
        Inputs ``road_displacement`` and ``road_velocity``.
    rows : sequence of int
        Output indices whose plain r.m.s. is wanted.
    weighted_rows : sequence of int
        Output indices (accelerations) whose Wk-weighted r.m.s. is wanted.

    Returns
    -------
    rms, weighted : ndarray
        In the outputs' units per ``sqrt(m^2/s^3)``; ``inf`` where the output is not
        stationary (:func:`stationary_outputs`) or the model is not asymptotically
        stable.
    """
    rows, wrows = list(rows), list(weighted_rows)
    Bw, K, Dv = _relative(lm)
    n = lm.A.shape[0]
    if not np.all(np.linalg.eigvals(lm.A).real < 0):
        return np.full(len(rows), np.inf), np.full(len(wrows), np.inf)
    Aw, Bwk, Cw = _wk()
    nw = Aw.shape[0]
    N = n + nw * len(wrows)
    A = np.zeros((N, N))
    B = np.zeros(N)
    C = np.zeros((len(rows) + len(wrows), N))
    A[:n, :n] = lm.A
    B[:n] = Bw
    C[: len(rows), :n] = lm.C[rows]
    for j, r in enumerate(wrows):  # a Wk filter fed by output r: C x~ + Dv w
        s = slice(n + nw * j, n + nw * (j + 1))
        A[s, s] = Aw
        A[s, :n] = Bwk @ lm.C[r : r + 1]
        B[s] = Bwk[:, 0] * Dv[r]
        C[len(rows) + j, s] = Cw[0]
    P = scipy.linalg.solve_continuous_lyapunov(A, -np.outer(B, B))
    ms = np.einsum("ij,jk,ik->i", C, P, C)
    rms = np.sqrt(np.maximum(ms, 0.0))
    finite = np.concatenate([(K[rows] == 0) & (Dv[rows] == 0), K[wrows] == 0])
    nr = len(rows)
    return (
        np.where(finite[:nr], rms[:nr], np.inf),
        np.where(finite[nr:], rms[nr:], np.inf),
    )


def unit_mean_product(lm: LinearModel, wa, wb) -> float:
    """Stationary mean of the product of two output combinations for ``W = 1``.

    ``E[(wa . y)(wb . y)]`` for weight vectors over ``lm.outputs``, e.g. the seat force
    and the seat velocity (their mean product is the absorbed power; multiply by
    ``W``, :func:`road_velocity_intensity`, for a road and speed). A combination may
    hold absolute displacements as long as it does not follow the road statically.

    Parameters
    ----------
    lm : LinearModel
    wa, wb : (outputs,) array_like
        Weights on ``lm.outputs``.

    Returns
    -------
    float
        ``inf`` if a combination is not stationary or the model not stable.

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> from bodyvib.runtime.network import linear_model
    >>> lm = linear_model(load_car())
    >>> w = np.zeros(len(lm.outputs)); w[lm.output_index("sprung.a")] = 1.0
    >>> r, _ = unit_rms(lm, [lm.output_index("sprung.a")])
    >>> bool(abs(unit_mean_product(lm, w, w) / r[0] ** 2 - 1) < 1e-12)
    True
    """
    Bw, K, Dv = _relative(lm)
    wa, wb = np.asarray(wa, dtype=float), np.asarray(wb, dtype=float)
    if not np.all(np.linalg.eigvals(lm.A).real < 0):
        return math.inf
    for w in (wa, wb):
        scale = np.abs(w) @ (np.abs(lm.C).sum(axis=1) + 1.0)
        if abs(w @ K) > 1e-9 * scale or w @ Dv != 0:
            return math.inf
    P = scipy.linalg.solve_continuous_lyapunov(lm.A, -np.outer(Bw, Bw))
    return float((wa @ lm.C) @ P @ (lm.C.T @ wb))


@dataclass(frozen=True)
class RandomResponse:
    """Stationary r.m.s. of a model's outputs on an ISO 8608 road.

    Attributes
    ----------
    road_class : str
        ISO 8608 class, ``A`` to ``H``.
    speed : float
        m/s.
    intensity : float
        Road-velocity noise intensity ``W``, m^2/s^3 (:func:`road_velocity_intensity`).
    outputs : tuple of str
        Output names of ``rms``.
    rms : tuple of float
        Their r.m.s. (SI units; ``inf`` where not stationary).
    weighted : tuple of str
        Output names of ``weighted_rms``.
    weighted_rms : tuple of float
        Their ISO 2631-1 Wk-weighted r.m.s., m/s2.
    static_wheel_load : float
        N (:func:`static_wheel_load`).
    """

    road_class: str
    speed: float
    intensity: float
    outputs: Tuple[str, ...]
    rms: Tuple[float, ...]
    weighted: Tuple[str, ...]
    weighted_rms: Tuple[float, ...]
    static_wheel_load: float

    @property
    def tire_load_ratio(self) -> float:
        """R.m.s. dynamic tire force over the static wheel load (needs ``tire.force``)."""
        return self.of("tire.force") / self.static_wheel_load

    def travel_ratio(self, rattle_space: float, output: str = "suspension.deflection") -> float:
        """3-sigma suspension travel over the rattle space (m); above 1 it hits the stops.

        Examples
        --------
        >>> from bodyvib.runtime.network import linear_model
        >>> from bodyvib.vehicle.quarter_car import load_car
        >>> r = random_response(linear_model(load_car()), "C", 20.0)
        >>> round(r.travel_ratio(0.07), 3), round(r.tire_load_ratio, 3)
        (0.569, 0.301)
        """
        return 3.0 * self.of(output) / float(rattle_space)

    def of(self, output: str, weighted: bool = False) -> float:
        """The r.m.s. (or Wk-weighted r.m.s.) of one output by name."""
        names, values = (self.weighted, self.weighted_rms) if weighted else (self.outputs, self.rms)
        try:
            return values[names.index(output)]
        except ValueError:
            raise BodyvibError(f"no output '{output}' in this response") from None


def random_response(
    lm: LinearModel,
    road_class: str,
    speed: float,
    outputs: Sequence[str] = None,
    weighted: Sequence[str] = (),
) -> RandomResponse:
    """Stationary r.m.s. of outputs of a linear model on an ISO 8608 road (``w = 2``).

    Parameters
    ----------
    lm : LinearModel
        A car (with its occupant: :func:`bodyvib.vehicle.quarter_car.seated_system`)
        with inputs ``road_displacement`` and ``road_velocity``.
    road_class : str
        ``"A"`` ... ``"H"``.
    speed : float
        m/s.
    outputs : sequence of str, optional
        Outputs whose r.m.s. is wanted (default: every stationary output).
    weighted : sequence of str
        Accelerations whose Wk-weighted r.m.s. is wanted (e.g. ``"body.head.a"``).

    Returns
    -------
    RandomResponse

    Raises
    ------
    BodyvibError
        Unknown output, class or a bad speed.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> from bodyvib.runtime.network import linear_model
    >>> from bodyvib.vehicle.quarter_car import load_car, seated_system
    >>> lm = linear_model(seated_system(load_car(), load_model("reduced-paper")))
    >>> r = random_response(lm, "C", 20.0, ["suspension.deflection"], ["body.head.a"])
    >>> round(r.of("body.head.a", weighted=True), 3)  # m/s2
    1.128
    """
    if outputs is None:
        outputs = [o for o, ok in zip(lm.outputs, stationary_outputs(lm)) if ok]
    rows = [lm.output_index(o) for o in outputs]
    wrows = [lm.output_index(o) for o in weighted]
    W = road_velocity_intensity(road_class, speed)
    rms, wrms = unit_rms(lm, rows, wrows)
    s = math.sqrt(W)
    return RandomResponse(
        road_class=str(road_class).strip().upper(),
        speed=float(speed),
        intensity=W,
        outputs=tuple(outputs),
        rms=tuple(float(x * s) for x in rms),
        weighted=tuple(weighted),
        weighted_rms=tuple(float(x * s) for x in wrms),
        static_wheel_load=static_wheel_load(lm),
    )


#: Frequency grid of :func:`wheel_spectral_rms`, Hz: log-spaced points over seven decades,
#: wide enough that an output with a stationary r.m.s. on the ideal ISO 8608 road (no band
#: limits, as the Lyapunov solution takes it) has its whole variance inside (the quarter
#: car's figures agree with :func:`unit_rms` to 1e-4, tested): lowest, highest, points.
SPECTRAL_GRID_HZ = (1e-3, 1e4, 7000)


def road_inputs(lm: LinearModel):
    """Each road point's displacement and velocity input indices, ``[(iz, iv), ...]``."""
    return [
        (lm.input_index(f"{b}_displacement"), lm.input_index(f"{b}_velocity"))
        for b in lm.network.bases
    ]


def static_output(lm: LinearModel, output: str) -> float:
    """An output's value in the static equilibrium under gravity, the road held level.

    Parameters
    ----------
    lm : LinearModel
    output : str
        E.g. a tire's force, ``"tire_front_left.force"`` (N, + in compression).

    Returns
    -------
    float
        In the output's own unit (a force in N, a displacement in m).

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> from bodyvib.runtime.network import linear_model
    >>> lm = linear_model(load_car())
    >>> bool(abs(static_output(lm, "tire.force") - static_wheel_load(lm)) < 1e-6)
    True
    """
    g = np.zeros(lm.A.shape[0])
    net = lm.network
    for m in list(net.masses) + list(net.bodies):
        g[lm.states.index(f"{m}.v")] = -GRAVITY
    x = np.linalg.solve(lm.A, -g)
    return float(lm.C[lm.output_index(output)] @ x)


def wheel_spectral_rms(lm: LinearModel, rows, weighted_rows, point, wheels):
    """R.m.s. of outputs of a car driven at several road points, on an ISO 8608 road.

    The rear wheels meet the road a distance ``behind`` later, and the two tracks of a
    full car are correlated as an isotropic surface
    (:func:`bodyvib.vehicle.road.track_coherence`): with ``H_p`` an output's response to the road at point ``p`` and
    ``G(f) = Gd(f / V) / V`` the road's PSD in time, the output's one-sided PSD is
    ``G sum_pq H_p conj(H_q) e^(-i w (tau_p - tau_q)) rho_pq`` (``tau_p`` the point's
    delay, ``rho_pq`` 1 on one track and the coherence across). Its integral over
    :data:`SPECTRAL_GRID_HZ` (trapezoids in ``ln f``) is the mean square; a Lyapunov
    equation cannot hold the delays.

    Parameters
    ----------
    lm : LinearModel
        Inputs ``<base>_displacement`` and ``<base>_velocity`` per road point.
    rows, weighted_rows : sequence of int
        Outputs whose r.m.s. and Wk-weighted r.m.s. are wanted.
    point : OperatingPoint-like
        ``road`` (ISO 8608 class) and ``speed`` (m/s).
    wheels : (behind, sides, track)
        Each road point's distance behind the first (m), its track (1 left, -1 right,
        0 centre) and the track width (m) (:mod:`bodyvib.vehicle.quarter_car`).

    Returns
    -------
    rms, weighted : ndarray
        ``inf`` where the model is not asymptotically stable.
    """
    from bodyvib.comfort.figures import wk_response

    from ..road.synthetic import displacement_psd, track_coherence

    rows, wrows = list(rows), list(weighted_rows)
    if not np.all(np.linalg.eigvals(lm.A).real < 0):
        return np.full(len(rows), np.inf), np.full(len(wrows), np.inf)
    behind, sides, track = wheels
    f = np.geomspace(*SPECTRAL_GRID_HZ[:2], int(SPECTRAL_GRID_HZ[2]))
    jw = 2j * np.pi * f
    out = rows + wrows
    n = lm.A.shape[0]
    ins = road_inputs(lm)
    Bp = np.stack([lm.B[:, iz][None, :] + jw[:, None] * lm.B[:, iv][None, :] for iz, iv in ins], -1)
    X = np.linalg.solve(jw[:, None, None] * np.eye(n) - lm.A, Bp)  # (F, n, P)
    Dp = np.stack(
        [lm.D[out, iz][None, :] + jw[:, None] * lm.D[out, iv][None, :] for iz, iv in ins], -1
    )
    H = np.einsum("rn,fnp->frp", lm.C[out], X) + Dp  # (F, outputs, points)
    H = H * np.exp(-jw[:, None, None] * np.asarray(behind)[None, None, :] / point.speed)
    n_road = f / point.speed
    rho = track_coherence(n_road, track) if track > 0 else np.ones_like(f)
    S = np.zeros((f.size, len(out)))
    for p in range(len(ins)):
        for q in range(len(ins)):
            c = np.ones_like(f) if sides[p] == sides[q] else rho
            S += c[:, None] * (H[:, :, p] * np.conj(H[:, :, q])).real
    S *= (displacement_psd(n_road, point.road) / point.speed)[:, None]
    S[:, len(rows) :] *= (np.abs(wk_response(f)) ** 2)[:, None]
    ms = np.trapezoid(S * f[:, None], np.log(f), axis=0)
    rms = np.sqrt(np.maximum(ms, 0.0))
    return rms[: len(rows)], rms[len(rows) :]
