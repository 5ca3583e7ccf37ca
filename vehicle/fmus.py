"""The project's FMUs: HumanBody3DOF, HumanBodyISO7962, QuarterCar, HalfCar, FullCar, Road,
RoadFrontRear.

``python build_fmu.py`` and ``bodyvib build`` build these with
:func:`bodyvib.fmu.builder.build`, pythonfmu or native (``Road``: a road of
:mod:`bodyvib.vehicle.road.synthetic` or a road file, tabulated at build time); the co-simulation commands build the ones they are
not given into a temporary folder (:func:`temporary_fmu_dir`).
"""

import math
import tempfile
from pathlib import Path
from typing import Dict, Iterable, Optional

from bodyvib.fmu.builder import build
from bodyvib.models import load_model
from bodyvib.process import interrupts
from bodyvib.process.outputs import staged_writes
from bodyvib.process.progress import Progress, progress_lines
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.renames import renamed_parameters

from .quarter_car import load_car
from .road.bumps import check_bump_start
from .road.driven import (
    RoadOptions,
    file_options_refused,
    file_road,
    is_road_file,
    renamed_road_options,
)
from .road.synthetic import (
    ISO8608_CLASSES,
    TaperedRoad,
    lead_in_period,
    make_road,
    random_road,
    road_source,
)

__all__ = [
    "AXLE_ROAD_CAR",
    "FMUS",
    "WHEEL_ROAD_CARS",
    "ROAD_DEFAULTS",
    "build_fmus",
    "build_project_fmu",
    "car_fmu_name",
    "fmu_road",
    "fmu_road_length",
    "fmu_road_of",
    "linear_car_file",
    "road_with_defaults",
    "load_fmu_model",
    "temporary_fmu_dir",
]

#: Road.fmu's defaults: ISO 8608 class C, seed 0, 601 m (30 s at 20 m/s and a metre
#: to spare, the road of ``bodyvib check``), faded in and out over 5 m, speed
#: parameter 20 m/s.
ROAD_DEFAULTS = {
    "road": "C",
    "seed": 0,
    "length": 601.0,
    "speed": 20.0,
    "taper_m": 5.0,
    "track_m": 0.0,
    "units": None,
    "envelope": False,
    "repeat": False,
    "contact": "auto",
}

#: FMU name -> (kind, default model, description).
FMUS = {
    "HumanBody3DOF": (
        "body",
        "reduced-paper",
        "Reduced 3-DOF seated human body (Balci & Gundogdu 2025): seat motion in, "
        "head acceleration and seat force out; exact discretization",
    ),
    "HumanBodyISO7962": (
        "body",
        "iso7962",
        "ISO 7962 four-mass seated human body (reconstructed topology): seat motion "
        "in, head acceleration and seat force out; exact discretization",
    ),
    "QuarterCar": (
        "car",
        "quarter-car",
        "Quarter car (sprung mass, suspension, unsprung mass, tire): road and seat force "
        "in, seat motion, suspension deflection and tire force out; exact discretization",
    ),
    "HalfCar": (
        "car",
        "half-car",
        "Half car (body bounce and pitch on front and rear suspensions, unsprung masses and "
        "tires): front and rear road and seat force in, seat motion, bounce, pitch, "
        "suspension deflections and tire forces out; exact discretization",
    ),
    "FullCar": (
        "car",
        "full-car",
        "Full car (body bounce, pitch and roll on four suspensions, unsprung masses and "
        "tires): the four corners' road and the seat force in, the seat point's vertical "
        "motion and horizontal accelerations, bounce, pitch, roll, suspension deflections "
        "and tire forces out; exact discretization",
    ),
    "Road": (
        "source",
        "C",
        "Road profile under a wheel driving at a speed (a parameter): road_displacement and "
        "its exact time derivative road_velocity, from a table built by bodyvib.vehicle.road",
    ),
    "RoadFrontRear": (
        "source",
        "C",
        "Road profile under the front and the rear wheel of a half car (the rear a wheelbase "
        "behind) driving at a speed: road_displacement_front/_rear and their exact time "
        "derivatives road_velocity_front/_rear, from a table built by bodyvib.vehicle.road",
    ),
    "RoadFourWheel": (
        "source",
        "C",
        "Road profiles under the four wheels of a full car driving at a speed, the left "
        "wheels on the road's left track and the right wheels on its right track (a track "
        "width apart), the rear a wheelbase behind: road_displacement_front_left, "
        "_front_right, _rear_left, _rear_right and their exact time derivatives "
        "road_velocity_..., from a table built by bodyvib.vehicle.road",
    ),
}

#: The car whose wheelbase RoadFrontRear.fmu is built for, unless a half car is chosen.
AXLE_ROAD_CAR = "half-car"

#: Road FMU with a pair per wheel -> (the car FMU it feeds, the car it is built for unless
#: a car of that FMU is chosen: its wheelbase, its wheels' sides and track width).
WHEEL_ROAD_CARS = {
    "RoadFrontRear": ("HalfCar", AXLE_ROAD_CAR),
    "RoadFourWheel": ("FullCar", "full-car"),
}


@renamed_parameters(taper="taper_m", track="track_m")
def fmu_road(
    spec: str = "C",
    length: float = 601.0,
    seed: int = 0,
    speed: float = 20.0,
    taper_m: float = 5.0,
    track_m: float = 0.0,
    units: Optional[str] = None,
    envelope: bool = False,
    repeat: bool = False,
    contact: str = "auto",
    *,
    side: int = 0,
    track_width: float = 0.0,
):
    """The road a ``Road.fmu`` tabulates: the road a run drives (faded in from level).

    Parameters
    ----------
    spec : str
        ISO 8608 class ``A``-``H`` (a random road whose period is ``length``),
        ``bump``, ``sweep`` (0.5-20 Hz at ``speed`` over ``length``) or a road file
        (``.crg``, ``.csv``, ``.txt``, ``.erd``: tabulated over its own length).
    length : float
        m (a synthetic road's).
    seed : int
        Seed of a random road.
    speed : float
        Design speed of a sweep, and the speed a profile's spacing is checked at, m/s.
    taper_m : float
        Every road fades in from level over its first ``taper_m`` metres and out
        over its last (:class:`bodyvib.vehicle.road.synthetic.TaperedRoad`; 0: none), as
        every run's road does (:func:`bodyvib.vehicle.road.driven.driven_road`): the car
        starts at rest on a level road. The old name ``taper`` works for one release,
        with a ``DeprecationWarning`` (``track`` likewise).
    track_m, units, envelope, repeat, contact
        A road file's track (OpenCRG), units (CSV/ERD), moving average, repetition
        and tire contact (:class:`bodyvib.vehicle.road.driven.RoadOptions`). A repeated
        file is tabulated over one period, faded in and out (a table repeats whole).
    side, track_width
        A road file's track of a car with left and right wheels
        (:func:`bodyvib.vehicle.road.driven.file_road`).

    Returns
    -------
    bodyvib.vehicle.road.synthetic.TaperedRoad

    Raises
    ------
    BodyvibError
        Unknown road, bad length or seed, a road file that cannot be driven.
    """
    s = str(spec).strip()
    if is_road_file(s):
        from .road.measured import load_profile

        if repeat:  # faded in once, then the profile again and again, as a run drives it
            crg = s.lower().endswith(".crg")
            road = load_profile(
                s,
                track_m=track_m + (side * track_width / 2 if crg else 0.0),
                side=side,
                units=units,
                envelope=envelope,
                contact=contact,
                periodic=True,
            )
            road.check_run(speed, road.length / speed, None, repeat=True)  # its spacing
            return TaperedRoad(road, math.inf, taper_m)
        options = RoadOptions(taper_m, track_m, units, envelope, False, contact)
        return file_road(s, options, speed, side=side, track_width=track_width)
    if track_m or units or envelope or repeat or contact != "auto":
        raise file_options_refused(spec)
    if len(s) == 1 and s.upper() in ISO8608_CLASSES:
        return TaperedRoad(random_road(s.upper(), length=length, seed=seed), length, taper_m)
    road = make_road(s, speed, length / speed if length > 0 else length, seed=seed)
    check_bump_start(road, taper_m)
    return TaperedRoad(road, road.length, taper_m)


def fmu_road_length(road, length: float) -> float:
    """Extent of ``Road.fmu``'s table: a road file's own length, else ``length`` (m).

    A file driven repeated is tabulated over its fade-in and one period beyond it: the
    whole periods that hold the fade, then the one that repeats.
    """
    inner = getattr(road, "road", road)
    period = lead_in_period(road)
    if period:
        return period * (math.ceil(road.taper / period - 1e-9) + 1)
    return float(inner.length) if hasattr(inner, "spacing") else float(length)


def fmu_road_of(options: dict, side: int = 0, track_width: float = 0.0):
    """Road.fmu's road and the extent of its table (m) from options over :data:`ROAD_DEFAULTS`.

    Parameters
    ----------
    options : dict
        Keys of :data:`ROAD_DEFAULTS` (``road`` is the road, :func:`fmu_road`'s ``spec``).
    side, track_width
        A road file's track (:func:`fmu_road`).

    Returns
    -------
    road : bodyvib.vehicle.road.synthetic.TaperedRoad
    length : float
        m, :func:`fmu_road_length`.
    """
    r = road_with_defaults(options)
    rd = fmu_road(
        r["road"],
        **{k: r[k] for k in ROAD_DEFAULTS if k != "road"},
        side=side,
        track_width=track_width,
    )
    return rd, fmu_road_length(rd, r["length"])


def road_with_defaults(options: Optional[dict]) -> dict:
    """Road.fmu's road options: ``options`` over :data:`ROAD_DEFAULTS`, under the new names.

    Parameters
    ----------
    options : dict or None
        Some keys of :data:`ROAD_DEFAULTS`; the old ``taper`` and ``track`` work for one
        release, with a ``DeprecationWarning``.

    Returns
    -------
    dict
        Every key of :data:`ROAD_DEFAULTS`.

    Examples
    --------
    >>> road_with_defaults({"road": "bump"})["taper_m"]
    5.0
    """
    return dict(ROAD_DEFAULTS, **renamed_road_options(options or {}, "Road.fmu's road options"))


def _road_source(**options):
    """The source description and table of Road.fmu, pythonfmu or native alike."""
    r = road_with_defaults(options)
    return road_source(*fmu_road_of(r), r["speed"])


def _source(name: str, car: Optional[str] = None, **options):
    """The source of a road FMU of :data:`FMUS`: Road.fmu's, or that of a road FMU with a
    pair per wheel (:data:`WHEEL_ROAD_CARS`) for the wheels of ``car`` (its default car
    by default): each wheel on its track, a wheelbase behind the first."""
    if name not in WHEEL_ROAD_CARS:
        return _road_source(**options)
    from .quarter_car import track_width, wheel_offsets, wheel_sides
    from .road.synthetic import wheel_road_source
    from .road.tracks import two_tracks

    fmu, default = WHEEL_ROAD_CARS[name]
    network = load_car(car or default)
    offsets = wheel_offsets(network)
    if car_fmu_name(car or default) != fmu:
        raise BodyvibError(
            f"{name}.fmu serves a car built as {fmu}.fmu; '{car}' is built as "
            f"{car_fmu_name(car)}.fmu"
        )
    r = road_with_defaults(options)
    road, length = fmu_road_of(r)
    sides, width = wheel_sides(network), track_width(network)
    tracks = {0: road}
    if -1 in sides:
        tracks[1], tracks[-1] = two_tracks(
            r["road"],
            road,
            width,
            length=r["length"],
            seed=r["seed"],
            taper=r["taper_m"],
            file_track=lambda side: fmu_road_of(r, side, width)[0],
        )
    wheels = {
        base[len("road_") :]: (tracks[side], behind)
        for base, side, behind in zip(network.bases, sides, offsets)
    }
    return wheel_road_source(wheels, length, r["speed"])


def load_fmu_model(name: str, model: Optional[str] = None):
    """The model an FMU of :data:`FMUS` bakes in.

    Parameters
    ----------
    name : str
        A key of :data:`FMUS`.
    model : str, optional
        Shipped model name or parameter file (the FMU's default if None).

    Returns
    -------
    bodyvib.runtime.network.Network

    Raises
    ------
    BodyvibError
        Unknown FMU name, unknown model or invalid parameter file.
    """
    if name not in FMUS:
        raise BodyvibError(f"unknown FMU '{name}'; FMUs are {', '.join(FMUS)}")
    kind, default, _ = FMUS[name]
    if kind == "source":
        raise BodyvibError(
            f"{name}.fmu carries a road table, not a model (build_project_fmu('{name}', road=...))"
        )
    return (load_car if kind == "car" else load_model)(model or default)


def build_project_fmu(
    name: str,
    dest="dist",
    model: Optional[str] = None,
    *,
    road: Optional[dict] = None,
    native: bool = False,
    fmi: int = 2,
    platforms: Iterable[str] = ("linux64", "win64"),
) -> Path:
    """Build one FMU of :data:`FMUS`, pythonfmu or native: the one entry for every kind.

    Parameters
    ----------
    name : str
        A key of :data:`FMUS`.
    dest : str or path
        Output folder.
    model : str, optional
        Shipped model name or parameter file to bake in (the FMU's default if None); for
        ``Road``, the road (an ISO 8608 class, ``bump``, ``sweep`` or a road file).
    road : dict, optional
        ``Road`` only: the options of :func:`fmu_road` (``seed``, ``length``, ``speed``,
        ``taper_m``, ``track_m``, ``units``, ``envelope``, ``repeat``) over
        :data:`ROAD_DEFAULTS`.
    native : bool
        A native C FMU (:mod:`bodyvib.fmu.native`) instead of a pythonfmu one.
    fmi : int
        With ``native``: FMI version, 2 or 3 (pythonfmu FMUs are FMI 2.0).
    platforms : iterable of str
        With ``native``: :data:`bodyvib.fmu.native.PLATFORMS` to compile.

    Returns
    -------
    Path
        The FMU written, ``dest/<name>.fmu`` (pythonfmu FMI 2.0 or native FMI ``fmi``.0).

    Raises
    ------
    BodyvibError
        An unknown FMU; see :func:`load_fmu_model`, :func:`fmu_road` and
        :func:`bodyvib.fmu.builder.build`.

    Examples
    --------
    >>> build_project_fmu("QuarterCar", "dist")  # doctest: +SKIP
    PosixPath('dist/QuarterCar.fmu')
    >>> build_project_fmu("Road", "dist/native", "road.crg", native=True, fmi=3)  # doctest: +SKIP
    PosixPath('dist/native/Road.fmu')
    """
    if name not in FMUS:
        raise BodyvibError(f"unknown FMU '{name}'; FMUs are {', '.join(FMUS)}")
    kind, _, description = FMUS[name]
    if kind == "source":
        model = _source(name, **dict(road or {}, **({"road": model} if model else {})))
    else:
        model = load_fmu_model(name, model)
    return build(
        model,
        kind,
        name,
        description,
        dest,
        backend="native" if native else "pythonfmu",
        fmi=fmi,
        platforms=platforms,
    )


def _chosen_models(params, car, seat):
    """The model file of each FMU that takes one, the seat put into the cars; the car's."""
    chosen = {"HumanBody3DOF": params, car_fmu_name(car): car}
    if seat:
        from .seats import car_with_seat

        for n, (kind, default, _) in FMUS.items():
            if kind == "car":
                chosen[n] = car_with_seat(chosen.get(n) or default, seat)
        car = chosen[car_fmu_name(car)]
    return chosen, car


def _built_from(name, road, chosen):
    """What an FMU was built from, in words: its road or its model."""
    if FMUS[name][0] != "source":
        return f"model {chosen.get(name) or FMUS[name][1]}"
    if is_road_file(road["road"]):
        return f"road {road['road']}"
    return f"road {road['road']}, seed {road['seed']}, {road['length']:g} m"


@renamed_parameters(echo="progress")
def build_fmus(
    dest="dist",
    params: Optional[str] = None,
    car: str = "quarter-car",
    names: Optional[Iterable[str]] = None,
    progress: Progress = False,
    road: Optional[dict] = None,
    native: bool = False,
    fmi: Iterable[int] = (2, 3),
    platforms: Optional[Iterable[str]] = None,
    seat: Optional[str] = None,
) -> Dict[str, Path]:
    """Build the project's FMUs.

    Parameters
    ----------
    dest : str or path
        Output folder (``dist`` by default).
    params : str, optional
        Parameter file (or shipped model name) baked into ``HumanBody3DOF.fmu``;
        the paper's Table 2 (``reduced-paper``) by default.
    car : str
        Vehicle parameter file or shipped name for ``QuarterCar.fmu`` (a car driven at
        one road point) or ``HalfCar.fmu`` (at a front and a rear one).
    names : iterable of str, optional
        Which FMUs (all of :data:`FMUS` by default).
    progress : bool or callable
        One line per FMU written: on stderr (True) or to a callable (``echo`` still
        works for one release, with a ``DeprecationWarning``).
    road : dict, optional
        Options of :func:`fmu_road` for ``Road.fmu`` (``road``, ``seed``, ...)
        (:data:`ROAD_DEFAULTS` by default).
    native : bool
        Build the native C FMUs instead of the pythonfmu ones: FMI 2.0 into
        ``dest``, FMI 3.0 into ``dest/fmi3`` (keys ``"fmi3/<name>"``), Road.fmu
        included (its table in C).
    fmi : iterable of int
        With ``native``, the FMI versions to build.
    platforms : iterable of str, optional
        With ``native``, the binaries to compile (:data:`bodyvib.fmu.native.PLATFORMS`);
        by default every platform whose compiler is on PATH
        (:func:`bodyvib.fmu.native.choose_platforms`).
    seat : str, optional
        A seat (shipped name or seat file, :mod:`bodyvib.vehicle.seats`) put into every car
        FMU built (``QuarterCar``, ``HalfCar``) on its seat point.

    Returns
    -------
    dict of str to Path

    Raises
    ------
    BodyvibError
        See :func:`bodyvib.fmu.pythonfmu.build_fmu`; every model is loaded (and a
        bad one refused) before the first FMU is built.

    Examples
    --------
    >>> paths = build_fmus("dist")  # doctest: +SKIP
    >>> sorted(paths)  # doctest: +SKIP
    ['HumanBody3DOF', 'HumanBodyISO7962', 'QuarterCar']
    """
    names = list(names or FMUS)
    chosen, car = _chosen_models(params, car, seat)
    road = road_with_defaults(road)
    sources = {}
    for n in names:  # refuse a bad model (or road) before building anything
        if n in FMUS and FMUS[n][0] == "source":
            # a wheel road FMU for the chosen car if it feeds that car's FMU, else its own
            mine = n in WHEEL_ROAD_CARS and car_fmu_name(car) == WHEEL_ROAD_CARS[n][0]
            sources[n] = _source(n, car if mine else None, **road)  # once for every FMI
        else:
            load_fmu_model(n, chosen.get(n))
    if native:
        from bodyvib.fmu.native import choose_platforms

        platforms = choose_platforms(platforms).platforms
    out, what = {}, {}
    with staged_writes(guard=interrupts.critical):  # all FMUs or none: a failed (or
        for version in fmi if native else (2,):  # interrupted) build keeps the old ones
            folder = Path(dest) if version == 2 else Path(dest) / "fmi3"
            for n in names:
                key = n if version == 2 else f"fmi3/{n}"
                how = {"fmi": version, "platforms": platforms}
                if FMUS[n][0] == "source":
                    backend = "native" if native else "pythonfmu"
                    out[key] = build(
                        sources[n], "source", n, FMUS[n][2], folder, backend=backend, **how
                    )
                else:
                    out[key] = build_project_fmu(n, folder, chosen.get(n), native=native, **how)
                what[key] = _built_from(n, road, chosen)
                if native:
                    what[key] = f"native C, FMI {version}.0, {what[key]}, {'+'.join(platforms)}"
        interrupts.check()
    say = progress_lines(progress)
    for key in out:
        say(f"wrote {out[key]} ({what[key]}; fmpy validate: no problems)")
    return out


def linear_car_file(car: str, folder) -> str:
    """Write a car linearized about static equilibrium as a parameter file; its path.

    What ``--linear`` builds its car FMU from (and the sweeps' co-simulation engine, whose
    other engines step linear cars).

    Parameters
    ----------
    car : str
        Shipped vehicle name, parameter file or ``CAR+SEAT``
        (:func:`bodyvib.vehicle.quarter_car.load_car`).
    folder : str or path
        An existing folder; the file is ``car-linear.json`` there.

    Returns
    -------
    str
        The file's path.
    """
    from bodyvib.process.outputs import write_json
    from bodyvib.runtime.modelfile import network_to_dict

    path = str(Path(folder) / "car-linear.json")
    write_json(path, network_to_dict(load_car(car, linear=True)))
    return path


def car_fmu_name(car: str = "quarter-car") -> str:
    """The FMU a vehicle model is built as: ``FullCar`` for a car with left and right
    wheels, ``HalfCar`` for a car with axles, else ``QuarterCar``.

    Parameters
    ----------
    car : str
        Shipped vehicle name or parameter file.

    Returns
    -------
    str
        A key of :data:`FMUS`.

    Raises
    ------
    BodyvibError
        What :func:`bodyvib.vehicle.quarter_car.load_car` refuses.

    Examples
    --------
    >>> car_fmu_name("quarter-car"), car_fmu_name("half-car"), car_fmu_name("full-car")
    ('QuarterCar', 'HalfCar', 'FullCar')
    """
    net = load_car(car)
    if any(net.body_point_places[p][2] for p in net.body_points):
        return "FullCar"  # a body with points off its centreline: it rolls
    return "HalfCar" if net.extra_bases else "QuarterCar"


def temporary_fmu_dir() -> str:
    """A fresh temporary folder for FMUs built for one run (the caller deletes it)."""
    return tempfile.mkdtemp(prefix="bodyvib-fmus-")
