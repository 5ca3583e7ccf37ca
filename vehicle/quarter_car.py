"""The car models: networks driven by the road, loaded by the occupant.

A car is a :class:`bodyvib.runtime.network.Network` read from a parameter file
(``vehicle/data/quarter-car.json`` by default): sprung mass on the suspension
on the unsprung mass on the tire, base ``road``. The half car
(``vehicle/data/half-car.json``) is a rigid body that bounces and pitches on a
front and a rear axle, driven at ``road_front`` and ``road_rear``; the rear
wheel meets the road :func:`wheel_offsets` metres after the front. Its inputs are
``road_displacement`` [m], ``road_velocity`` [m/s] and ``sprung.force`` [N,
positive up] -- the negative of the occupant's seat force, which is positive
in compression. The occupant sits on the point with role ``seat``. The full car
(``vehicle/data/full-car.json``) also rolls, on four corners: its left wheels run
on a road's left track, its right wheels on the right (:func:`wheel_sides`).
"""

import os
from typing import Dict, Tuple

import numpy as np

from bodyvib.models import load_network
from bodyvib.runtime.contract import seat_point
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.network import Network, linearized, mount

from .seats import load_seat, mount_seat, split_car_name

__all__ = [
    "CAR_DIR",
    "CAR_FMU_OUTPUTS",
    "load_car",
    "seated_system",
    "wheel_offsets",
    "track_width",
    "wheel_sides",
]

#: Folder of the shipped vehicle parameter files.
CAR_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")

#: Car FMU outputs beyond the contract's seat motion that the co-simulation
#: master records (``seat_acceleration`` is ``sprung_acceleration``). The shipped
#: cars declare them, in this order, in their parameter files' ``fmu_outputs``.
CAR_FMU_OUTPUTS = ("sprung_acceleration", "suspension_deflection", "tire_force")


def load_car(name_or_path: str = "quarter-car", linear: bool = False) -> Network:
    """Load a vehicle model by shipped name or parameter-file path, with a seat or without.

    Parameters
    ----------
    name_or_path : str
        ``"quarter-car"`` (default), ``"half-car"``, another shipped name or a JSON
        parameter file; followed by ``+`` and a seat (a shipped seat name or a seat
        file, :mod:`bodyvib.vehicle.seats`), that car with the seat on its seat point.
    linear : bool
        The car linearized about static equilibrium
        (:func:`bodyvib.runtime.network.linearized`: a tire that never leaves the road,
        no stops): the linear car of earlier releases.

    Returns
    -------
    Network
        Base ``road``; a mass with role ``seat`` that takes a force input.

    Raises
    ------
    BodyvibError
        Unknown name, invalid file, a model without a ``seat`` role, or what
        :func:`~bodyvib.vehicle.seats.mount_seat` refuses.

    Examples
    --------
    >>> load_car("quarter-car+cushion").roles["seat"]
    'seat_pan'
    """
    car_name, seat_name = split_car_name(os.fspath(name_or_path))
    if seat_name:
        car = mount_seat(load_car(car_name), load_seat(seat_name))
    else:
        car = load_network(name_or_path, CAR_DIR, "vehicle model")
        seat_point(car)  # refuses a car without a seat for the occupant
    return linearized(car) if linear else car


def seated_system(car: Network, body: Network) -> Network:
    """The monolithic car-plus-occupant network (the co-simulation's reference).

    Parameters
    ----------
    car : Network
        From :func:`load_car`.
    body : Network
        A body model (base ``seat``).

    Returns
    -------
    Network
        Driven by the road; the body's points are prefixed ``body.``.
    """
    return mount(car, body, at=car.roles["seat"], prefix="body.")


def wheel_offsets(car: Network) -> Tuple[float, ...]:
    """Distance of each road point (base) of a car behind the first, m.

    A base's longitudinal position is that of the rigid-body point its tire and
    suspension lead to (the chain of elements from the base through masses and nodes
    to a body point); a car without rigid bodies has one base at 0.

    Parameters
    ----------
    car : Network
        A vehicle model (:func:`load_car`).

    Returns
    -------
    tuple of float
        ``0`` for the first base, then the distance of every other base behind it
        (the half car's rear road: the wheelbase ``lf + lr``).

    Raises
    ------
    BodyvibError
        A car with several bases whose base does not lead to exactly one body point,
        or a base ahead of the first.

    Examples
    --------
    >>> wheel_offsets(load_car())
    (0.0,)
    >>> wheel_offsets(load_car("half-car"))
    (0.0, 2.8)
    """
    if not car.extra_bases:
        return (0.0,)
    where = [car.body_points[p][1] for p in _axle_points(car)]
    offsets = tuple(where[0] - x for x in where)
    if min(offsets) < 0:
        raise BodyvibError(
            f"vehicle model '{car.name}': its first road point '{car.base}' must be the "
            "front axle's (list the bases front to rear)"
        )
    return offsets


def wheel_sides(car: Network) -> Tuple[int, ...]:
    """The road track each road point (base) of a car runs on: 1 left, -1 right, 0 centre.

    A base's side is that of the rigid-body point its tire and suspension lead to
    (``y`` > 0: left); a car without rigid bodies has one base on the centre line.

    Parameters
    ----------
    car : Network
        As :func:`wheel_offsets`.

    Returns
    -------
    tuple of int
        A side per base, in the order of its bases.

    Raises
    ------
    BodyvibError
        As :func:`wheel_offsets`: a base that does not lead to one body point, or one
        ahead of the first.

    Examples
    --------
    >>> wheel_sides(load_car("half-car")), wheel_sides(load_car("full-car"))
    ((0, 0), (1, -1, 1, -1))
    """
    if not car.extra_bases:
        return (0,)
    places = car.body_point_places
    return tuple(int(np.sign(places[p][2])) for p in _axle_points(car))


def track_width(car: Network) -> float:
    """Distance between a car's left and right wheels (the front pair's), m; 0 without sides.

    Parameters
    ----------
    car : Network
        As :func:`wheel_sides`; one without left and right wheels has no track width.

    Returns
    -------
    float
        ``y`` of the first left wheel's body point minus ``y`` of the first right one's.

    Examples
    --------
    >>> track_width(load_car("full-car")), track_width(load_car("half-car"))
    (1.5, 0.0)
    """
    sides = wheel_sides(car)
    if 1 not in sides or -1 not in sides:
        return 0.0
    places, points = car.body_point_places, _axle_points(car)
    return places[points[sides.index(1)]][2] - places[points[sides.index(-1)]][2]


def _axle_points(car: Network) -> Tuple[str, ...]:
    """The rigid-body point each base's tire and suspension lead to, base by base."""
    points = car.body_points
    links: Dict[str, set] = {}
    for el in car.elements:
        chain = [el.a, el.b] if el.internal_node is None else [el.a, el.internal_node, el.b]
        for p, q in zip(chain, chain[1:]):
            links.setdefault(p, set()).add(q)
            links.setdefault(q, set()).add(p)
    where = []
    for base in car.bases:
        seen, todo, found = {base}, [base], set()
        while todo:
            for q in links.get(todo.pop(), ()):
                if q in seen or q in car.bases:
                    continue
                seen.add(q)
                if q in points:
                    found.add(q)
                else:
                    todo.append(q)
        if len(found) != 1:
            raise BodyvibError(
                f"vehicle model '{car.name}': road point '{base}' leads to "
                f"{len(found)} body points ({', '.join(sorted(found)) or 'none'}); each road "
                "point must carry one axle, its tire and suspension ending at one body point"
            )
        where.append(found.pop())
    return tuple(where)
