"""The quarter-car model: a network driven by the road, loaded by the occupant.

The car is a :class:`bodyvib.runtime.network.Network` read from a parameter file
(``vehicle/data/quarter-car.json`` by default): sprung mass on the suspension
on the unsprung mass on the tire, base ``road``. Its inputs are
``road_displacement`` [m], ``road_velocity`` [m/s] and ``sprung.force`` [N,
positive up] -- the negative of the occupant's seat force, which is positive
in compression. The occupant sits on the point with role ``seat``.
"""

import os

from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.modelfile import network_from_file
from bodyvib.runtime.network import Network, mount

__all__ = ["CAR_DIR", "load_car", "seated_system"]

#: Folder of the shipped vehicle parameter files.
CAR_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")


def load_car(name_or_path: str = "quarter-car") -> Network:
    """Load a vehicle model by shipped name or parameter-file path.

    Parameters
    ----------
    name_or_path : str
        ``"quarter-car"`` (default) or a JSON parameter file.

    Returns
    -------
    Network
        Base ``road``; a mass with role ``seat`` that takes a force input.

    Raises
    ------
    BodyvibError
        Unknown name, invalid file, or a model without a ``seat`` role.
    """
    if os.path.isfile(name_or_path):
        car = network_from_file(name_or_path)
    else:
        path = os.path.join(CAR_DIR, name_or_path + ".json")
        if not os.path.isfile(path):
            shipped = sorted(f[:-5] for f in os.listdir(CAR_DIR) if f.endswith(".json"))
            raise BodyvibError(
                f"unknown vehicle model '{name_or_path}'; give a file or one of: "
                + ", ".join(shipped)
            )
        car = network_from_file(path)
    seat = car.roles.get("seat")
    if seat is None or seat not in car.force_inputs:
        raise BodyvibError(
            f"vehicle model '{car.name}' needs a 'seat' role naming a mass listed in "
            "force_inputs (the occupant's seat force acts there)"
        )
    return car


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
