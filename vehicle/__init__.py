"""vehicle: the quarter-car model, road profiles and the co-simulation with a body FMU.

The vehicle models are parameter files like the body models (see
:mod:`bodyvib.models`); :func:`bodyvib.vehicle.quarter_car.load_car` loads them.
"""

__all__ = []  # type: list[str]
