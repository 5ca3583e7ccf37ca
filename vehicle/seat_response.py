"""A seat's response: its transmissibility with an occupant on it and its SEAT value.

:func:`seat_transmissibility` gives the floor-to-pan and floor-to-head transmissibility of
a seat (:mod:`bodyvib.vehicle.seats`) with each body sitting on it, the pan curve's peak
being the seat-occupant resonance; :func:`seat_value` the SEAT value (ISO 10326-1) of a
seat in a car on an ISO 8608 road. ``bodyvib frf --seat`` prints both.
"""

from dataclasses import dataclass, field
from typing import Dict, Optional, Sequence

import numpy as np

from bodyvib.frequency.compare import ModelTransmissibility, TransmissibilityComparison
from bodyvib.frequency.response import find_peaks, frequency_response
from bodyvib.models import load_model
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.network import linear_model, mount

from .design.stationary import random_response
from .quarter_car import load_car, seated_system
from .seats import FLOOR, SEAT_SEPARATOR, check_seat, load_seat, mount_seat

__all__ = ["SeatTransmissibility", "seat_transmissibility", "seat_value"]


def seat_value(car, body="reduced-paper") -> float:
    """The SEAT value of a car's seat on an ISO 8608 road, percent.

    SEAT (seat effective amplitude transmissibility, ISO 10326-1) is the Wk-weighted
    r.m.s. acceleration of the seat pan over that of the floor under the seat, times 100:
    below 100 % the seat isolates, above it amplifies. Both r.m.s. values are the exact
    stationary ones of the car with the occupant on an ISO 8608 road (a Lyapunov
    equation, :func:`bodyvib.vehicle.design.stationary.random_response`). An ISO 8608 road
    of waviness 2 has a white velocity spectrum in time at any class and speed, so the
    SEAT value is the same on every such road: a property of car, seat and occupant.

    Parameters
    ----------
    car : str or Network
        A car with a seat (``"quarter-car+suspension"``), driven at one road point.
    body : str or Network
        The occupant (body model).

    Returns
    -------
    float
        ``100 a_w,pan / a_w,floor``, percent.

    Raises
    ------
    BodyvibError
        A car without a seat (no ``floor`` role), or one driven at several road points.

    Examples
    --------
    >>> round(seat_value("quarter-car+suspension"), 1)
    40.2
    """
    net = load_car(car) if isinstance(car, str) else car
    if FLOOR not in net.roles:
        raise BodyvibError(
            f"vehicle model '{net.name}' has no seat (no '{FLOOR}' role) to take a SEAT "
            "value of: give a car with a seat, e.g. quarter-car+suspension"
        )
    if net.extra_bases:
        raise BodyvibError(
            f"the SEAT value is computed for a car driven at one road point; "
            f"'{net.name}' has {len(net.bases)} (use its quarter car)"
        )
    occupant = load_model(body) if isinstance(body, str) else body
    lm = linear_model(seated_system(net, occupant))
    r = random_response(lm, "C", 20.0, [], ["seat.a", f"{FLOOR}.a"])
    pan, floor = r.weighted_rms
    return 100.0 * pan / floor


@dataclass(frozen=True)
class SeatTransmissibility(TransmissibilityComparison):
    """A seat's transmissibility curves (:func:`seat_transmissibility`) and its SEAT values.

    Attributes
    ----------
    seat : str
        The seat's name.
    car : str
        The car of the SEAT values ('' when none were computed).
    seat_value_percent : dict of str to float
        Body name -> SEAT value (:func:`seat_value`) of the seat in ``car``, percent.
    """

    seat: str = ""
    car: str = ""
    seat_value_percent: Dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The comparison's JSON document with ``seat``, ``car`` and ``seat_value_percent``."""
        return dict(
            super().to_dict(),
            seat=self.seat,
            car=self.car,
            seat_value_percent=dict(self.seat_value_percent),
        )

    def summary(self) -> str:
        """One line per body: the SEAT value in the car (empty without a car)."""
        return "\n".join(
            f"SEAT value of {self.seat} in {self.car} with {body}, ISO 8608 road (any class "
            f"and speed): {value:.1f} %"
            for body, value in self.seat_value_percent.items()
        )


def seat_transmissibility(
    seat="suspension",
    bodies: Sequence = ("reduced-paper",),
    f_min: float = 0.5,
    f_max: float = 31.5,
    points: int = 1200,
    car: Optional[str] = None,
) -> SeatTransmissibility:
    """Floor-to-pan and floor-to-head transmissibility of a seat with an occupant on it.

    The occupant sits on the seat's pan (two-way coupled: its apparent mass loads the
    cushion) and the floor moves: ``X_pan / X_floor`` is what the seat passes to the
    occupant, ``X_head / X_floor`` what reaches the head. The peak of the pan curve is the
    seat-occupant resonance.

    Parameters
    ----------
    seat : str or Network
        Shipped seat name, parameter file or seat model.
    bodies : sequence of str or Network
        Body models (shipped names, parameter files or networks).
    f_min, f_max : float
        Frequency range, Hz.
    points : int
        Logarithmically spaced frequency points.
    car : str, optional
        A car (without a seat, driven at one road point) to put the seat in for the SEAT
        values (:func:`seat_value`); none computed if None.

    Returns
    -------
    SeatTransmissibility
        Curves ``"<body>: floor to pan"`` and ``"<body>: floor to head"`` per body
        (modulus, unwrapped phase in degrees, peaks), and the SEAT values;
        ``format_table`` and ``plot_transmissibility`` of
        :mod:`bodyvib.frequency.compare` print and draw it.

    Raises
    ------
    BodyvibError
        A bad range, an unknown or invalid seat, body or car.

    Examples
    --------
    >>> r = seat_transmissibility("suspension", ["reduced-paper"], points=400)
    >>> p = r.models["reduced-paper: floor to pan"].peaks[0]
    >>> round(p.frequency_hz, 2), round(p.modulus, 2)
    (1.41, 2.24)
    """
    if not (0 < f_min < f_max < np.inf) or points < 10:
        raise BodyvibError(
            f"frequency range must satisfy 0 < fmin < fmax < inf with at least 10 points; "
            f"got fmin={f_min}, fmax={f_max}, points={points}"
        )
    seat = load_seat(seat) if isinstance(seat, str) else seat
    pan = check_seat(seat)
    occupants = [load_model(b) if isinstance(b, str) else b for b in bodies]
    seated = None
    if car is not None:
        seated = mount_seat(load_car(car) if isinstance(car, str) else car, seat)
    f = np.geomspace(f_min, f_max, points)
    curves, values = {}, {}
    for occupant in occupants:
        system = mount(seat, occupant, at=pan, prefix="body.")
        for where, signal in (("pan", f"{pan}.x"), ("head", f"body.{occupant.point('head')}.x")):
            T = frequency_response(system, f, signal)
            mod = np.abs(T)
            curves[f"{occupant.name}: floor to {where}"] = ModelTransmissibility(
                modulus=mod,
                phase_deg=np.degrees(np.unwrap(np.angle(T))),
                peaks=tuple(find_peaks(f, mod)),
            )
        if seated is not None:
            values[occupant.name] = seat_value(seated, occupant)
    return SeatTransmissibility(
        frequency_hz=f,
        models=curves,
        seat=seat.name,
        car=seated.name.rpartition(SEAT_SEPARATOR)[0] if seated is not None else "",
        seat_value_percent=values,
    )
