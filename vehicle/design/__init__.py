"""Design with the occupant in the loop: random-road r.m.s. without simulation, optimization.

:mod:`~bodyvib.vehicle.design.stationary` computes the stationary r.m.s. of every
output of a linear car-plus-occupant model on an ISO 8608 road from a Lyapunov equation
(the Wk weighting appended as states), fast enough to evaluate thousands of designs;
:mod:`~bodyvib.vehicle.design.spec` reads and checks a design specification;
:mod:`~bodyvib.vehicle.design.optimize` searches it (the fit's GA or CMA-ES for one
objective, NSGA-II for a Pareto front) and verifies the chosen designs by time-domain
runs; :mod:`~bodyvib.vehicle.design.report` writes the front, its plot and the chosen
designs' car files.
"""

from .optimize import DesignPoint, DesignProblem, DesignResult, design, verify_design
from .spec import OBJECTIVES, DesignSpec, load_spec, parse_spec
from .stationary import (
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
    "OBJECTIVES",
    "DesignSpec",
    "parse_spec",
    "load_spec",
    "DesignProblem",
    "DesignPoint",
    "DesignResult",
    "design",
    "verify_design",
]
