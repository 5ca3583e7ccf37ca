"""vehicle: the quarter-car model, road profiles and the co-simulation with a body FMU.

The vehicle models are parameter files like the body models (see
:mod:`bodyvib.models`); :func:`vehicle.quarter_car.load_car` loads them.
"""
