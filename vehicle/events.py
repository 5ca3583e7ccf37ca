"""What a run's tire and stops did: lift-offs, flights, stop contacts, the lowest tire load.

A car with a tire contact and suspension stops (:mod:`bodyvib.runtime.regimes`) gives, at
each communication point, its contact flag (``tire_contact``), its stop force
(``stop_force``) and its dynamic tire force (``tire_force``, the perturbation about the
static wheel load). :class:`EventStream` reads them block by block and gives a run's
:class:`RunEvents`: at the resolution of the communication step (the car FMU locates each
event inside its step; the monolithic reference's own log has the located times). A car
with several wheels gives these per wheel (:func:`bodyvib.vehicle.signals.wheel_columns`):
one :class:`RunEvents` per wheel, and :func:`combine_events` the car's.
"""

from dataclasses import asdict, dataclass
from typing import Optional, Tuple

import numpy as np

__all__ = [
    "RunEvents",
    "EventStream",
    "CarEventStream",
    "format_events",
    "LinearRange",
    "LinearRangeStream",
    "LinearRangeWarning",
    "linear_range",
    "linear_ranges",
    "seated_preloads",
    "combine_events",
]


@dataclass(frozen=True)
class RunEvents:
    """A run's events, at its communication points.

    Attributes
    ----------
    lift_offs : int
        Times the tire left the road (contact flag 1 -> 0).
    time_in_air_s : float
        Time with the contact flag 0, s.
    longest_flight_s : float
        Longest stretch with the flag 0, s.
    stop_contacts : int
        Times a stop was met (stop force 0 -> not 0).
    largest_stop_force_n : float
        Largest stop force (either stop), N.
    smallest_tire_load_ratio : float or None
        Smallest total tire force over the static one (1 at rest, 0 in the air); None
        when the static load is unknown (a car FMU without its model).
    """

    lift_offs: int
    time_in_air_s: float
    longest_flight_s: float
    stop_contacts: int
    largest_stop_force_n: float
    smallest_tire_load_ratio: Optional[float]

    def to_dict(self) -> dict:
        """The JSON form (the attribute names)."""
        return asdict(self)


class EventStream:
    """:class:`RunEvents` of a run fed block by block.

    Parameters
    ----------
    step : float
        Communication step, s.
    static_load : float, optional
        The tire's static load, N (for the load ratio).

    Examples
    --------
    >>> s = EventStream(0.001, 4000.0)
    >>> s.update(np.array([1, 0, 0, 1.0]), np.zeros(4), np.array([0, -4000, -4000, 10.0]))
    >>> s.result().lift_offs, round(s.result().longest_flight_s, 6)
    (1, 0.002)
    """

    def __init__(self, step: float, static_load: Optional[float] = None):
        self._h = float(step)
        self._f0 = static_load
        self._contact = 1.0  # the previous point's flag (at rest: on the road)
        self._stop = 0.0
        self._run = 0  # points of the current flight
        self.lift_offs = self.stop_contacts = self.air = self.longest = 0
        self.stop_max = 0.0
        self.tire_min = np.inf

    def update(self, contact, stop_force, tire_force) -> None:
        """Take the next communication points' contact flags, stop forces and tire forces."""
        c = np.asarray(contact, dtype=float)
        f = np.asarray(stop_force, dtype=float)
        off = c < 0.5
        prev = np.concatenate([[self._contact], c[:-1]]) >= 0.5
        self.lift_offs += int(np.count_nonzero(prev & off))
        self.air += int(np.count_nonzero(off))
        for flag in off.tolist():  # the longest run of points in the air
            self._run = self._run + 1 if flag else 0
            self.longest = max(self.longest, self._run)
        on = f != 0.0
        was = np.concatenate([[self._stop], f[:-1]]) != 0.0
        self.stop_contacts += int(np.count_nonzero(on & ~was))
        if f.size:
            self.stop_max = max(self.stop_max, float(np.max(np.abs(f))))
            self.tire_min = min(self.tire_min, float(np.min(tire_force)))
            self._contact, self._stop = float(c[-1]), float(f[-1])

    def result(self) -> RunEvents:
        """The events so far."""
        ratio = None
        if self._f0 and np.isfinite(self.tire_min):
            ratio = max(0.0, (self._f0 + self.tire_min) / self._f0)
        return RunEvents(
            lift_offs=self.lift_offs,
            time_in_air_s=self.air * self._h,
            longest_flight_s=self.longest * self._h,
            stop_contacts=self.stop_contacts,
            largest_stop_force_n=self.stop_max,
            smallest_tire_load_ratio=ratio,
        )


class CarEventStream:
    """The events of a car's run fed block by block from its signals: each wheel's
    (:class:`EventStream` on ``tire_contact_<wheel>``, ``stop_force_<wheel>``,
    ``tire_force_<wheel>``) and the car's (:func:`combine_events` of the wheels'; a car
    without per-wheel columns, a quarter car: its ``tire_contact``, ``stop_force`` and
    ``tire_force``).

    Parameters
    ----------
    step : float
        Communication step, s.
    tire_loads : dict of str to float or None
        The tires' static loads by tire-force output (``tire_force``,
        ``tire_force_front``, ...), N, for the load ratios.
    wheels : sequence of str
        The wheels with their own columns (:data:`bodyvib.vehicle.signals.WHEELS`), empty
        for a quarter car.

    Examples
    --------
    >>> s = CarEventStream(0.001, {"tire_force_front": 4000.0, "tire_force_rear": 3000.0},
    ...                    ["front", "rear"])
    >>> off = {"tire_contact": np.array([1, 0, 1.0]), "stop_force": np.zeros(3),
    ...        "tire_force": np.array([0, -4000, 0.0])}
    >>> s.update({f"{k}_{w}": x for k, x in off.items() for w in ("front", "rear")})
    >>> s.result().lift_offs, sorted(s.wheel_results())
    (2, ['front', 'rear'])
    """

    def __init__(self, step: float, tire_loads, wheels=()):
        from .signals import corner_variable

        self.wheels = {w: EventStream(step, tire_loads.get(f"tire_force_{w}")) for w in wheels}
        self._car = None
        if not self.wheels:
            self._car = EventStream(step, tire_loads.get(corner_variable("tire_force", tire_loads)))

    def update(self, signals) -> None:
        """Take the next communication points' signals, by name."""
        from .signals import WHEEL_SIGNALS

        if self._car is not None:
            self._car.update(*(signals[k] for k in WHEEL_SIGNALS))
        for w, stream in self.wheels.items():
            stream.update(*(signals[f"{k}_{w}"] for k in WHEEL_SIGNALS))

    def result(self) -> RunEvents:
        """The car's events so far."""
        if self._car is not None:
            return self._car.result()
        return combine_events([e.result() for e in self.wheels.values()])

    def wheel_results(self) -> dict:
        """Each wheel's events so far (empty for a quarter car)."""
        return {w: e.result() for w, e in self.wheels.items()}


def format_events(e: RunEvents) -> str:
    """The lift-offs' cell of the text report: ``2 (80 ms, 66 ms)``: their count, the time
    in the air and the longest flight."""
    if not e.lift_offs:
        return "0"
    return f"{e.lift_offs} ({1e3 * e.time_in_air_s:.0f} ms, {1e3 * e.longest_flight_s:.0f} ms)"


class LinearRangeWarning(UserWarning):
    """A run of a car's linear model left its range (:class:`LinearRangeStream`): a message
    to the user about the run, not a defect of the program."""


@dataclass(frozen=True)
class LinearRange:
    """Where a car's linear model holds at one wheel: its tire's static load and its
    suspension's stop gaps, from the car with its nonlinear elements (:func:`linear_ranges`).

    Attributes
    ----------
    static_load : float or None
        The tire's static load with the occupant, N (None: the tire is no contact).
    gap_compression, gap_rebound : float or None
        Suspension travel from static equilibrium to the bump (rebound) stop, m (None:
        no stops on that suspension).
    wheel : str
        The wheel (:data:`bodyvib.vehicle.signals.WHEELS`, e.g. ``"rear"``,
        ``"front_left"``); ``""`` for a car with one (a quarter car). Its run's columns are
        ``tire_force_<wheel>`` and ``suspension_deflection_<wheel>``.
    """

    static_load: Optional[float]
    gap_compression: Optional[float]
    gap_rebound: Optional[float]
    wheel: str = ""

    @property
    def columns(self) -> Tuple[str, str]:
        """The run's columns of this wheel's dynamic tire force and suspension deflection."""
        tail = f"_{self.wheel}" if self.wheel else ""
        return f"tire_force{tail}", f"suspension_deflection{tail}"


def seated_preloads(car, occupant_mass: Optional[float] = None):
    """The static forces of a car's contacts with an occupant's weight on its seat point.

    Parameters
    ----------
    car : Network
        The car with its nonlinear elements.
    occupant_mass : float, optional
        The occupant's mass, kg (the car's own ``static_loads`` value, e.g. ``m_occupant``,
        if not given or if the car has no seat load).

    Returns
    -------
    preloads : dict of str to float
        Contact element -> static force, N (:func:`bodyvib.runtime.network.static_preloads`):
        every tire's.
    occupant : dict of str to float
        The car's start values that put that weight on its seat (empty: the car's own).

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> pre, occupant = seated_preloads(load_car(), 69.88)
    >>> round(pre["tire"]), occupant
    (4108, {'m_occupant': 69.88})
    >>> pre, _ = seated_preloads(load_car("half-car"), 69.88)
    >>> {k: round(v) for k, v in pre.items()}
    {'tire_front': 4409, 'tire_rear': 3877}
    """
    from bodyvib.runtime.network import static_preloads

    ref = car.static_loads.get(car.roles.get("seat", ""))
    occupant = {}
    if isinstance(ref, str) and occupant_mass is not None:
        occupant = {ref: float(occupant_mass)}
    return static_preloads(car.with_parameters(**occupant) if occupant else car), occupant


def linear_ranges(car, occupant_mass: Optional[float] = None) -> Tuple[LinearRange, ...]:
    """The range of a car's linearization at each wheel: its tire's static load and its
    suspension's stop gaps.

    Parameters
    ----------
    car : Network
        The car with its nonlinear elements (:func:`bodyvib.vehicle.quarter_car.load_car`).
    occupant_mass : float, optional
        The occupant's mass, kg, on the car's seat point for the static loads (the car's
        own ``static_loads`` value, e.g. ``m_occupant``, if not given).

    Returns
    -------
    tuple of LinearRange
        One per wheel whose tire force and suspension deflection the car outputs
        (``tire_force_<wheel>``, ``suspension_deflection_<wheel>``), in the order of
        :data:`bodyvib.vehicle.signals.WHEELS`; a quarter car's one (``wheel`` ``""``).

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> [(r.wheel, round(r.static_load)) for r in linear_ranges(load_car("half-car"), 69.88)]
    [('front', 4409), ('rear', 3877)]
    """
    from .signals import WHEELS

    outs = {o["name"]: o["signal"] for o in car.fmu_outputs}
    wheels = [w for w in WHEELS if {f"tire_force_{w}", f"suspension_deflection_{w}"} <= set(outs)]
    preloads = seated_preloads(car, occupant_mass)[0]
    elements = {e.name: e for e in car.elements}
    out = []
    for wheel in wheels or [""]:
        probe = LinearRange(None, None, None, wheel)
        tire, susp = (outs.get(c, "").rpartition(".")[0] for c in probe.columns)
        gaps: tuple = (None, None)
        s = elements.get(susp)
        for e in car.elements:
            if s is not None and e.kind == "stop" and {e.a, e.b} == {s.a, s.b}:
                gaps = tuple(car.value(e.values[k]) for k in ("gap_compression", "gap_rebound"))
        out.append(LinearRange(preloads.get(tire) if tire else None, *gaps, wheel=wheel))
    return tuple(out)


def linear_range(car, occupant_mass: Optional[float] = None) -> LinearRange:
    """The range of a car's linearization at its (front, front left) wheel
    (:func:`linear_ranges`' first).

    Parameters
    ----------
    car : Network
        The car with its nonlinear elements (:func:`bodyvib.vehicle.quarter_car.load_car`).
    occupant_mass : float, optional
        As :func:`linear_ranges`.

    Returns
    -------
    LinearRange

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> r = linear_range(load_car(), 69.88)
    >>> round(r.static_load), r.gap_compression, r.gap_rebound
    (4108, 0.07, 0.09)
    """
    return linear_ranges(car, occupant_mass)[0]


#: The fix each line of :class:`LinearRangeStream` ends with (the command line shows
#: ``'linear'`` as its flag, ``--linear``).
_FIX = "run without 'linear'"


class _WheelRange:
    """The extremes of one wheel's dynamic tire force and suspension deflection so far."""

    def __init__(self):
        self.tire = (np.inf, 0)  # smallest dynamic tire force, N, and its point
        self.low = (np.inf, 0)  # smallest deflection (compression), m, and its point
        self.high = (-np.inf, 0)  # largest deflection (rebound), m, and its point

    def update(self, f: np.ndarray, d: np.ndarray, k: int) -> None:
        i, j, m = int(np.argmin(f)), int(np.argmin(d)), int(np.argmax(d))
        if f[i] < self.tire[0]:
            self.tire = (float(f[i]), k + i)
        if d[j] < self.low[0]:
            self.low = (float(d[j]), k + j)
        if d[m] > self.high[0]:
            self.high = (float(d[m]), k + m)

    def warnings(self, lim: LinearRange, h: float) -> list:
        where = f"{lim.wheel.replace('_', ' ')} " if lim.wheel else ""
        out, f0 = [], lim.static_load
        if f0 and self.tire[0] < -f0:
            pull = -(f0 + self.tire[0])
            out.append(
                f"the linear {where}tire pulls with up to {pull / 1e3:.1f} kN ({pull / f0:.1f}x "
                f"the static load) at t = {self.tire[1] * h:.2f} s: the wheel would leave the "
                f"road; {_FIX}"
            )
        for (x, k), gap, sign, way, stop in (
            (self.low, lim.gap_compression, -1.0, "compression", "bump"),
            (self.high, lim.gap_rebound, 1.0, "rebound", "rebound"),
        ):
            if gap is not None and np.isfinite(x) and sign * x > gap:
                out.append(
                    f"the linear {where}suspension travels {1e3 * sign * x:.0f} mm in {way} at "
                    f"t = {k * h:.2f} s, beyond the {stop} stop's gap of {1e3 * gap:.0f} mm: "
                    f"the car would hit it; {_FIX}"
                )
        return out


class LinearRangeStream:
    """Where a run of a car's linear model leaves its range, fed block by block, at every
    wheel.

    Parameters
    ----------
    step : float
        Communication step, s.
    limits : LinearRange or sequence of LinearRange
        The nonlinear car's static tire load and stop gaps, per wheel
        (:func:`linear_ranges`).

    Attributes
    ----------
    columns : tuple of str
        The run's columns :meth:`update_columns` reads: each wheel's
        (:attr:`LinearRange.columns`).

    Examples
    --------
    >>> s = LinearRangeStream(0.01, LinearRange(4000.0, 0.07, 0.09))
    >>> s.update(np.array([0.0, -9300.0, 100.0]), np.array([0.0, -0.1, 0.02]))
    >>> for line in s.warnings(): print(line)
    the linear tire pulls with up to 5.3 kN (1.3x the static load) at t = 0.01 s: the wheel would leave the road; run without 'linear'
    the linear suspension travels 100 mm in compression at t = 0.01 s, beyond the bump stop's gap of 70 mm: the car would hit it; run without 'linear'
    >>> s = LinearRangeStream(0.01, [LinearRange(4400.0, 0.07, 0.09, "front"),
    ...                              LinearRange(3900.0, 0.07, 0.09, "rear")])
    >>> s.update_columns({"tire_force_front": np.zeros(2), "suspension_deflection_front":
    ...                   np.zeros(2), "tire_force_rear": np.array([0.0, -5000.0]),
    ...                   "suspension_deflection_rear": np.zeros(2)})
    >>> s.warnings()[0][:48]
    'the linear rear tire pulls with up to 1.1 kN (0.'
    """

    def __init__(self, step: float, limits):
        self._h = float(step)
        self.limits: Tuple[LinearRange, ...] = (
            (limits,) if isinstance(limits, LinearRange) else tuple(limits)
        )
        self._k = 0  # points seen
        self._wheels = [_WheelRange() for _ in self.limits]
        self.columns = tuple(c for lim in self.limits for c in lim.columns)

    def update(self, tire_force, deflection) -> None:
        """Take the next points' dynamic tire forces (N, + in compression) and suspension
        deflections (m, + in extension): arrays of the points, or with a column per wheel
        in the order of ``limits``."""
        f, d = np.asarray(tire_force, dtype=float), np.asarray(deflection, dtype=float)
        f, d = f.reshape(f.shape[0], -1), d.reshape(d.shape[0], -1)
        if f.shape[1] != len(self._wheels) or d.shape != f.shape:
            raise ValueError(
                f"{f.shape[1]} tire-force and {d.shape[1]} deflection columns for "
                f"{len(self._wheels)} wheels"
            )
        if f.shape[0]:
            for j, wheel in enumerate(self._wheels):
                wheel.update(f[:, j], d[:, j], self._k)
        self._k += f.shape[0]

    def update_columns(self, signals) -> None:
        """:meth:`update` from a block's signals by name (``columns``)."""
        tire = np.column_stack([signals[lim.columns[0]] for lim in self.limits])
        self.update(tire, np.column_stack([signals[lim.columns[1]] for lim in self.limits]))

    def warnings(self) -> list:
        """One line for each way the run left the range at each wheel (none: an empty
        list)."""
        return [
            line
            for lim, wheel in zip(self.limits, self._wheels)
            for line in wheel.warnings(lim, self._h)
        ]


def combine_events(wheels) -> RunEvents:
    """The events of a car with several wheels from each wheel's.

    Parameters
    ----------
    wheels : sequence of RunEvents
        One per wheel.

    Returns
    -------
    RunEvents
        Lift-offs, stop contacts and the time in the air summed over the wheels (wheel
        seconds: two wheels in the air for 10 ms count 20 ms); the longest flight, the
        largest stop force and the smallest tire-load ratio over the wheels (the ratio None
        if any wheel's static load is unknown).

    Examples
    --------
    >>> a = RunEvents(1, 0.05, 0.05, 0, 0.0, 0.0)
    >>> b = RunEvents(2, 0.03, 0.02, 1, 900.0, 0.0)
    >>> e = combine_events([a, b])
    >>> e.lift_offs, round(e.time_in_air_s, 3), e.longest_flight_s, e.largest_stop_force_n
    (3, 0.08, 0.05, 900.0)
    """
    ratios = [e.smallest_tire_load_ratio for e in wheels]
    return RunEvents(
        lift_offs=sum(e.lift_offs for e in wheels),
        time_in_air_s=sum(e.time_in_air_s for e in wheels),
        longest_flight_s=max(e.longest_flight_s for e in wheels),
        stop_contacts=sum(e.stop_contacts for e in wheels),
        largest_stop_force_n=max(e.largest_stop_force_n for e in wheels),
        smallest_tire_load_ratio=None if None in ratios else min(ratios),
    )
