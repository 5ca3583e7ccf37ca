"""Design with the occupant in the loop: random-road r.m.s. without simulation, optimization.

:mod:`~bodyvib.vehicle.design.random_response` computes the stationary r.m.s. of every
output of a linear car-plus-occupant model on an ISO 8608 road from a Lyapunov equation
(the Wk weighting appended as states), fast enough to evaluate thousands of designs.
"""

from .random_response import (
    GRAVITY,
    RandomResponse,
    random_response,
    road_velocity_intensity,
    static_wheel_load,
    stationary_outputs,
    unit_rms,
)

__all__ = [
    "GRAVITY",
    "RandomResponse",
    "random_response",
    "road_velocity_intensity",
    "stationary_outputs",
    "static_wheel_load",
    "unit_rms",
]
