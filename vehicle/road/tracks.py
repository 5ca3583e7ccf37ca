"""The road under each wheel of a car with left and right wheels: two tracks of one road.

A full car's left wheels run on a road's left track and its right wheels on its right
track, ``track_width`` apart. An ISO 8608 class gives two tracks correlated as an
isotropic surface (:func:`bodyvib.vehicle.road.synthetic.two_track_road`; the left track is
the one-track road of the same class and seed, so a full car's left wheels see what a
half car's see); every other synthetic road (a bump, a sweep, a speed hump) lies across
the whole lane, identical on both tracks, and so does a road file for now (one profile).
Each track is faded in from level as :func:`bodyvib.vehicle.road.driven.driven_road`
fades a road in.
"""

from typing import Dict, Sequence, Tuple

import numpy as np

from bodyvib.runtime.errors import BodyvibError

from .base import Road
from .driven import RunSettings, is_road_file, wheel_inputs
from .synthetic import ISO8608_CLASSES, TaperedRoad, two_track_road

__all__ = ["wheel_roads", "roads_input"]


def wheel_roads(
    settings: RunSettings, road: Road, sides: Sequence[int], track_width: float = 0.0
) -> Tuple[Road, ...]:
    """The road each wheel drives: ``road`` itself, or its left or right track.

    Parameters
    ----------
    settings : RunSettings
        The run's road, speed, duration and seed (those ``road`` was made from).
    road : Road
        The run's road as :func:`bodyvib.vehicle.road.driven.driven_road` made it: the
        left track, and the road of every wheel of a car without sides.
    sides : sequence of int
        Each wheel's side: 1 left, -1 right, 0 centre
        (:func:`bodyvib.vehicle.quarter_car.wheel_sides`).
    track_width : float
        Distance between the left and right tracks, m (a car with right wheels only).

    Returns
    -------
    tuple of Road
        A road per wheel; wheels on the same track share one object.

    Raises
    ------
    BodyvibError
        A car with right wheels and a track width that is not positive.

    Examples
    --------
    >>> from bodyvib.vehicle.road.driven import driven_road
    >>> s = RunSettings("C", 20.0, 5.0)
    >>> fl, fr, rl, rr = wheel_roads(s, driven_road(s), (1, -1, 1, -1), 1.5)
    >>> fl is rl, fr is rr, fl is fr
    (True, True, False)
    """
    if not any(side < 0 for side in sides):
        return tuple(road for _ in sides)
    if not track_width > 0:
        raise BodyvibError(f"track width must be a positive number of m, got {track_width!r}")
    spec = str(settings.road).strip()
    right = road
    if not is_road_file(spec) and len(spec) == 1 and spec.upper() in ISO8608_CLASSES:
        length = settings.speed * settings.duration + 1.0  # as make_road's
        # the left track is the one-track road ``road`` already is (same class, length
        # and seed): only the right one is made here
        _, far = two_track_road(spec.upper(), track_width, length, settings.seed)
        right = TaperedRoad(far, far.length, settings.road_options.taper_m)
    return tuple(right if side < 0 else road for side in sides)


def roads_input(
    roads: Sequence[Road], speed: float, t, behind: Sequence[float]
) -> Tuple[np.ndarray, np.ndarray]:
    """Road displacement and velocity under each wheel, each on its own road.

    :func:`bodyvib.vehicle.road.driven.wheel_inputs` per track: the wheels sharing a
    road object are evaluated together.

    Parameters
    ----------
    roads : sequence of Road
        A road per wheel (:func:`wheel_roads`).
    speed : float
        m/s.
    t : array_like
        Times, s.
    behind : sequence of float
        Each wheel's distance behind the first, m.

    Returns
    -------
    displacement, velocity : (n, wheels) ndarray
        m and m/s, a column per wheel.
    """
    groups: Dict[int, list] = {}
    for j, r in enumerate(roads):
        groups.setdefault(id(r), []).append(j)
    n = np.size(t)
    z, v = np.empty((n, len(roads))), np.empty((n, len(roads)))
    for cols in groups.values():
        zj, vj = wheel_inputs(roads[cols[0]], speed, t, [behind[j] for j in cols])
        z[:, cols], v[:, cols] = zj, vj
    return z, v
