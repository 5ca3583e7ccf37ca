"""The interface every road implements: a height and a slope over the distance.

A road is a vertical profile ``z(x)`` [m] over the distance ``x`` [m] travelled by a
wheel. Synthetic roads (:mod:`~bodyvib.vehicle.road.synthetic`), measured profiles
(:mod:`~bodyvib.vehicle.road.profile`, through their tire contact,
:mod:`~bodyvib.vehicle.road.contact`) and the faded-in road a run drives all derive
from :class:`Road`; a car at speed ``V`` sees ``z(V t)`` and the road velocity
``V dz/dx(V t)``.
"""

import math
from typing import Sequence

import numpy as np

__all__ = ["Road", "RoadWarning"]


class RoadWarning(UserWarning):
    """A fact about a road a run should know but that does not stop it (a band the profile
    does not carry at the run's speed, a step a point contact passes on as it is); the
    command line prints it as one line.

    ``parameters`` lists the settings the message names, as
    :class:`~bodyvib.runtime.errors.BodyvibError` does, for the command line to show as flags.
    """

    def __init__(self, message: str = "", *, parameters: Sequence[str] = ()):
        super().__init__(message)
        self.parameters = tuple(parameters)


class Road:
    """A road profile: ``displacement(x)`` [m] and ``slope(x)`` [-] over distance x [m].

    Subclasses set ``length`` (m; ``math.inf`` for an unbounded road) and ``name``, and
    implement :meth:`displacement` and :meth:`slope` (the exact derivative of the same
    profile, which the exact discretization of a car takes as its in-step slope).

    Examples
    --------
    >>> class Ramp(Road):
    ...     name = "ramp"
    ...     def displacement(self, x):
    ...         return 0.01 * np.asarray(x, dtype=float)
    ...     def slope(self, x):
    ...         return np.full_like(np.asarray(x, dtype=float), 0.01)
    >>> float(Ramp().displacement(2.0)), Ramp().describe()
    (0.02, {'name': 'ramp'})
    """

    length: float = math.inf
    name: str = "road"

    def displacement(self, x) -> np.ndarray:  # pragma: no cover - interface
        """Profile height at distances ``x`` (m), in m."""
        raise NotImplementedError

    def slope(self, x) -> np.ndarray:  # pragma: no cover - interface
        """Profile slope ``dz/dx`` at distances ``x`` (m), dimensionless."""
        raise NotImplementedError

    def profile(self, x):
        """Height and slope at distances ``x``: ``(displacement(x), slope(x))``.

        A road whose two share work (a faded-in road evaluates its inner road's
        height for both) computes that work once here; the values are the same.

        Parameters
        ----------
        x : array_like
            Distances, m.

        Returns
        -------
        displacement : ndarray
            m.
        slope : ndarray
            Dimensionless.
        """
        return self.displacement(x), self.slope(x)

    def describe(self) -> dict:
        """Parameters of the road for reports (JSON-serializable)."""
        return {"name": self.name}
