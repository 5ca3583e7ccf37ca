"""Passive against controlled: the same car, occupant and road under several laws.

Each case is the seated car's exact closed loop
(:func:`bodyvib.vehicle.control.closed_loop_model`, discretized exactly), so the
comparison needs no FMU and carries no coupling error; ``bodyvib cosim --control`` co-simulates the same loop with FMUs.
The figures are the classic trade-off of suspension control: ride comfort (the
occupant's head acceleration, ISO 2631-1 Wk-weighted r.m.s.), road holding (the
dynamic tire force r.m.s.), the rattle space used (suspension travel r.m.s.) and the
effort (actuator force r.m.s.). A car with several axles reports the r.m.s. over all
of them (the root of the mean of the axles' mean squares).
"""

from dataclasses import dataclass
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from bodyvib.comfort import check_step, weighted_rms
from bodyvib.process import interrupts
from bodyvib.runtime.discretize import Discretization, input_rates
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.network import Network, linear_model

from .control import SkyhookController, check_actuated, closed_loop_model, parse_control
from .quarter_car import seated_system, wheel_offsets
from .records import Record
from .road.driven import RunSettings, driven_road, wheel_inputs

__all__ = ["LawFigures", "ControlComparison", "compare_laws", "format_comparison", "plot_laws"]

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
    """

    law: str
    controller: Optional[SkyhookController]
    head_wk_rms: float
    tire_force_rms: float
    suspension_travel_rms: float
    actuator_force_rms: float


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
    """

    car: str
    body: str
    settings: RunSettings
    laws: Tuple[LawFigures, ...]
    time: np.ndarray
    head: Dict[str, np.ndarray]
    tire_force: Dict[str, np.ndarray]
    suspension_travel: Dict[str, np.ndarray]


def _axle_outputs(car: Network) -> Tuple[Tuple[str, ...], Tuple[str, ...]]:
    """The tire-force and suspension-deflection outputs, one per actuator (axle)."""
    tires, travels = [], []
    bases = set(car.bases)
    for act in car.actuators:
        pair = {act["from"], act["to"]}
        for el in car.elements:
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


def compare_laws(
    car: Network,
    body: Network,
    settings: Optional[RunSettings] = None,
    laws: Sequence[str] = DEFAULT_LAWS,
) -> ControlComparison:
    """Run the seated car on one road under each law; the comfort and handling figures.

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
    open_loop = linear_model(seated_system(car, body))
    u = np.zeros((n, len(open_loop.inputs)))
    nb = len(car.bases)
    u[:, 0 : 2 * nb : 2], u[:, 1 : 2 * nb : 2] = z, v
    du = input_rates(open_loop, u)
    head = f"body.{body.roles['head']}.a"
    controllers = [None if law == "passive" else parse_control(law, car) for law in laws]
    for law, controller in zip(laws, controllers):
        if controller is not None and controller.semi_active:
            raise BodyvibError(
                f"law '{law}': the semi-active law is nonlinear; compare it by co-simulation "
                "(run_study)",
                parameters=("run_study",),
            )
    loops = [
        (open_loop, np.zeros((0, len(open_loop.states))))
        if controller is None
        else closed_loop_model(open_loop, car, controller)
        for controller in controllers
    ]
    check_step(h, [lm for lm, _ in loops])  # before any run: the figures' step
    rows, traces = [], ({}, {}, {})
    for law, controller, (lm, forces) in zip(laws, controllers, loops):
        x = Discretization(lm).run(u, du, h, safe_point=interrupts.check)
        interrupts.check()

        def cols(names, x=x, lm=lm):  # the few outputs used, not all (3e6 samples: seconds)
            i = [lm.output_index(s) for s in names]
            return x @ lm.C[i].T + u @ lm.D[i].T

        a_head = cols([head])[:, 0]
        rows.append(
            LawFigures(
                law=law,
                controller=controller,
                head_wk_rms=weighted_rms(a_head, 1.0 / h),
                tire_force_rms=_rms_over(cols(tires)),
                suspension_travel_rms=_rms_over(cols(travels)),
                actuator_force_rms=_rms_over(x @ forces.T) if forces.size else 0.0,
            )
        )
        for trace, signal in zip(traces, (a_head, cols(tires)[:, 0], cols(travels)[:, 0])):
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
    lines = [
        f"{comparison.body} on {comparison.car}: road {s.road}, {s.speed:g} m/s, "
        f"{s.duration:g} s, step {s.step:g} s (exact closed loop)",
        "",
        f"{'law':<16}{'c_sky':>8}{'c_ground':>10}{'head Wk rms':>13}{'tire force':>12}"
        f"{'susp. travel':>14}{'actuator':>10}",
        f"{'':<16}{'[N s/m]':>8}{'[N s/m]':>10}{'[m/s2]':>13}{'rms [N]':>12}"
        f"{'rms [mm]':>14}{'rms [N]':>10}",
    ]
    for f in comparison.laws:
        c = f.controller or SkyhookController()
        lines.append(
            f"{f.law:<16}{c.c_sky:>8.0f}{c.c_ground:>10.0f}{f.head_wk_rms:>13.3f}"
            f"{f.tire_force_rms:>12.0f}{1e3 * f.suspension_travel_rms:>14.2f}"
            f"{f.actuator_force_rms:>10.0f}"
        )
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
