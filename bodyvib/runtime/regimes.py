"""Piecewise-affine models and their exact stepping with located events.

A network with contacts, stops or asymmetric dampers
(:data:`bodyvib.runtime.network.NONLINEAR_KINDS`) is linear within each *regime*:
``x' = A_r x + B_r u + b_r``, ``y = C_r x + D_r u + d_r``
(:func:`bodyvib.runtime.network.regime_model`; ``b_r`` holds a free contact's lost
preload, an engaged stop's gap). Each regime changes at the sign of a *switching
function*, affine in the state and the input, ``g = G [x; u] + g0``:

- a contact: its force ``F0 + k (x_from - x_to) + c (v_from - v_to)``: engaged while
  positive (the force is ``max(0, g)``);
- a stop's compression (rebound) side: ``-k gap + s (k (x_from - x_to) + c (v_from -
  v_to))``, ``s`` +1 (-1): engaged while positive;
- an asymmetric damper: its rate ``v_to - v_from``: ``c_rebound`` while positive.

Stepping (:class:`EventStepper`), over a step ``h`` with input ``u + du tau``:

1. the exact step of the regime in force (:mod:`bodyvib.runtime.discretize`, the
   affine term as one more input held at 1); where the regime has no affine term the
   matrices and the products are those of the linear step, so a run that never
   switches is the linear run bit for bit;
2. one sign test per switching function on the end state, and a guard from the last
   three values of each function (``g`` at ``t - h``, ``t``, ``t + h``): a parabola
   through them whose extremum inside the step crosses zero sends the step to 3;
3. otherwise the step is done again with located events: on a segment from ``tau`` to
   ``h`` the functions and their rates at both ends give a cubic-Hermite estimate of
   each, sampled for its first wrong-sided point (a root at the end, or two inside:
   the grazing guard); the earliest estimate starts a safeguarded Newton iteration on
   the regime's exact solution, ``g(tau)`` from the exact step of length ``tau``
   (one matrix exponential per iterate) and ``g'(tau) = G [A x + B u + b; du]``,
   kept inside a sign-change bracket (bisection when Newton leaves it), until the
   root moves less than :data:`EVENT_TOLERANCE` times the step. The state there
   is the regime's exact state, the switching element changes regime, and the
   step continues in the new regime from that point.

Numpy only, relative imports only: this module runs inside the FMUs.
"""

import math
from typing import Dict, List, NamedTuple, Optional, Sequence, Tuple, Union

import numpy as np

from .errors import BodyvibError
from .exact import StepCache, discretize
from .network import LinearModel, Network, linear_model, regime_model, static_preloads

Vec = Union[np.ndarray, Sequence[float]]

__all__ = [
    "EVENT_TOLERANCE",
    "MAX_EVENTS_PER_STEP",
    "PiecewiseModel",
    "Regime",
    "EventStepper",
    "EventLog",
]

#: Located event times are exact to this fraction of the step (Newton's last move).
EVENT_TOLERANCE = 1e-10

#: Most switchings inside one step; more is a chattering contact (refused).
MAX_EVENTS_PER_STEP = 64

_SAMPLES = 16  # points at which a segment's cubic-Hermite estimate is looked at


class Regime:
    """One regime's affine state space and its exact step matrices (cached per step).

    Parameters
    ----------
    model : LinearModel
        ``A, B, C, D`` of the regime.
    b, d : ndarray
        Constant state-derivative and output terms.
    """

    def __init__(self, model: LinearModel, b: np.ndarray, d: np.ndarray):
        self.model = model
        self.b = b
        self.d = d
        self.affine = bool(np.any(b))
        self._cache = StepCache(self._matrices)

    def _matrices(self, h: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        A, B = self.model.A, self.model.B
        if not self.affine:  # exactly the linear step's matrices
            Phi, G0, G1 = discretize(A, B, h)
            return Phi, G0, G1, np.zeros(A.shape[0])
        ni = B.shape[1]
        Phi, G0, G1 = discretize(A, np.hstack([B, self.b[:, None]]), h)
        return Phi, G0[:, :ni], G1[:, :ni], G0[:, ni]

    def matrices(self, h: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``Phi, Gamma0, Gamma1, gamma_b`` for a step ``h`` (rounded as the linear cache)."""
        return self._cache.get(float(f"{h:.12g}"))

    def step(self, x: np.ndarray, u: np.ndarray, du: np.ndarray, h: float) -> np.ndarray:
        """The exact state after ``h`` from ``x`` with input ``u + du tau``."""
        Phi, G0, G1, gb = self.matrices(h)
        out = Phi @ x + G0 @ u + G1 @ du
        return out + gb if self.affine else out

    def step_exact(self, x: np.ndarray, u: np.ndarray, du: np.ndarray, tau: float) -> np.ndarray:
        """As :meth:`step` for any ``tau`` (not cached: one matrix exponential)."""
        A, B = self.model.A, self.model.B
        ni = B.shape[1]
        Phi, G0, G1 = discretize(A, np.hstack([B, self.b[:, None]]), tau)
        return Phi @ x + G0[:, :ni] @ u + G1[:, :ni] @ du + G0[:, ni]

    def rate(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The state derivative ``A x + B u + b``."""
        return self.model.A @ x + self.model.B @ u + self.b


class PiecewiseModel:
    """A network with nonlinear elements as switching functions and regimes.

    Parameters
    ----------
    network : Network
        Any network; one without nonlinear elements has no switching function and
        one regime (its linear model).

    Attributes
    ----------
    preloads : dict of str to float
        Static force of each contact, N (:func:`bodyvib.runtime.network.static_preloads`).
    switches : tuple of (str, str)
        ``(element, side)`` of each switching function, side ``"contact"``,
        ``"compression"``, ``"rebound"`` or ``"rate"``.
    G : (n_switches, ns + ni) ndarray
        Switching functions' rows on ``[x; u]``.
    g0 : (n_switches,) ndarray
        Their constants.
    initial : tuple of bool
        Each function's state at static equilibrium (``g0 > 0``).

    Examples
    --------
    >>> from bodyvib.runtime.network import Element
    >>> net = Network("drop", {"m": 10.0, "k": 1e4}, {"m": "m"},
    ...               (Element("floor", "contact", "ground", "m", {"k": "k"}),), base="ground")
    >>> PiecewiseModel(net).switches, PiecewiseModel(net).initial
    ((('floor', 'contact'),), (True,))
    """

    def __init__(self, network: Network):
        self.network = network
        self.preloads = static_preloads(network)
        lm = linear_model(network)
        self.linear = lm
        ns, ni = lm.A.shape[0], len(lm.inputs)
        self._ns = ns

        def row(point: str, quantity: str) -> np.ndarray:
            if point in network.bases:
                r = np.zeros(ns + ni)
                what = "displacement" if quantity == "x" else "velocity"
                r[ns + lm.inputs.index(f"{point}_{what}")] = 1.0
                return r
            i = lm.output_index(f"{point}.{quantity}")
            return np.concatenate([lm.C[i], lm.D[i]])

        switches, rows, consts = [], [], []
        for el in network.nonlinear_elements:
            v = {p: network.value(r) for p, r in el.values.items()}
            rel_v = row(el.a, "v") - row(el.b, "v")
            if el.kind == "asymmetric_damper":
                switches.append((el.name, "rate"))
                rows.append(-rel_v)
                consts.append(0.0)
                continue
            push = v["k"] * (row(el.a, "x") - row(el.b, "x")) + v.get("c", 0.0) * rel_v
            if el.kind == "contact":
                switches.append((el.name, "contact"))
                rows.append(push)
                consts.append(self.preloads[el.name])
            else:
                switches += [(el.name, "compression"), (el.name, "rebound")]
                rows += [push, -push]
                consts += [-v["k"] * v["gap_compression"], -v["k"] * v["gap_rebound"]]
        self.switches: Tuple[Tuple[str, str], ...] = tuple(switches)
        self.G = np.array(rows).reshape(len(rows), ns + ni)
        self.Gx = np.ascontiguousarray(self.G[:, :ns])
        self.Gu = np.ascontiguousarray(self.G[:, ns:])
        self.g0 = np.array(consts, dtype=float)
        self.initial: Tuple[bool, ...] = tuple(bool(c > 0) for c in consts)
        self._regimes: Dict[Tuple[bool, ...], Regime] = {}

    def modes(self, state: Tuple[bool, ...]) -> Dict[str, str]:
        """Element name -> mode for a state of the switching functions."""
        out: Dict[str, str] = {}
        for (name, side), on in zip(self.switches, state):
            if side == "contact":
                out[name] = "engaged" if on else "free"
            elif side == "rate":
                out[name] = "rebound" if on else "compression"
            elif on:
                out[name] = side
            else:
                out.setdefault(name, "free")
        return out

    def regime(self, state: Tuple[bool, ...]) -> Regime:
        """The regime of a state of the switching functions (built once)."""
        reg = self._regimes.get(state)
        if reg is None:
            lm, b, d = regime_model(self.network, self.modes(state), self.preloads)
            reg = self._regimes[state] = Regime(lm, b, d)
        return reg

    def g(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The switching functions at state ``x`` and input ``u``."""
        return self.Gx @ x + self.Gu @ u + self.g0

    def g_rate(self, reg: Regime, x: np.ndarray, u: np.ndarray, du: np.ndarray) -> np.ndarray:
        """Their time derivatives in regime ``reg``: ``G [A x + B u + b; du]``."""
        ns = self._ns
        return self.G[:, :ns] @ reg.rate(x, u) + self.G[:, ns:] @ du


class EventLog:
    """What the switching elements did over a run: events and extremes.

    Parameters
    ----------
    model : PiecewiseModel
        The run's model: its ``switches`` name the elements the log counts.

    Attributes
    ----------
    events : list of (float, str, str)
        ``(time s, element, what)``, ``what`` one of ``"lift-off"``, ``"landing"``,
        ``"stop-on"``, ``"stop-off"``, ``"rebound"``, ``"compression"``; the first
        :data:`MAX_KEPT` only.
    """

    MAX_KEPT = 10000

    def __init__(self, model: PiecewiseModel):
        self._model = model
        n = len(model.switches)
        self.events: List[Tuple[float, str, str]] = []
        self.counts = [0] * n  # entries into the "on" state (contact: lift-offs)
        self.g_min = [math.inf] * n
        self.g_max = [-math.inf] * n
        self.flight = [0.0] * n  # time in the air, summed (contacts)
        self.longest = [0.0] * n
        self._since: List[Optional[float]] = [None] * n  # start of the current flight
        self.t = 0.0

    def switched(self, t: float, i: int, on: bool) -> None:
        """Record switching function ``i`` turning ``on`` (or off) at ``t``."""
        name, side = self._model.switches[i]
        if side == "contact":
            what = "landing" if on else "lift-off"
            if on:
                start = self._since[i]
                if start is not None:
                    self._end_flight(i, t - start)
                self._since[i] = None
            else:
                self.counts[i] += 1
                self._since[i] = t
        elif side == "rate":
            what = "rebound" if on else "compression"
        else:
            what = "stop-on" if on else "stop-off"
            self.counts[i] += int(on)
        if len(self.events) < self.MAX_KEPT:
            self.events.append((float(t), name, what))

    def _end_flight(self, i: int, d: float) -> None:
        self.flight[i] += d
        self.longest[i] = max(self.longest[i], d)

    def sample(self, t: float, g: List[float]) -> None:
        """Track the functions' extremes at a communication point ``t``."""
        lo, hi = self.g_min, self.g_max
        for i, v in enumerate(g):
            if v < lo[i]:
                lo[i] = v
            if v > hi[i]:
                hi[i] = v
        self.t = t

    def summary(self) -> Dict[str, dict]:
        """Per element: contacts ``lift_offs``, ``time_in_air_s``, ``longest_flight_s``,
        ``smallest_load_ratio`` (total force / static, at the communication points);
        stops ``contacts`` and ``largest_force_N`` (at the communication points)."""
        out: Dict[str, dict] = {}
        for i, (name, side) in enumerate(self._model.switches):
            if side == "contact":
                flight, longest = self.flight[i], self.longest[i]
                since = self._since[i]
                if since is not None:  # still in the air
                    d = self.t - since
                    flight, longest = flight + d, max(longest, d)
                f0 = self._model.preloads[name]
                low = max(0.0, float(self.g_min[i])) if math.isfinite(self.g_min[i]) else f0
                out[name] = {
                    "kind": "contact",
                    "lift_offs": self.counts[i],
                    "time_in_air_s": flight,
                    "longest_flight_s": longest,
                    "smallest_load_ratio": low / f0,
                }
            elif side in ("compression", "rebound"):
                e = out.setdefault(name, {"kind": "stop", "contacts": 0, "largest_force_N": 0.0})
                e["contacts"] += self.counts[i]
                if math.isfinite(self.g_max[i]):
                    e["largest_force_N"] = max(e["largest_force_N"], float(self.g_max[i]))
        return out

    def to_state(self) -> dict:
        """A JSON-serializable snapshot."""
        return {
            "events": [list(e) for e in self.events],
            "counts": list(self.counts),
            "g_min": list(self.g_min),
            "g_max": list(self.g_max),
            "flight": list(self.flight),
            "longest": list(self.longest),
            "since": list(self._since),
            "t": self.t,
        }

    def from_state(self, s: dict) -> None:
        """Restore :meth:`to_state`."""
        self.events = [(float(t), str(n), str(w)) for t, n, w in s["events"]]
        self.counts = [int(c) for c in s["counts"]]
        self.g_min = [float(v) for v in s["g_min"]]
        self.g_max = [float(v) for v in s["g_max"]]
        self.flight = [float(x) for x in s["flight"]]
        self.longest = [float(x) for x in s["longest"]]
        self._since = [None if x is None else float(x) for x in s["since"]]
        self.t = float(s["t"])


class _Segment(NamedTuple):
    """One switching function ``i`` (signed: >= 0 allowed) along a regime's exact solution
    from ``x`` with input ``u + du tau``."""

    model: PiecewiseModel
    reg: Regime
    i: int
    sign: float
    x: np.ndarray
    u: np.ndarray
    du: np.ndarray

    def value(self, tau: float) -> Tuple[float, float]:
        """``g`` and ``g'`` at ``tau``, signed."""
        m, ns = self.model, self.model._ns
        xt = self.reg.step_exact(self.x, self.u, self.du, tau)
        ut = self.u + self.du * tau
        g = m.G[self.i] @ np.concatenate([xt, ut]) + m.g0[self.i]
        dg = m.G[self.i, :ns] @ self.reg.rate(xt, ut) + m.G[self.i, ns:] @ self.du
        return float(self.sign * g), float(self.sign * dg)


class EventStepper:
    """Exact stepping of a :class:`PiecewiseModel` with located events (module docstring).

    Parameters
    ----------
    model : PiecewiseModel or Network

    Attributes
    ----------
    state : tuple of bool
        The switching functions' states (the regime in force).
    log : EventLog

    Examples
    --------
    >>> from bodyvib.runtime.network import Element
    >>> net = Network("drop", {"m": 10.0, "k": 1e4}, {"m": "m"},
    ...               (Element("floor", "contact", "ground", "m", {"k": "k"}),), base="ground")
    >>> s = EventStepper(net)
    >>> x = np.array([0.0, 2.0])  # moving up at 2 m/s: it leaves the floor
    >>> for k in range(100):
    ...     x = s.step(x, np.zeros(2), np.zeros(2), 1e-3, k * 1e-3)
    >>> s.log.summary()["floor"]["lift_offs"]
    1
    """

    def __init__(self, model: Union[PiecewiseModel, Network]):
        self.model = model if isinstance(model, PiecewiseModel) else PiecewiseModel(model)
        self.state: Tuple[bool, ...] = self.model.initial
        self.log = EventLog(self.model)
        self._g_prev = self._g_now = self.model.g0.tolist()
        self._sign = np.where(self.state, 1.0, -1.0)
        self.located = 0  # steps that took the event path

    @property
    def regime(self) -> Regime:
        """The regime in force."""
        return self.model.regime(self.state)

    def step(self, x: Vec, u: Vec, du: Vec, h: float, t: float = 0.0) -> np.ndarray:
        """The state after a step ``h`` from ``x`` at ``t`` with input ``u + du tau``.

        Raises
        ------
        BodyvibError
            More than :data:`MAX_EVENTS_PER_STEP` switchings inside the step.
        """
        x = np.asarray(x, dtype=float)
        u = np.asarray(u, dtype=float)
        du = np.asarray(du, dtype=float)
        return self.finish(x, u, du, h, t, self.regime.step(x, u, du, h))

    def start(self, x: Vec, u: Vec) -> None:
        """Take the regime of state ``x`` at input ``u`` (each function's sign there)."""
        g = self.model.g(np.asarray(x, dtype=float), np.asarray(u, dtype=float)).tolist()
        self.state = tuple(v > 0 for v in g)
        self._sign = np.where(self.state, 1.0, -1.0)
        self._g_prev = self._g_now = g

    def finish(
        self, x: Vec, u: np.ndarray, du: np.ndarray, h: float, t: float, xe: np.ndarray
    ) -> np.ndarray:
        """The end of a step whose regime step ``xe`` is already known (the sign test on).

        Parameters
        ----------
        x, u, du, h, t
            As :meth:`step`.
        xe : ndarray
            The exact step of the regime in force from ``x`` (:meth:`Regime.step`).

        Returns
        -------
        ndarray
            ``xe`` where nothing switches (the same object), else the state with
            located events.
        """
        if not self.model.switches:
            return xe
        model = self.model
        ge = (model.Gx @ xe + model.Gu @ (u + du * h) + model.g0).tolist()
        if not self.clear(ge):
            xe = self._events(np.asarray(x, dtype=float), u, du, h, t)
            ge = model.g(xe, u + du * h).tolist()
        self.accept(ge, t + h)
        return xe

    def accept(self, ge: List[float], t: float) -> None:
        """Take the functions' values ``ge`` at the end ``t`` of a finished step."""
        self._g_prev, self._g_now = self._g_now, ge
        self.log.sample(t, ge)

    def clear(self, ge: List[float]) -> bool:
        """Nothing switches in a step whose end has the functions' values ``ge``: each keeps
        its sign, and no parabola through its last three values dips across zero inside
        the step."""
        for on, gm, g0, g1 in zip(self.state, self._g_prev, self._g_now, ge):
            if not on:
                gm, g0, g1 = -gm, -g0, -g1
            if g1 < 0.0:
                return False
            a = 0.5 * (g1 + gm) - g0  # p(s) = g0 + b s + a s^2 through s = -1, 0, 1
            if a > 0.0:
                m = 0.5 * (gm - g1) / (2.0 * a)
                if 0.0 < m < 1.0 and g0 - a * m * m < 0.0:
                    return False
        return True

    def _events(
        self, x: np.ndarray, u: np.ndarray, du: np.ndarray, h: float, t: float
    ) -> np.ndarray:
        """The step again, with located events (module docstring, point 3)."""
        self.located += 1
        model, tau, fresh = self.model, 0.0, set()
        for _ in range(MAX_EVENTS_PER_STEP):
            H = h - tau
            if H <= EVENT_TOLERANCE * h:
                return x
            reg = model.regime(self.state)
            ub, ue = u + du * tau, u + du * h
            xe = reg.step(x, ub, du, H) if tau == 0.0 else reg.step_exact(x, ub, du, H)
            s = self._sign
            g_s, g_e = s * model.g(x, ub), s * model.g(xe, ue)
            r_s, r_e = s * model.g_rate(reg, x, ub, du) * H, s * model.g_rate(reg, xe, ue, du) * H
            best: Optional[float] = None
            hits: List[Tuple[float, int]] = []
            for i in range(g_s.size):
                start = 0.0 if i in fresh else g_s[i]
                seg = _Segment(model, reg, i, s[i], x, ub, du)
                root = self._locate(seg, H, start, r_s[i], g_e[i], r_e[i], h)
                if root is not None:
                    hits.append((root, i))
                    best = root if best is None else min(best, root)
            if best is None:
                return xe
            x = reg.step_exact(x, ub, du, best)
            fresh = {i for r, i in hits if r <= best + EVENT_TOLERANCE * h}
            state = list(self.state)
            for i in sorted(fresh):
                state[i] = not state[i]
                self.log.switched(t + tau + best, i, state[i])
            self.state = tuple(state)
            self._sign = np.where(self.state, 1.0, -1.0)
            tau += best
        raise BodyvibError(
            f"more than {MAX_EVENTS_PER_STEP} switchings of "
            f"{', '.join(sorted({model.switches[i][0] for i in fresh}))} within the step "
            f"from t = {t:g} s (a chattering contact); shorten the step or add damping"
        )

    def _locate(
        self, seg: "_Segment", H: float, g0: float, m0: float, g1: float, m1: float, h: float
    ) -> Optional[float]:
        """The first root of ``seg``'s function in ``(0, H]``, or None (its signed values
        ``g0``, ``g1`` and rates times ``H`` ``m0``, ``m1`` at the ends: >= 0 is allowed)."""
        s = np.linspace(0.0, 1.0, _SAMPLES + 1)[1:]
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        cubic = h00 * g0 + h10 * m0 + h01 * g1 + h11 * m1
        bad = np.flatnonzero(cubic < 0)

        def cubic_root(j: int) -> float:  # the estimate's root in the sample interval j
            a, b = (s[j - 1] if j else 0.0), s[j]
            for _ in range(30):
                m = 0.5 * (a + b)
                p = (
                    (2 * m**3 - 3 * m**2 + 1) * g0
                    + (m**3 - 2 * m**2 + m) * m0
                    + (-2 * m**3 + 3 * m**2) * g1
                    + (m**3 - m**2) * m1
                )
                a, b = (m, b) if p >= 0 else (a, m)
            return 0.5 * (a + b) * H

        if g1 < 0:
            lo, hi = 0.0, H
            guess = cubic_root(int(bad[0])) if bad.size else H * g0 / max(g0 - g1, 1e-300)
        elif bad.size:  # two crossings inside the segment: is the dip real?
            mid = s[int(np.argmin(cubic))] * H
            if seg.value(mid)[0] >= 0:
                return None
            lo, hi, guess = 0.0, mid, cubic_root(int(bad[0]))
        else:
            return None
        return self._newton(seg, lo, hi, guess, h)

    @staticmethod
    def _newton(seg: "_Segment", lo: float, hi: float, tau: float, h: float) -> float:
        """Newton on the exact ``g(tau)`` inside the bracket ``[lo, hi]`` (bisection outside)."""
        tau = min(max(tau, lo), hi)
        for _ in range(100):
            if tau <= 0.0:
                tau = 0.5 * (lo + hi)
            g, dg = seg.value(tau)
            if g < 0:
                hi = tau
            else:
                lo = tau
            new = tau - g / dg if dg != 0.0 else 0.5 * (lo + hi)
            if not lo < new < hi:
                new = 0.5 * (lo + hi)
            if abs(new - tau) <= EVENT_TOLERANCE * h or hi - lo <= EVENT_TOLERANCE * h:
                return new
            tau = new
        return 0.5 * (lo + hi)  # pragma: no cover - the bracket halves at worst

    def to_state(self) -> dict:
        """A JSON-serializable snapshot of the switching state and the log."""
        return {
            "state": list(self.state),
            "g_prev": list(self._g_prev),
            "g_now": list(self._g_now),
            "log": self.log.to_state(),
        }

    def from_state(self, snap: dict) -> None:
        """Restore :meth:`to_state`."""
        self.state = tuple(bool(b) for b in snap["state"])
        self._sign = np.where(self.state, 1.0, -1.0)
        self._g_prev = [float(v) for v in snap["g_prev"]]
        self._g_now = [float(v) for v in snap["g_now"]]
        self.log.from_state(snap["log"])
