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
from typing import Optional

import numpy as np

__all__ = ["RunEvents", "EventStream", "format_events", "combine_events"]


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


def format_events(e: RunEvents) -> str:
    """The lift-offs' cell of the text report: ``2 (80 ms, 66 ms)``: their count, the time
    in the air and the longest flight."""
    if not e.lift_offs:
        return "0"
    return f"{e.lift_offs} ({1e3 * e.time_in_air_s:.0f} ms, {1e3 * e.longest_flight_s:.0f} ms)"


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
