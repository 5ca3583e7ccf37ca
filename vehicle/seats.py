"""The seat as a part: seat models between a car's floor and the occupant.

A *seat* is a parameter file like a car or a body (:mod:`bodyvib.runtime.modelfile`)
whose base is ``floor``: the point of the car it stands on. Its mass with role
``seat`` (the seat pan) carries the occupant and takes the occupant's seat force as a
force input. Two seats ship in ``vehicle/data/seats/``:

``cushion``
    A conventional car seat: the pan on a foam cushion (spring parallel damper) rigid
    on the floor; it resonates near 4 Hz with an occupant on it.
``suspension``
    A suspension seat: a frame on a suspension spring and damper on the floor, tuned to
    1.6 Hz with its occupant, with the same cushion and pan on top.

:func:`mount_seat` puts a seat on a car's seat point and returns one car network: the
seat's points, elements and parameters are renamed with the prefix ``seat_`` and the
combined car's ``seat`` role is the seat pan, so the FMUs, the co-simulation and the
monolithic reference run it as any car. By name, ``"CAR+SEAT"`` is that car
(:func:`~bodyvib.vehicle.quarter_car.load_car` reads it; :func:`car_with_seat` writes it),
so every command that takes a car takes a car with a seat. The seat's transmissibility and
SEAT value are in :mod:`bodyvib.vehicle.seat_response`.
"""

import os
from dataclasses import replace
from typing import Tuple

from bodyvib.models import load_network
from bodyvib.runtime.contract import seat_point
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.network import Network, mount

__all__ = [
    "SEAT_DIR",
    "SEAT_PREFIX",
    "SEAT_SEPARATOR",
    "available_seats",
    "load_seat",
    "check_seat",
    "mount_seat",
    "car_with_seat",
    "split_car_name",
]

#: Folder of the shipped seat parameter files.
SEAT_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "seats")

#: Prefix of a mounted seat's point, element and parameter names in the combined car.
SEAT_PREFIX = "seat_"

#: Separator of a car name and a seat name in the name of a car with a seat.
SEAT_SEPARATOR = "+"

#: The base point of a seat model: the car point it stands on.
FLOOR = "floor"

#: Quantities of a point signal, for the descriptions of the combined car's outputs.
_QUANTITY = {
    "x": "Vertical displacement",
    "v": "Vertical velocity",
    "a": "Absolute vertical acceleration",
}


def available_seats() -> list:
    """Names of the shipped seats.

    Returns
    -------
    list of str
        Sorted file stems of :data:`SEAT_DIR`.

    Examples
    --------
    >>> available_seats()
    ['cushion', 'suspension']
    """
    return sorted(f[:-5] for f in os.listdir(SEAT_DIR) if f.endswith(".json"))


def check_seat(seat: Network) -> str:
    """Refuse a network that cannot be a seat; return its pan (the point with role ``seat``).

    Parameters
    ----------
    seat : Network
        A seat model.

    Returns
    -------
    str
        The point the occupant sits on.

    Raises
    ------
    BodyvibError
        A base other than one ``floor`` point, or no ``seat`` role naming a mass in
        ``force_inputs``.

    Examples
    --------
    >>> check_seat(load_seat("suspension"))
    'pan'
    """
    if seat.base != FLOOR or seat.extra_bases:
        raise BodyvibError(
            f"seat model '{seat.name}' has no floor point: its base must be '{FLOOR}' "
            f"(the car point it stands on), not {', '.join(repr(b) for b in seat.bases)}"
        )
    return seat_point(seat, "seat model")


def load_seat(name_or_path: str) -> Network:
    """Load a seat model by shipped name or parameter-file path.

    Parameters
    ----------
    name_or_path : str
        ``"cushion"``, ``"suspension"`` or a JSON parameter file.

    Returns
    -------
    Network
        Base ``floor``; a mass with role ``seat`` that takes a force input.

    Raises
    ------
    BodyvibError
        Unknown name, invalid file, or what :func:`check_seat` refuses.

    Examples
    --------
    >>> seat = load_seat("suspension")
    >>> seat.parameters["ks"], seat.parameters["cs"]
    (9400.0, 561.0)
    """
    seat = load_network(name_or_path, SEAT_DIR, "seat model")
    check_seat(seat)
    return seat


def _floor(car: Network, seat: Network) -> str:
    """The car's seat point, refusing a car without one or with a seat already."""
    if FLOOR in car.roles:
        raise BodyvibError(
            f"vehicle model '{car.name}' already has a seat (its role '{FLOOR}' names the "
            f"point its seat stands on): mount seat '{seat.name}' on a car without one, "
            "e.g. quarter-car or half-car"
        )
    try:
        return seat_point(car)
    except BodyvibError:
        raise BodyvibError(
            f"vehicle model '{car.name}' has no seat point to mount seat '{seat.name}' on: "
            "it needs a 'seat' role naming a mass or body point listed in force_inputs"
        ) from None


def _check_names(car: Network, seat: Network) -> None:
    """Refuse a seat whose prefixed names a car already uses."""
    ours = {
        "parameter": (set(car.parameters), {SEAT_PREFIX + p for p in seat.parameters}),
        "point": (
            set(car.masses) | set(car.node_names) | set(car.body_points),
            {SEAT_PREFIX + p for p in set(seat.masses) | set(seat.node_names)},
        ),
        "element": (
            {el.name for el in car.elements},
            {SEAT_PREFIX + el.name for el in seat.elements},
        ),
        "FMU output": (
            {o["name"] for o in car.fmu_outputs},
            {SEAT_PREFIX + o["name"] for o in seat.fmu_outputs} | {"floor_acceleration"},
        ),
    }
    for what, (have, new) in ours.items():
        both = sorted(have & new)
        if both:
            raise BodyvibError(
                f"vehicle model '{car.name}' already has the {what} name(s) "
                f"{', '.join(both)} that seat '{seat.name}' brings: rename them in the car file"
            )


def _outputs(car: Network, seat: Network, floor: str) -> tuple:
    """The combined car's FMU outputs: the car's (seat-role signals now at the pan), the
    floor's acceleration and the seat's own, renamed."""
    out = []
    for o in car.fmu_outputs:
        point, _, q = o["signal"].rpartition(".")
        if point == "seat" and q in _QUANTITY:
            o = dict(o, description=f"{_QUANTITY[q]} of the seat pan (seat {seat.name})")
        elif point == "seat" and q in ("ax", "ay"):  # a seat moves only up and down on
            o = dict(o, signal=f"{FLOOR}.{q}")  # its floor: fore-aft and sideways, the floor's
        out.append(dict(o))
    out.append(
        {
            "name": "floor_acceleration",
            "signal": f"{FLOOR}.a",  # the role: a car point may be named 'seat'
            "unit": "m/s2",
            "description": f"Absolute vertical acceleration of the car floor under the seat "
            f"({car.name} point {floor})",
        }
    )
    for o in seat.fmu_outputs:
        point, _, q = o["signal"].rpartition(".")
        point = seat.roles.get(point, point)
        out.append(dict(o, name=SEAT_PREFIX + o["name"], signal=f"{SEAT_PREFIX}{point}.{q}"))
    return tuple(out)


def mount_seat(car: Network, seat: Network) -> Network:
    """Put a seat on a car's seat point: one car network with the seat in it.

    The seat's ``floor`` becomes the car's seat point; the seat's points, elements,
    parameters and FMU outputs are renamed with :data:`SEAT_PREFIX`. The result's
    ``seat`` role is the seat pan, which takes the occupant's seat force, and its role
    ``floor`` names the car point under the seat (a car with that role has a seat and
    takes no second one). Its FMU outputs are the car's (those of the ``seat`` role now
    describe the pan), ``floor_acceleration`` and the seat's own.

    Parameters
    ----------
    car : Network
        A vehicle model without a seat (:func:`~bodyvib.vehicle.quarter_car.load_car`).
    seat : Network
        A seat model (:func:`load_seat`).

    Returns
    -------
    Network
        Named ``"<car>+<seat>"``, with a description and provenance of both parts.

    Raises
    ------
    BodyvibError
        A seat without a floor point or a pan (:func:`check_seat`), a car without a seat
        point, a car that already has a seat, or names the seat brings that the car uses.

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> car = mount_seat(load_car("quarter-car"), load_seat("suspension"))
    >>> car.name, car.roles["seat"], car.roles["floor"]
    ('quarter-car+suspension', 'seat_pan', 'sprung')
    >>> round(car.total_mass(), 1)
    367.0
    """
    pan = check_seat(seat)
    floor = _floor(car, seat)
    _check_names(car, seat)
    both = mount(car, seat, at=floor, prefix=SEAT_PREFIX)
    roles = dict(car.roles)
    roles.update({SEAT_PREFIX + r: SEAT_PREFIX + p for r, p in seat.roles.items() if r != "seat"})
    roles.update({"seat": SEAT_PREFIX + pan, FLOOR: floor})
    return replace(
        both,
        name=f"{car.name}{SEAT_SEPARATOR}{seat.name}",
        description=f"{car.description} On its seat point '{floor}' stands the seat "
        f"'{seat.name}' (names prefixed '{SEAT_PREFIX}'): {seat.description}",
        provenance={
            "source": f"Car: {car.name}; seat: {seat.name}; each part's provenance below.",
            "car": dict(car.provenance),
            "seat": dict(seat.provenance),
        },
        force_inputs=both.force_inputs + (SEAT_PREFIX + pan,),
        roles=roles,
        fmu_outputs=_outputs(car, seat, floor),
        # the occupant's weight, for the tire's preload, rests on the pan now
        static_loads={
            **both.static_loads,
            **({SEAT_PREFIX + pan: car.static_loads[floor]} if floor in car.static_loads else {}),
        },
    )


def car_with_seat(car: str, seat: str) -> str:
    """The name of a car with a seat, as every command that takes a car name takes it.

    Parameters
    ----------
    car : str
        Shipped vehicle name or parameter file.
    seat : str
        Shipped seat name or parameter file.

    Returns
    -------
    str
        ``"<car>+<seat>"``.

    Raises
    ------
    BodyvibError
        A name that contains the separator ``+`` and is not a file.

    Examples
    --------
    >>> car_with_seat("half-car", "suspension")
    'half-car+suspension'
    """
    for what, s in (("car", car), ("seat", seat)):
        if SEAT_SEPARATOR in os.path.basename(s) and not os.path.isfile(s):
            raise BodyvibError(
                f"{what} '{s}': a name with '{SEAT_SEPARATOR}' already carries a seat "
                f"(CAR{SEAT_SEPARATOR}SEAT); give the car and the seat once each"
            )
    return f"{car}{SEAT_SEPARATOR}{seat}"


def split_car_name(name: str) -> Tuple[str, str]:
    """Split ``"CAR+SEAT"`` into the car and the seat; ``(name, "")`` for a car alone.

    An existing file is a car alone whatever its name; otherwise the seat is what
    follows the last ``+``.

    Parameters
    ----------
    name : str
        A car name, a parameter file, or ``"CAR+SEAT"``.

    Returns
    -------
    car, seat : str

    Examples
    --------
    >>> split_car_name("quarter-car+suspension")
    ('quarter-car', 'suspension')
    >>> split_car_name("half-car")
    ('half-car', '')
    """
    if os.path.isfile(name) or SEAT_SEPARATOR not in name:
        return name, ""
    car, _, seat = name.rpartition(SEAT_SEPARATOR)
    if not car or not seat:
        raise BodyvibError(
            f"vehicle model '{name}': give a car and a seat around '{SEAT_SEPARATOR}', "
            "e.g. quarter-car+suspension"
        )
    return car, seat
