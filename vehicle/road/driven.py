"""The road a run drives: a synthetic road or a road file, faded in from level.

Every run (``bodyvib cosim``, ``check``, every ``sweep`` engine) and ``Road.fmu``
take their road from here, so they all start the same way: the car starts at rest
on level road, and the road fades in over its first ``taper_m`` metres (5 m by
default, ``--road-taper``) and out over its last
(:class:`~bodyvib.vehicle.road.synthetic.TaperedRoad`): no initial height, no initial slope,
whatever the road, and the car's own state untouched. The alternative, starting the
car in static equilibrium at the road's first height, would need every car FMU to
take an initial road height and every host to set it, which ``Road.fmu`` in an SSP
cannot do.

A road file is driven through a tire contact (``--road-contact``, by default the
tandem-cam effective road when the profile is sampled finer than the tire's footprint,
:mod:`~bodyvib.vehicle.road.contact`). A repeated file (``--road-repeat``, or any file
shorter than the run, with a warning) fades in once and then repeats without a step in
height or slope; a file shorter than four fades is faded over a quarter of its length at
each end, with a warning saying so.
"""

import math
import os
import warnings
from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np

from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.renames import renamed_fields, warn_renamed

from ..records import Record
from .base import Road, RoadWarning
from .bumps import check_bump_start, is_bump_spec, parse_bump
from .measured import PROFILE_EXTENSIONS
from .synthetic import ISO8608_CLASSES, TaperedRoad, make_road, road_input

__all__ = [
    "DEFAULT_TAPER_M",
    "RENAMED_ROAD_OPTIONS",
    "RoadOptions",
    "renamed_road_options",
    "RunSettings",
    "is_road_file",
    "driven_road",
    "file_road",
    "file_options_refused",
    "road_label",
    "road_handling",
    "wheel_inputs",
    "road_columns",
]

#: Default fade-in (and fade-out) length of every road, m.
DEFAULT_TAPER_M = 5.0


@dataclass(frozen=True)
class RoadOptions(Record):
    """How a road is driven (the ``--road-*`` options).

    Attributes
    ----------
    taper_m : float
        Fade-in and fade-out length, m (0: none).
    track_m : float
        OpenCRG: lateral offset of the wheel from the reference line, m.
    units : str or None
        CSV/ERD: ``"DIST,ELEV"`` units when the file does not name them.
    envelope : bool
        Measured roads: the IRI standard's 250 mm moving average.
    repeat : bool
        Measured roads: drive the profile periodically. A run longer than the profile
        repeats it in any case (with a warning).
    contact : str
        Measured roads: the tire contact, ``auto``, ``tandem-cam``, ``mfswift-205-60R15`` or ``point``
        (:data:`bodyvib.vehicle.road.contact.CONTACTS`).
    """

    taper_m: float = DEFAULT_TAPER_M
    track_m: float = 0.0
    units: Optional[str] = None
    envelope: bool = False
    repeat: bool = False
    contact: str = "auto"


#: Old names of road options (a sweep spec's ``road_options``, ``Road.fmu``'s road
#: options) -> the :class:`RoadOptions` field: accepted for one release, warned.
RENAMED_ROAD_OPTIONS = {"taper": "taper_m", "track": "track_m"}


def renamed_road_options(options: dict, owner: str) -> dict:
    """``options`` with the old road option names of :data:`RENAMED_ROAD_OPTIONS` renamed.

    Parameters
    ----------
    options : dict
        Road options by name (a sweep spec's ``road_options``, ``Road.fmu``'s options).
    owner : str
        What takes them, for the ``DeprecationWarning`` an old name gives.

    Returns
    -------
    dict
        A copy under the new names (``options`` itself when no old name is in it).

    Raises
    ------
    BodyvibError
        An old name given together with its new one.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as w:
    ...     warnings.simplefilter("always")
    ...     renamed_road_options({"taper": 2.0, "repeat": True}, "spec")
    {'repeat': True, 'taper_m': 2.0}
    >>> str(w[0].message)
    "spec: 'taper' is renamed 'taper_m'; the old name will be removed in the next release"
    """
    if RENAMED_ROAD_OPTIONS.keys().isdisjoint(options):
        return options
    out = dict(options)
    for old, new in RENAMED_ROAD_OPTIONS.items():
        if old in out:
            if new in out:
                raise BodyvibError(f"{owner}: {old!r} and its new name {new!r}: give {new!r}")
            warn_renamed(owner, old, new, stacklevel=4)
            out[new] = out.pop(old)
    return out


@renamed_fields(speed_m_s="speed", duration_s="duration", step_s="step")
@dataclass(frozen=True)
class RunSettings(Record):
    """What a run drives: the road, at which speed, for how long, at which step.

    One object for the settings every run shares (``bodyvib cosim`` and ``check``, a
    study, a sweep's case): :func:`driven_road` makes its road,
    :func:`bodyvib.vehicle.study.check_settings` checks it before any work,
    :func:`bodyvib.vehicle.study.run_study` runs it and keeps it as the study's settings.
    The defaults are those of ``bodyvib cosim``.

    Attributes
    ----------
    road : str
        ISO 8608 class ``A``-``H``, ``bump``, ``sweep`` or a road file, as given.
    speed, duration, step : float
        Vehicle speed (m/s), simulated time (s), communication step (s). The names
        ``speed_m_s``, ``duration_s`` and ``step_s`` still work for one release, with a
        ``DeprecationWarning``.
    seed : int
        Random-road seed.
    road_options : RoadOptions
        How the road is driven (the ``--road-*`` options).

    Examples
    --------
    >>> RunSettings(road="bump", speed=10.0).duration
    30.0
    """

    road: str = "C"
    speed: float = 20.0
    duration: float = 30.0
    step: float = 1e-3
    seed: int = 0
    road_options: RoadOptions = RoadOptions()

    @classmethod
    def from_attributes(cls, source, road_options: RoadOptions) -> "RunSettings":
        """The settings an object holds in attributes of the fields' names.

        Parameters
        ----------
        source : object
            Has ``road``, ``speed``, ``duration``, ``step`` and ``seed`` (a parsed
            command line, a sweep's case).
        road_options : RoadOptions

        Returns
        -------
        RunSettings

        Examples
        --------
        >>> from types import SimpleNamespace
        >>> s = SimpleNamespace(road="D", speed=15.0, duration=5.0, step=2e-3, seed=3)
        >>> RunSettings.from_attributes(s, RoadOptions()).seed
        3
        """
        return cls(
            **{k: getattr(source, k) for k in ("road", "speed", "duration", "step", "seed")},
            road_options=road_options,
        )


def is_road_file(spec) -> bool:
    """Whether a road spec names a file rather than a synthetic road.

    Parameters
    ----------
    spec : str or os.PathLike
        A road as ``--road`` or a sweep spec's ``road`` names it (surrounding spaces
        ignored).

    Returns
    -------
    bool
        True for a name with a road file's extension (``.crg``, ``.csv``, ``.txt``, ``.erd``), a
        path or an existing file; False for an ISO 8608 class letter, ``bump``,
        ``sweep`` or any other name (refused as an unknown road).

    Examples
    --------
    >>> is_road_file("C"), is_road_file("bump"), is_road_file("road.crg")
    (False, False, True)
    """
    s = str(spec).strip()
    if (len(s) == 1 and s.upper() in ISO8608_CLASSES) or s.lower() in ("bump", "sweep"):
        return False
    if is_bump_spec(s):
        return False
    return os.path.splitext(s)[1].lower() in PROFILE_EXTENSIONS or os.sep in s or os.path.isfile(s)


def road_label(spec) -> str:
    """The road as a table shows it: a class letter, ``bump``, ``sweep``, a bump shape with all
    its dimensions, or the file's absolute path.

    Examples
    --------
    >>> road_label("c"), road_label("Bump"), road_label("hump:l=3.7")
    ('C', 'bump', 'hump:h=0.075,l=3.7,at=10')
    """
    s = str(spec).strip()
    if is_road_file(s):
        return os.path.abspath(s)
    if is_bump_spec(s):
        return parse_bump(s).name
    return s.upper() if len(s) == 1 else s.lower()


def driven_road(settings: RunSettings) -> Road:
    """The road a run drives, faded in from level.

    Parameters
    ----------
    settings : RunSettings
        The road (ISO 8608 class ``A``-``H``, ``bump``, ``sweep``, a bump shape:
        :func:`bodyvib.vehicle.road.synthetic.make_road`; or a road file, ``.crg``, ``.csv``,
        ``.txt``, ``.erd``: :func:`bodyvib.vehicle.road.measured.load_profile`), the speed and
        duration it is driven at and for, the random-road seed, the communication step (a
        measured profile's spacing is checked against it) and the road options.

    Returns
    -------
    TaperedRoad
        The road faded in (and out) over ``options.taper_m``; a random road and a
        repeated profile repeat with their length.

    Raises
    ------
    BodyvibError
        Unknown road, bad settings, a file that cannot be driven (see
        :func:`bodyvib.vehicle.road.measured.load_profile` and
        :meth:`bodyvib.vehicle.road.profile.ProfileRoad.check_run`), a taper longer than
        half the road.

    Examples
    --------
    >>> r = driven_road(RunSettings(road="C", speed=20.0, duration=10.0))
    >>> float(r.displacement(0.0)), float(r.slope(0.0))
    (0.0, 0.0)
    """
    spec, speed, duration = settings.road, settings.speed, settings.duration
    opt = settings.road_options
    if is_road_file(spec):
        if not (isinstance(speed, (int, float)) and math.isfinite(speed) and speed > 0):
            raise BodyvibError(f"speed must be a positive number of m/s, got {speed!r}")
        return file_road(spec, opt, speed, duration, settings.step)
    if opt.track_m or opt.units or opt.envelope or opt.repeat or opt.contact != "auto":
        raise file_options_refused(spec)
    road = make_road(spec, speed, duration, seed=settings.seed)
    check_bump_start(road, opt.taper_m)
    return TaperedRoad(road, road.length, opt.taper_m)


def file_options_refused(spec) -> BodyvibError:
    """The error for a synthetic road given options that only a road file takes."""
    names = ("track_m", "units", "envelope", "repeat", "contact")
    quoted = [f"'{n}'" for n in names]
    return BodyvibError(
        f"{', '.join(quoted[:-1])} and {quoted[-1]} apply to road files; road '{spec}' is "
        "synthetic",
        parameters=names,
    )


def file_road(
    spec,
    options: RoadOptions,
    speed: float,
    duration=None,
    step=None,
    *,
    side: int = 0,
    track_width: float = 0.0,
) -> Road:
    """A road file as a run drives it: read, through its tire contact, faded in.

    Parameters
    ----------
    spec : str or os.PathLike
        The file (``.crg``, ``.csv``, ``.txt``, ``.erd``).
    options : RoadOptions
        Track, units, moving average, contact, repetition and fade.
    speed : float
        m/s (the profile's spacing is judged at it).
    duration : float, optional
        s; None: the profile's own length at ``speed`` (a table of it, ``Road.fmu``).
    step : float, optional
        Communication step, s.
    side, track_width : int, float
        1 the left, -1 the right track of a car whose tracks are ``track_width`` m apart
        (OpenCRG: the surface at ``options.track_m`` plus or minus ``track_width / 2``; a
        profile: its ``elevation_left`` or ``elevation_right``, or its one column), 0 the
        file's road (OpenCRG at ``options.track_m``, a two-track profile's left track).

    Returns
    -------
    TaperedRoad
        Repeated: faded in once over ``taper_m`` and then the profile again and again.
        Otherwise faded in and out over ``taper_m``, or over a quarter of the profile at
        each end when it is shorter than ``4 taper_m`` (with a :class:`~bodyvib.vehicle.road.base.RoadWarning`).

    Raises
    ------
    BodyvibError
        A file that cannot be read or driven (see
        :func:`bodyvib.vehicle.road.measured.load_profile`,
        :meth:`bodyvib.vehicle.road.profile.ProfileRoad.check_run`).

    Warns
    -----
    bodyvib.vehicle.road.base.RoadWarning
        A run longer than the profile (driven repeated), a slope steeper than 45 degrees
        under a point contact (named with where it is), a band the profile does not
        carry, a shortened fade.
    """
    from .measured import load_profile

    crg = str(spec).strip().lower().endswith(".crg")
    offset = side * track_width / 2 if crg else 0.0

    def load(periodic):
        return load_profile(
            str(spec).strip(),
            track_m=options.track_m + offset,
            side=side,
            units=options.units,
            envelope=options.envelope,
            contact=options.contact,
            periodic=periodic,
        )

    road = load(options.repeat)
    repeat = options.repeat
    if not repeat and duration is not None and speed * duration > road.length * (1 + 1e-12):
        # a scan shorter than the run is driven again and again (as a test track is), and
        # said so; the contact then envelops the profile across its join too
        warnings.warn(
            RoadWarning(
                f"road '{road.name}' is {road.length:.6g} m long and the {duration:g} s run "
                f"at {speed:g} m/s drives {speed * duration:.6g} m: it is driven repeated "
                f"(faded in once; duration={road.length / speed:.4g} drives it once)",
                parameters=("duration",),
            ),
            stacklevel=2,
        )
        repeat = True
        road = load(True)
    road.check_run(
        speed, road.length / speed if duration is None else duration, step, repeat=repeat
    )
    if road.contact is None:
        _warn_steep(road)
    taper = options.taper_m
    if repeat:
        return TaperedRoad(road, math.inf, taper)
    return TaperedRoad(road, road.length, _fitted_taper(road, taper))


def _fitted_taper(road, taper):
    """The fade of a profile driven once: ``taper``, or a quarter of a shorter profile."""
    if not (isinstance(taper, (int, float)) and 4 * taper > road.length):
        return taper
    short = road.length / 4
    warnings.warn(
        RoadWarning(
            f"road '{road.name}' is {road.length:.4g} m long: faded in and out over "
            f"{short:.4g} m at each end instead of {taper:g} m (choose with taper_m, or "
            "drive it repeated with repeat=True: it then fades in once)",
            parameters=("taper_m", "repeat"),
        ),
        stacklevel=3,
    )
    return short


def _warn_steep(road):
    """Warn of a slope steeper than a tire follows on a road driven with point contact."""
    from .profile import STEEP_SLOPE

    steep, where = road.steepest()
    if steep > STEEP_SLOPE:
        warnings.warn(
            RoadWarning(
                f"road '{road.name}': its slope reaches {steep:.3g} m per m at {where:.4g} "
                "m (a step, a joint or an edge), steeper than a tire follows; point "
                "contact passes it to the wheel as it is (contact=tandem-cam envelops it)",
                parameters=("contact",),
            ),
            stacklevel=3,
        )


def road_handling(road: dict) -> str:
    """How a road is driven, in words, from its description (:meth:`~bodyvib.vehicle.road.base.Road.describe`).

    Parameters
    ----------
    road : dict
        A driven road's description.

    Returns
    -------
    str
        The fade, the contact, the moving average and the repetition, e.g.
        ``"faded in over 5 m, tandem-cam contact (r0 0.313 m, footprint 0.111 m), repeated
        every 9.76 m"``; the fade alone for a synthetic road (a random road, periodic
        over more than the run, never repeats within it).

    Examples
    --------
    >>> d = {"taper_m": 5.0, "tapered_length_m": 30.0, "contact": {"model": "point"}}
    >>> road_handling(d)
    'faded in and out over 5 m, point contact'
    """
    parts = []
    taper = road.get("taper_m")
    if taper:
        once = road.get("tapered_length_m") is None
        parts.append(f"faded in over {taper:g} m" if once else f"faded in and out over {taper:g} m")
    contact = road.get("contact")
    if contact:
        parts.append(
            "point contact"
            if contact.get("model") == "point"
            else f"{contact.get('name', contact['model'])} contact "
            f"(r0 {contact['radius_m']:g} m, footprint {contact['footprint_m']:g} m)"
        )
    if road.get("moving_average_m"):
        parts.append(f"{1000 * road['moving_average_m']:g} mm moving average")
    if road.get("repeats") and contact and road.get("length_m"):  # a file, driven again
        parts.append(f"repeated every {road['length_m']:.6g} m")
    return ", ".join(parts)


def wheel_inputs(
    road: Road, speed: float, t, behind: Sequence[float] = (0.0,)
) -> Tuple[np.ndarray, np.ndarray]:
    """Road displacement and velocity under each wheel of a car driving at constant speed.

    The first wheel is at ``x = speed * t``; a wheel ``behind[j]`` metres behind it
    (the rear axle of a half car: the wheelbase) sees the same road later,
    ``r(speed * t - behind[j])``, evaluated on the road's own profile (its velocity is
    the exact derivative ``speed * dr/dx`` there, not a resampled copy), and the level
    road before the start (``x < 0``) where the road has not begun under it.

    Parameters
    ----------
    road : Road
        A road as driven (:func:`driven_road`).
    speed : float
        m/s, positive.
    t : array_like
        Times in s.
    behind : sequence of float
        Distance of each wheel behind the first, m (``0`` for the first).

    Returns
    -------
    displacement, velocity : (n, wheels) ndarray
        m and m/s, a column per wheel.

    Raises
    ------
    BodyvibError
        A speed that is not a positive number, or a negative distance.

    Examples
    --------
    The rear wheel, 2 m behind, is where the front wheel was 0.25 s earlier at 8 m/s:

    >>> r = driven_road(RunSettings("sweep", 8.0, 4.0))
    >>> z, v = wheel_inputs(r, 8.0, [0.125, 0.375, 0.625], behind=(0.0, 2.0))
    >>> z.shape, float(z[0, 1]), bool(z[1, 1] == z[0, 0]), bool(v[2, 1] == v[1, 0])
    ((3, 2), 0.0, True, True)
    """
    t = np.asarray(t, dtype=float)
    z = np.empty((t.size, len(behind)))
    v = np.empty((t.size, len(behind)))
    for j, d in enumerate(behind):
        if not (math.isfinite(d) and d >= 0):
            raise BodyvibError(
                f"a wheel must be a non-negative distance behind the first, got {d!r}"
            )
        if d == 0:
            z[:, j], v[:, j] = road_input(road, speed, t)
            continue
        x = speed * t - d
        ahead = x >= 0  # the wheel has reached the road's start
        # the road at those points only: they stay a uniform grid (the fast harmonic sum;
        # with the level points in, a 2000 s half-car run took minutes in the direct sum)
        z[:, j], v[:, j] = 0.0, 0.0
        zj, sj = road.profile(x[ahead])  # height and slope from one call: shared work once
        z[ahead, j] = zj
        v[ahead, j] = speed * sj
    return z, v


def road_columns(road_displacement, road_velocity, points: int) -> Tuple[np.ndarray, np.ndarray]:
    """A car's road input as given to a run, checked: a column per road point.

    Parameters
    ----------
    road_displacement, road_velocity : (m,) or (m, points) array_like
        m and m/s (a single column may be given flat for a car driven at one point).
    points : int
        The car's road points.

    Returns
    -------
    displacement, velocity : (m, points) ndarray

    Raises
    ------
    BodyvibError
        Arrays of another shape, or a non-finite value.

    Examples
    --------
    >>> z, v = road_columns([0.0, 0.01], [0.0, 0.2], 1)
    >>> z.shape
    (2, 1)
    """
    z = np.asarray(road_displacement, dtype=float)
    v = np.asarray(road_velocity, dtype=float)
    if z.ndim == 1 and points == 1:
        z, v = z[:, None], v[:, None]
    if z.shape != v.shape or z.ndim != 2 or z.shape[1] != points:
        raise BodyvibError(
            "road displacement and velocity must be arrays of equal shape, "
            f"(samples,) or (samples, {points}): a column per road point of the car"
        )
    if not (np.all(np.isfinite(z)) and np.all(np.isfinite(v))):
        raise BodyvibError("road input is not finite; check the road profile")
    return z, v
