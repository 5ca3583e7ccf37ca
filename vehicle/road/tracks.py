"""The road under each wheel of a car with left and right wheels: two tracks of one road.

A full car's left wheels run on a road's left track and its right wheels on its right
track, ``track_width`` apart. An ISO 8608 class gives two tracks correlated as an
isotropic surface (:func:`bodyvib.vehicle.road.synthetic.two_track_road`; the left track is
the one-track road of the same class and seed, so a full car's left wheels see what a
half car's see); every other synthetic road (a bump, a sweep, a speed hump) lies across
the whole lane, identical on both tracks. A road file gives each track its own profile:
an OpenCRG surface is read at plus and minus half the track width about the lateral
offset ``track_m``, a profile with ``elevation_left`` and ``elevation_right`` columns
gives each track its column, a one-track profile drives both tracks alike.
Each track is faded in from level as :func:`bodyvib.vehicle.road.driven.driven_road`
fades a road in.
"""

import warnings
from typing import Callable, Dict, Sequence, Tuple

import numpy as np

from bodyvib.runtime.errors import BodyvibError

from .base import Road, RoadWarning
from .driven import RunSettings, file_road, is_road_file, wheel_inputs
from .synthetic import ISO8608_CLASSES, TaperedRoad, two_track_road

__all__ = ["wheel_roads", "roads_input", "two_tracks"]


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
        road of every wheel of a car without sides, and a synthetic road's left track.
    sides : sequence of int
        Each wheel's side: 1 left, -1 right, 0 centre
        (:func:`bodyvib.vehicle.quarter_car.wheel_sides`).
    track_width : float
        Distance between the left and right tracks, m (a car with right wheels only).

    Returns
    -------
    tuple of Road
        A road per wheel (:func:`two_tracks`); wheels on the same track share one object.

    Raises
    ------
    BodyvibError
        A car with right wheels and a track width that is not positive; what
        :func:`bodyvib.vehicle.road.driven.file_road` refuses of either track of a file.

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

    def file_track(side):
        # the run's road (``road``, read from the same file) said already what the file's
        # length and repetition mean for the run: each track does not say it again
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RoadWarning)
            return file_road(
                settings.road,
                settings.road_options,
                settings.speed,
                settings.duration,
                settings.step,
                side=side,
                track_width=track_width,
            )

    left, right = two_tracks(
        settings.road,
        road,
        track_width,
        length=settings.speed * settings.duration + 1.0,  # as make_road's
        seed=settings.seed,
        taper=settings.road_options.taper_m,
        file_track=file_track,
    )
    return tuple(right if side < 0 else left for side in sides)


def two_tracks(
    spec: str,
    road: Road,
    track_width: float,
    *,
    length: float,
    seed: int,
    taper: float,
    file_track: Callable[[int], Road],
) -> Tuple[Road, Road]:
    """The left and right tracks of a road, ``track_width`` apart.

    * an ISO 8608 class: ``road`` (the one-track road of the class and seed) on the left,
      the correlated second track (:func:`bodyvib.vehicle.road.synthetic.two_track_road`)
      on the right, faded in as ``road`` is;
    * a road file: ``file_track(1)`` and ``file_track(-1)``, each track read from the file
      (an OpenCRG surface at the lateral offset plus or minus half the track width, a
      two-track profile's own column, a one-track profile twice);
    * any other synthetic road (a bump, a sweep) lies across the lane: ``road`` on both.

    Parameters
    ----------
    spec : str
        The road as given (class letter, bump, sweep or file).
    road : Road
        The one-track road made from ``spec``, faded in.
    track_width : float
        m, positive.
    length, seed, taper
        A random road's length (m) and seed and the fade-in length (m) of ``road``.
    file_track : callable
        A road file's track on a side (1 left, -1 right), faded in as ``road``.

    Returns
    -------
    (Road, Road)
        Left and right; one object twice when the tracks are the same.

    Raises
    ------
    BodyvibError
        A track width that is not a positive number.
    """
    if not (isinstance(track_width, (int, float)) and track_width > 0):
        raise BodyvibError(f"track width must be a positive number of m, got {track_width!r}")
    spec = str(spec).strip()
    if is_road_file(spec):
        return file_track(1), file_track(-1)
    if len(spec) == 1 and spec.upper() in ISO8608_CLASSES:
        # the left track is the one-track road ``road`` already is (same class, length
        # and seed): only the right one is made here
        _, far = two_track_road(spec.upper(), track_width, length, seed)
        return road, TaperedRoad(far, far.length, taper)
    return road, road


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
