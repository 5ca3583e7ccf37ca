"""Passive against controlled: the same car, occupant and road under several laws.

Each case is the seated car's exact closed loop
(:func:`bodyvib.vehicle.control.closed_loop_model`, discretized exactly; a car whose tires
are contacts and whose suspensions have stops regime by regime,
:class:`bodyvib.vehicle.control.ClosedLoopPiecewise`, with located events), so the
comparison needs no FMU and carries no coupling error; ``bodyvib cosim --control`` co-simulates the same loop with FMUs.
The figures are the classic trade-off of suspension control: ride comfort (the
occupant's head acceleration, ISO 2631-1 Wk-weighted r.m.s.), road holding (the
dynamic tire force r.m.s.), the rattle space used (suspension travel r.m.s.) and the
effort (actuator force r.m.s.). A car with several axles reports the r.m.s. over all
of them (the root of the mean of the axles' mean squares).
"""

from dataclasses import dataclass, field
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from bodyvib.comfort import check_step, weighted_rms
from bodyvib.process import interrupts
from bodyvib.runtime.discretize import Discretization, input_rates
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.network import Network, linear_model, linearized
from bodyvib.runtime.regimes import EventStepper, PiecewiseModel

from .control import (
    ClosedLoopPiecewise,
    SkyhookController,
    check_actuated,
    closed_loop_model,
    parse_control,
)
from .events import LinearRangeStream, linear_ranges
from .quarter_car import seated_system, wheel_offsets
from .records import Record
from .road.driven import RunSettings, driven_road, wheel_inputs

__all__ = [
    "LawFigures",
    "ControlComparison",
    "compare_laws",
    "format_comparison",
    "lift_offs",
    "plot_laws",
]

#: The laws compared by default: the passive car, then the default skyhook and groundhook.
DEFAULT_LAWS = ("passive", "skyhook", "groundhook")


@dataclass(frozen=True)
class LawFigures(Record):
    """The figures of one law on the road.

    Attributes
    ----------
    law : str
        As given (``"passive"``, ``"skyhook"``, ``"skyhook:c=3000"``).
    controller : SkyhookController or None
        None for the passive car.
    head_wk_rms : float
        Head acceleration, ISO 2631-1 Wk-weighted r.m.s., m/s2.
    tire_force_rms : float
        Dynamic tire force r.m.s., N.
    suspension_travel_rms : float
        Suspension deflection r.m.s., m.
    actuator_force_rms : float
        Actuator force r.m.s., N (0 for the passive car).
    events : dict
        What the tires and stops did: element name -> figures
        (:meth:`bodyvib.runtime.regimes.EventLog.summary`); empty for a linear car.
    warnings : tuple of str
        The linearized car's run: where it leaves its range at each wheel
        (:class:`bodyvib.vehicle.events.LinearRangeStream`); empty otherwise.
    """

    law: str
    controller: Optional[SkyhookController]
    head_wk_rms: float
    tire_force_rms: float
    suspension_travel_rms: float
    actuator_force_rms: float
    events: dict = field(default_factory=dict)
    warnings: Tuple[str, ...] = ()


@dataclass(frozen=True)
class ControlComparison:
    """The laws compared on one road.

    Attributes
    ----------
    car, body : str
        Model names.
    settings : RunSettings
        Road, speed, duration, step, seed.
    laws : tuple of LawFigures
    time : ndarray
        s.
    head, tire_force, suspension_travel : dict of str to ndarray
        Per law: head acceleration (m/s2), first axle's tire force (N) and suspension
        deflection (m) over time, for the plot.
    linear : bool
        The car ran linearized (its tires never left the road, no stops).
    """

    car: str
    body: str
    settings: RunSettings
    laws: Tuple[LawFigures, ...]
    time: np.ndarray
    head: Dict[str, np.ndarray]
    tire_force: Dict[str, np.ndarray]
    suspension_travel: Dict[str, np.ndarray]
    linear: bool = False


def lift_offs(figures: LawFigures) -> Tuple[int, int]:
    """A law's lift-offs (over its tires) and stop contacts (over its stops).

    Parameters
    ----------
    figures : LawFigures

    Returns
    -------
    (int, int)
        Both 0 for a linear car.

    Examples
    --------
    >>> lift_offs(LawFigures("passive", None, 1.0, 900.0, 0.01, 0.0, {
    ...     "tire": {"kind": "contact", "lift_offs": 2}, "stops": {"kind": "stop", "contacts": 1}}))
    (2, 1)
    """
    e = figures.events.values()
    return (
        sum(v["lift_offs"] for v in e if v["kind"] == "contact"),
        sum(v["contacts"] for v in e if v["kind"] == "stop"),
    )


def _axle_outputs(car: Network) -> Tuple[Tuple[str, ...], Tuple[str, ...]]:
    """The tire-force and suspension-deflection outputs, one per actuator (axle)."""
    tires, travels = [], []
    bases = set(car.bases)
    for act in car.actuators:
        pair = {act["from"], act["to"]}
        for el in car.elements:
            if el.kind == "stop":  # beside the suspension: its force is 0 within the gaps
                continue
            if {el.a, el.b} == pair:
                travels.append(f"{el.name}.deflection")
            elif act["from"] in (el.a, el.b) and ({el.a, el.b} & bases):
                tires.append(f"{el.name}.force")
    if len(tires) != len(car.actuators) or len(travels) != len(car.actuators):
        raise BodyvibError(
            f"car '{car.name}': each actuator needs a suspension element between its two "
            "points and a tire element from a road point to its lower point"
        )
    return tuple(tires), tuple(travels)


def _rms_over(y: np.ndarray) -> float:
    """Root of the mean square over all samples and columns."""
    return float(np.sqrt(np.mean(np.square(y))))


def _controllers(laws: Sequence[str], car: Network) -> list:
    """Each law's controller (None: passive); a semi-active law refused."""
    controllers = [None if law == "passive" else parse_control(law, car) for law in laws]
    for law, controller in zip(laws, controllers):
        if controller is not None and controller.semi_active:
            raise BodyvibError(
                f"law '{law}': the semi-active law is nonlinear; compare it by co-simulation "
                "(run_study)",
                parameters=("run_study",),
            )
    return controllers


def _range(car: Network, body: Network, step: float, axles: int):
    """The linear car's range at each axle (its wheels in the order of its actuators), or
    None where the car's wheels are not its axles."""
    ranges = linear_ranges(car, body.total_mass())
    if len(ranges) != axles or any(r.static_load is None for r in ranges):
        return None
    return LinearRangeStream(step, ranges)


def _law_models(seated: Network, car: Network, controllers):
    """Per law: ``(model, forces)``, a LinearModel and its actuator forces from the states
    for a linear car, a PiecewiseModel (:class:`ClosedLoopPiecewise` under a law) and None
    for a car with contacts and stops; and each law's model for the step check."""
    if not seated.nonlinear_elements:
        open_loop = linear_model(seated)
        loops = [
            (open_loop, np.zeros((0, len(open_loop.states))))
            if c is None
            else closed_loop_model(open_loop, car, c)
            for c in controllers
        ]
        return loops, [lm for lm, _ in loops]
    models = [
        PiecewiseModel(seated) if c is None else ClosedLoopPiecewise(seated, car, c)
        for c in controllers
    ]
    return [(m, None) for m in models], [m.regime(m.initial).model for m in models]


def _run_law(model, forces, u, du, h, names):
    """The outputs ``names`` (groups of outputs, their columns side by side) over the
    run, the actuator forces (columns, or None) and the events (:meth:`bodyvib.runtime.regimes.EventLog.summary`; ``{}`` for a
    linear car)."""
    if isinstance(model, PiecewiseModel):
        return _run_regimes(model, u, du, h, names)
    x = Discretization(model).run(u, du, h, safe_point=interrupts.check)

    def cols(group):  # the few outputs used, not all (3e6 samples: seconds)
        i = [model.output_index(s) for s in group]
        return x @ model.C[i].T + u @ model.D[i].T

    act = x @ forces.T if forces.size else None
    return np.hstack([cols(g) for g in names]), act, {}


def _run_regimes(model: PiecewiseModel, u, du, h, names):
    """:func:`_run_law` of a car with contacts and stops: exact steps, located events,
    each sample's outputs (and law) in its regime."""
    stepper = EventStepper(model)
    nominal = model.initial
    x = np.empty((u.shape[0], len(model.linear.states)))
    xk = np.zeros(x.shape[1])
    others = []
    for k in range(u.shape[0]):
        if not k & 4095:
            interrupts.check()
        x[k] = xk
        if stepper.state != nominal:
            others.append((k, stepper.state))
        xk = stepper.step(xk, u[k], du[k], h, k * h)
    reg = model.regime(nominal)
    i = [reg.model.output_index(s) for g in names for s in g]
    y = x @ reg.model.C[i].T + u @ reg.model.D[i].T + reg.d[i]
    closed = isinstance(model, ClosedLoopPiecewise)
    act = model.force(nominal, x) if closed else None
    for k, state in others:
        reg = model.regime(state)
        y[k] = reg.model.C[i] @ x[k] + reg.model.D[i] @ u[k] + reg.d[i]
        if closed:
            act[k] = model.force(state, x[k])
    return y, act, stepper.log.summary()


def compare_laws(
    car: Network,
    body: Network,
    settings: Optional[RunSettings] = None,
    laws: Sequence[str] = DEFAULT_LAWS,
    linear: bool = False,
) -> ControlComparison:
    """Run the seated car on one road under each law; the comfort and handling figures.

    A car with tire contacts and stops runs each law's closed loop by regime, stepped
    exactly with located events (:class:`~bodyvib.vehicle.control.ClosedLoopPiecewise`):
    a wheel leaves the road, a suspension meets its stops; ``linear`` runs it linearized.

    Parameters
    ----------
    car : Network
        A car with ``actuators`` (:func:`bodyvib.vehicle.quarter_car.load_car`).
    body : Network
        The occupant (base ``seat``, role ``head``).
    settings : RunSettings, optional
        Road, speed, duration, step, seed (default: those of ``bodyvib cosim``).
    laws : sequence of str
        ``"passive"`` or a controller as :func:`bodyvib.vehicle.control.parse_control`
        reads it (linear laws only: the closed loop is solved exactly).
    linear : bool
        Run the car linearized about static equilibrium
        (:func:`bodyvib.runtime.network.linearized`: the tires never leave the road, no
        stops): the linear active car, its figures those of its exact discretization.

    Returns
    -------
    ControlComparison

    Raises
    ------
    BodyvibError
        A car without actuators, an unknown or semi-active law, bad settings, a step
        longer than the figures allow (:func:`bodyvib.comfort.check_step`).

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> c = compare_laws(load_car("quarter-car-active"), load_model("reduced-paper"),
    ...                  RunSettings("C", 20.0, 5.0), ["passive", "skyhook"])
    >>> [f.law for f in c.laws], c.laws[1].head_wk_rms < c.laws[0].head_wk_rms
    (['passive', 'skyhook'], True)
    """
    check_actuated(car)
    settings = RunSettings() if settings is None else settings
    tires, travels = _axle_outputs(car)
    h, speed = settings.step, settings.speed
    n = int(round(settings.duration / h)) + 1
    t = np.arange(n) * h
    z, v = wheel_inputs(driven_road(settings), speed, t, wheel_offsets(car))
    seated = seated_system(linearized(car) if linear else car, body)
    open_loop = linear_model(seated)  # the inputs' order (every regime's)
    u = np.zeros((n, len(open_loop.inputs)))
    nb = len(car.bases)
    u[:, 0 : 2 * nb : 2], u[:, 1 : 2 * nb : 2] = z, v
    du = input_rates(open_loop, u)
    head = f"body.{body.roles['head']}.a"
    controllers = _controllers(laws, car)
    loops, checked = _law_models(seated, car, controllers)
    check_step(h, checked)  # before any run: the figures' step
    rows, traces = [], ({}, {}, {})
    names = ([head], tires, travels)
    na = len(tires)
    for law, controller, (model, forces) in zip(laws, controllers, loops):
        y, act, events = _run_law(model, forces, u, du, h, names)
        interrupts.check()
        a_head, tire, travel = y[:, 0], y[:, 1 : 1 + na], y[:, 1 + na :]
        rng = _range(car, body, h, na) if linear else None
        if rng is not None:  # where the linear car leaves its range, at each axle
            rng.update(tire, travel)
        rows.append(
            LawFigures(
                law=law,
                controller=controller,
                head_wk_rms=weighted_rms(a_head, 1.0 / h),
                tire_force_rms=_rms_over(tire),
                suspension_travel_rms=_rms_over(travel),
                actuator_force_rms=_rms_over(act) if act is not None else 0.0,
                events=events,
                warnings=tuple(rng.warnings()) if rng is not None else (),
            )
        )
        for trace, signal in zip(traces, (a_head, tire[:, 0], travel[:, 0])):
            trace[law] = signal
    return ControlComparison(
        car=car.name,
        body=body.name,
        settings=settings,
        laws=tuple(rows),
        time=t,
        head=traces[0],
        tire_force=traces[1],
        suspension_travel=traces[2],
        linear=linear or not seated.nonlinear_elements,
    )


def format_comparison(comparison: ControlComparison) -> str:
    """The comparison as a text table, one row per law.

    Parameters
    ----------
    comparison : ControlComparison

    Returns
    -------
    str
    """
    s = comparison.settings
    how = "linearized" if comparison.linear else "tires and stops stepped with events"
    events = not comparison.linear
    lines = [
        f"{comparison.body} on {comparison.car}: road {s.road}, {s.speed:g} m/s, "
        f"{s.duration:g} s, step {s.step:g} s (exact closed loop, {how})",
        "",
        f"{'law':<16}{'c_sky':>8}{'c_ground':>10}{'head Wk rms':>13}{'tire force':>12}"
        f"{'susp. travel':>14}{'actuator':>10}"
        + (f"{'lift-offs':>11}{'stops':>7}" if events else ""),
        f"{'':<16}{'[N s/m]':>8}{'[N s/m]':>10}{'[m/s2]':>13}{'rms [N]':>12}"
        f"{'rms [mm]':>14}{'rms [N]':>10}",
    ]
    for f in comparison.laws:
        c = f.controller or SkyhookController()
        n_lift, n_stop = lift_offs(f)
        lines.append(
            f"{f.law:<16}{c.c_sky:>8.0f}{c.c_ground:>10.0f}{f.head_wk_rms:>13.3f}"
            f"{f.tire_force_rms:>12.0f}{1e3 * f.suspension_travel_rms:>14.2f}"
            f"{f.actuator_force_rms:>10.0f}" + (f"{n_lift:>11d}{n_stop:>7d}" if events else "")
        )
    lines += [f"warning: {f.law}: {w}" for f in comparison.laws for w in f.warnings]
    return "\n".join(lines)


def plot_laws(comparison: ControlComparison, path, window_s: float = 3.0) -> None:
    """Head acceleration, tire force and suspension travel of each law over a window.

    Parameters
    ----------
    comparison : ControlComparison
    path : str or os.PathLike
        Plot file (.png, .pdf or .svg), written atomically.
    window_s : float
        Length of the window shown, s, mid-run.

    Raises
    ------
    BodyvibError
        An unsupported plot file extension.
    """
    from bodyvib.plotting import new_figure, save_figure

    t = comparison.time
    mid = t[-1] / 2
    w = (t >= mid - window_s / 2) & (t <= mid + window_s / 2)
    fig, axes = new_figure(3, 1, sharex=True, figsize=(8, 8))
    panels = (
        (comparison.head, 1.0, "head acceleration [m/s2]"),
        (comparison.tire_force, 1.0, "tire force (first axle) [N]"),
        (comparison.suspension_travel, 1e3, "suspension travel (first axle) [mm]"),
    )
    figures = {f.law: f for f in comparison.laws}
    for ax, (traces, scale, label) in zip(axes, panels):
        for law, y in traces.items():
            ax.plot(t[w], scale * y[w], lw=0.8, label=f"{law} (Wk {figures[law].head_wk_rms:.2f})")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right", fontsize="small", title="head Wk r.m.s. [m/s2]")
    axes[-1].set_xlabel("time [s]")
    s = comparison.settings
    axes[0].set_title(f"{comparison.body} on {comparison.car}, road {s.road} at {s.speed:g} m/s")
    save_figure(fig, path)
