"""The quarter-car model: a network driven by the road, loaded by the occupant.

The car is a :class:`bodyvib.runtime.network.Network` read from a parameter file
(``vehicle/data/quarter-car.json`` by default): sprung mass on the suspension
on the unsprung mass on the tire, base ``road``. Its inputs are
``road_displacement`` [m], ``road_velocity`` [m/s] and ``sprung.force`` [N,
positive up] -- the negative of the occupant's seat force, which is positive
in compression. The occupant sits on the point with role ``seat``.
"""

import os

from bodyvib.models import load_network
from bodyvib.runtime.contract import seat_point
from bodyvib.runtime.network import Network, mount

__all__ = ["CAR_DIR", "CAR_FMU_OUTPUTS", "load_car", "seated_system"]

#: Folder of the shipped vehicle parameter files.
CAR_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")

#: Car FMU outputs beyond the contract's seat motion that the co-simulation
#: master records (``seat_acceleration`` is ``sprung_acceleration``). The shipped
#: cars declare them, in this order, in their parameter files' ``fmu_outputs``.
CAR_FMU_OUTPUTS = ("sprung_acceleration", "suspension_deflection", "tire_force")


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
    car = load_network(name_or_path, CAR_DIR, "vehicle model")
    seat_point(car)  # refuses a car without a seat for the occupant
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
