"""Head acceleration of a body model under a measured seat acceleration, and its figures.

A body model's seat-to-head transmissibility ``T(s) = X_head / X_seat`` is a
ratio of linear, time-invariant responses, so it maps the seat acceleration
``s^2 X_seat`` onto the head acceleration ``s^2 X_head`` exactly as it maps
displacements. :func:`head_acceleration` therefore runs the body's own state
space (:func:`bodyvib.runtime.network.linear_model`) with the measured
acceleration in place of the seat displacement and its rate in place of the
seat velocity, and reads the head "displacement" output, which is then the
head acceleration. The record is taken linear between samples (on each step
the input is ``a_k + r_k tau`` with ``r_k = (a_{k+1} - a_k) / h``), and the
state is advanced by the exact step matrices of
:class:`bodyvib.runtime.discretize.Discretization` on the record's uniform grid
(:meth:`~bodyvib.runtime.discretize.Discretization.run`), ``x_{k+1} = Phi x_k +
Gamma0 u_k + Gamma1 du_k`` -- the update :func:`bodyvib.runtime.discretize.simulate`
makes, with the input terms formed for all steps at once since the step never
changes (measured 17-19 us per sample and model instead of 44 on a loaded
2-core machine: a 10-minute record at 1 kHz in about 11 s per model). The body starts at rest (a record is expected to
start near zero; a nonzero first sample is a step at t = 0).

:func:`internal_forces` gives the forces a body model names (neck, lumbar). A force is not
a ratio to the seat motion that the acceleration can stand in for, so it is computed in
the seat's frame instead: relative to the seat, each mass ``m`` feels the inertia force
``-m a_seat`` (d'Alembert) and the seat stands still, so the body's own network with
those forces as inputs and the seat held gives every element's deflection and force
exactly, with no integration of the record (a bias in it is a constant inertia load, not
a drift).

:func:`respond` adds the ISO 2631-1 figures (:func:`bodyvib.comfort.figures.comfort_figures`)
of seat and head, the standard's checks of the basic method
(:func:`bodyvib.comfort.figures.basic_method_checks`) and the figures of the named forces
(:class:`bodyvib.comfort.forces.ForceFigures`) for each model, and the seat record's motion
sickness dose value and Lee & Pradko absorbed-power estimate (:mod:`bodyvib.comfort.measures`)
and its ISO 2631-5:2018 spinal dose (:mod:`bodyvib.comfort.spine`).
"""

from dataclasses import dataclass, field, replace
from typing import Dict, Optional, Sequence

import numpy as np

from ..comfort.axes import SEATED_AXES, VibrationTotals, vibration_totals
from ..comfort.figures import ComfortFigures, basic_method_checks, check_rate, comfort_figures
from ..comfort.forces import ForceFigures, force_figures
from ..comfort.measures import lee_pradko_power, msdv
from ..comfort.spine import SpinalDose, spinal_dose
from ..comfort.validity import check_step, comfort_verdict
from ..models import DEFAULT_MODELS, load_model
from ..process import interrupts
from ..runtime.discretize import Discretization
from ..runtime.errors import BodyvibError
from ..runtime.network import Network, linear_model
from .signal import SeatSignal

__all__ = [
    "DEFAULT_MODELS",
    "head_acceleration",
    "internal_forces",
    "BodyResponse",
    "Response",
    "respond",
]


def head_acceleration(body: Network, acceleration, fs: float) -> np.ndarray:
    """Head acceleration of a body whose seat moves with the given acceleration.

    Parameters
    ----------
    body : Network
        A body model with a ``head`` role (or a mass named ``head``).
    acceleration : (n,) array_like
        Seat acceleration, m/s2, uniformly sampled, linear between samples.
    fs : float
        Sampling rate, Hz.

    Returns
    -------
    (n,) ndarray
        Absolute head acceleration at the sample times, m/s2, from rest.

    Raises
    ------
    BodyvibError
        A body without a head, non-finite samples, a bad rate.

    Examples
    --------
    >>> t = np.arange(0, 20, 1e-3)
    >>> a = head_acceleration(load_model("reduced-paper"), np.sin(2 * np.pi * 2 * t), 1000.0)
    >>> bool(0.9 < np.abs(a[-2000:]).max() < 2.0)
    True
    """
    lm = linear_model(body)
    a = np.asarray(acceleration, dtype=float)
    h = 1.0 / check_rate(fs)
    rate = np.zeros_like(a)
    rate[:-1] = np.diff(a) / h  # linear between samples
    base = body.base
    u = np.zeros((a.size, len(lm.inputs)))
    du = np.zeros_like(u)
    iz, iv = lm.input_index(f"{base}_displacement"), lm.input_index(f"{base}_velocity")
    u[:, iz], u[:, iv] = a, rate  # acceleration in place of displacement
    du[:, iz] = rate  # its rate over each step; the rate is held
    out = lm.output_index("head.x")
    x = Discretization(lm).run(u, du, h, safe_point=interrupts.check)
    return x @ lm.C[out] + u @ lm.D[out]


def internal_forces(body: Network, acceleration, fs: float) -> Dict[str, np.ndarray]:
    """The named internal forces of a body whose seat moves with the given acceleration.

    Parameters
    ----------
    body : Network
        A body model; its ``forces`` (``neck``, ``lumbar``) are computed.
    acceleration, fs
        As :func:`head_acceleration`.

    Returns
    -------
    dict of str to (n,) ndarray
        ``"<name>_force"`` -> the force at the sample times, N, positive in compression,
        from rest; empty for a body that names no force.

    Raises
    ------
    BodyvibError
        Non-finite samples, a bad rate.

    Examples
    --------
    >>> body = load_model("reduced-paper")
    >>> f = internal_forces(body, np.full(3000, 1.0), 1000.0)  # 1 m/s2, held
    >>> round(float(f["lumbar_force"][-1]), 3)  # the whole body's inertia: 69.88 kg x 1 m/s2
    69.88
    """
    if not body.forces:
        return {}
    a = np.asarray(acceleration, dtype=float)
    h = 1.0 / check_rate(fs)
    if not np.all(np.isfinite(a)):
        raise BodyvibError("the seat acceleration has non-finite samples")
    # the seat's frame: the seat held, an inertia force -m a_seat on every mass
    frame = replace(body, force_inputs=tuple(body.mass_names))
    lm = linear_model(frame)
    rate = np.zeros_like(a)
    rate[:-1] = np.diff(a) / h  # linear between samples
    u = np.zeros((a.size, len(lm.inputs)))
    du = np.zeros_like(u)
    for m, mass in frame.mass_values().items():
        j = lm.input_index(f"{m}.force")
        u[:, j], du[:, j] = -mass * a, -mass * rate
    x = Discretization(lm).run(u, du, h, safe_point=interrupts.check)
    out = {}
    for name in body.forces:
        i = lm.output_index(f"{name}_force")
        out[f"{name}_force"] = x @ lm.C[i] + u @ lm.D[i]
    return out


@dataclass(frozen=True)
class BodyResponse:
    """One body's head acceleration and its figures (:func:`respond`).

    Attributes
    ----------
    model : str
        The body model's shipped name or parameter file, as given.
    head_acceleration : ndarray
        m/s2, at the record's sample times.
    figures : ComfortFigures
        ISO 2631-1 figures of the head acceleration.
    checks : dict
        :func:`bodyvib.comfort.figures.basic_method_checks` of the head.
    forces : dict of str to ndarray
        The named internal forces (:func:`internal_forces`), N, + in compression.
    force_figures : dict of str to ForceFigures
        Their r.m.s., peak and the peak's time (from the record's start).
    """

    model: str
    head_acceleration: np.ndarray
    figures: ComfortFigures
    checks: Dict[str, dict]
    forces: Dict[str, np.ndarray] = field(default_factory=dict)
    force_figures: Dict[str, ForceFigures] = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-ready figures, checks and force figures (no history)."""
        return {
            "model": self.model,
            **self.figures.to_dict(),
            "checks": self.checks,
            **{name: f.to_dict() for name, f in self.force_figures.items()},
        }


@dataclass(frozen=True)
class Response:
    """A seat record through body models (:func:`respond`).

    Attributes
    ----------
    signal : SeatSignal
        The checked seat record the figures are of.
    seat_figures : ComfortFigures
        ISO 2631-1 figures of the seat acceleration itself (what the occupant sits on).
    seat_checks : dict
        :func:`bodyvib.comfort.figures.basic_method_checks` of the seat record.
    bodies : dict of str to BodyResponse
        By model label, in the order given.
    seat_msdv : float or None
        Motion sickness dose value of the seat record (Wf), m/s^1.5
        (:func:`bodyvib.comfort.measures.msdv`).
    lee_pradko_power_w : float or None
        Absorbed power estimated from the seat record (Lee & Pradko), W
        (:func:`bodyvib.comfort.measures.lee_pradko_power`).
    spinal : SpinalDose or None
        ISO 2631-5:2018 acceleration dose of the seat record (mean removed), its daily
        value for 8 h and the compressive stress (:func:`bodyvib.comfort.spine.spinal_dose`).
    axes : VibrationTotals or None
        ISO 2631-1 in every measured axis (``seat_z`` and the record's other axes): each
        axis's figures with its weighting, the point and overall vibration total values
        and the health guidance (:func:`bodyvib.comfort.vibration_totals`).
    """

    signal: SeatSignal
    seat_figures: ComfortFigures
    seat_checks: Dict[str, dict]
    bodies: Dict[str, BodyResponse] = field(default_factory=dict)
    seat_msdv: Optional[float] = None
    lee_pradko_power_w: Optional[float] = None
    spinal: Optional[SpinalDose] = None
    axes: Optional[VibrationTotals] = None

    def to_dict(self) -> dict:
        """The JSON document of ``bodyvib respond --json`` (undefined ratios as None)."""
        s = self.signal
        return _finite(
            {
                "signal": {
                    "name": s.name,
                    "samples": int(s.acceleration.size),
                    "sampling_rate_hz": s.fs,
                    "duration": s.duration,
                    "channels": dict(s.channels),
                },
                "seat": {
                    **self.seat_figures.to_dict(),
                    "comfort_method": _method(self.seat_figures, s.duration),
                    "checks": self.seat_checks,
                    "msdv": self.seat_msdv,
                    "lee_pradko_power_w": self.lee_pradko_power_w,
                    **(self.spinal.to_dict() if self.spinal is not None else {}),
                },
                "bodies": {
                    k: {**b.to_dict(), "comfort_method": _method(b.figures, s.duration)}
                    for k, b in self.bodies.items()
                },
                **({"axes": self.axes.to_dict()} if self.axes is not None else {}),
            }
        )


def _method(f: ComfortFigures, duration: float) -> str:
    """Which ISO 2631-1 method governs a record (clause 6.3): basic, vdv or mtvv."""
    return comfort_verdict(f, duration)["comfort_method"]


def _finite(obj):
    """``obj`` with NaN and infinities as None (JSON has neither; a zero record's crest factor)."""
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    return obj


def _axes_in_order(signal: SeatSignal) -> Dict[str, np.ndarray]:
    """Every axis of the record, in the order of :data:`bodyvib.comfort.SEATED_AXES`."""
    records = {"seat_z": signal.acceleration, **signal.axes}
    return {axis: records[axis] for axis in SEATED_AXES if axis in records}


def _label(model: str) -> str:
    import os

    return os.path.splitext(os.path.basename(model))[0] if os.path.isfile(model) else model


def respond(
    signal: SeatSignal, models: Sequence[str] = DEFAULT_MODELS, exposure_s: float = 8 * 3600.0
) -> Response:
    """Seat and head ISO 2631-1 figures of a seat record through each body model.

    The body models are driven by the seat's vertical acceleration; every axis of the
    record (``seat_z`` and ``signal.axes``) gets its ISO 2631-1 figures and totals.

    Parameters
    ----------
    signal : SeatSignal
        From :func:`bodyvib.seat.signal.read_signal` or
        :func:`bodyvib.seat.signal.check_signal`.
    models : sequence of str
        Shipped model names or parameter-file paths.
    exposure_s : float
        Daily exposure for the health guidance of ISO 2631-1 Annex B, s (default 8 h).

    Returns
    -------
    Response

    Raises
    ------
    BodyvibError
        An unknown model or a bad parameter file, a record sampled more coarsely than the
        head's figures allow (:func:`bodyvib.comfort.check_step`: 240 Hz for the shipped
        bodies).
    """
    if not models:
        raise BodyvibError("give at least one body model")
    nets = [(m, load_model(m)) for m in models]  # every model checked before any work
    # the head's figures are computed at the record's samples: its step must give them
    check_step(1.0 / signal.fs, [net for _, net in nets], name="sampling step")
    seat = comfort_figures(signal.acceleration, signal.fs)
    out = Response(
        signal=signal,
        seat_figures=seat,
        seat_checks=basic_method_checks(seat, signal.duration),
        seat_msdv=msdv(signal.acceleration, signal.fs),
        lee_pradko_power_w=lee_pradko_power(signal.acceleration, signal.fs),
        spinal=spinal_dose(signal.acceleration - signal.acceleration.mean(), signal.fs),
        axes=vibration_totals(_axes_in_order(signal), signal.fs, exposure_s),
    )
    for name, net in nets:
        head = head_acceleration(net, signal.acceleration, signal.fs)
        fig = comfort_figures(head, signal.fs)
        forces = internal_forces(net, signal.acceleration, signal.fs)
        label = _label(name)
        if label in out.bodies:
            label = name
        out.bodies[label] = BodyResponse(
            model=name,
            head_acceleration=head,
            figures=fig,
            checks=basic_method_checks(fig, signal.duration),
            forces=forces,
            force_figures={k: force_figures(f, 1.0 / signal.fs) for k, f in forces.items()},
        )
    return out
