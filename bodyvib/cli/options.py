"""The option groups several ``bodyvib`` commands share, declared once: output files, body
models and the ``--road-*`` options of a driven road."""

import os

from bodyvib.vehicle.road.contact import CONTACTS
from bodyvib.vehicle.road.driven import DEFAULT_TAPER_M, RoadOptions, RunSettings
from bodyvib.vehicle.sweep.spec import ROAD_OPTION_KEYS

from .outputs import OUTPUT_OPTIONS

__all__ = [
    "add_output_options",
    "add_models_option",
    "model_inputs",
    "add_seat_option",
    "car_and_seat",
    "ROAD_ARGUMENTS",
    "add_road_options",
    "add_run_options",
    "road_options_from_args",
    "run_settings_from_args",
]


def add_output_options(p, **helps) -> None:
    """Add output-file options (``--plot``, ``--csv``, ``--json``) to a command's parser.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    **helps : str
        Option name (a key of :data:`bodyvib.cli.outputs.OUTPUT_OPTIONS`) to its help text,
        in the order the options are listed in the help.

    Examples
    --------
    >>> import argparse
    >>> p = argparse.ArgumentParser()
    >>> add_output_options(p, plot="write the plot", json="write the figures as JSON")
    >>> p.parse_args(["--json", "a.json"]).json
    'a.json'
    """
    for name, text in helps.items():
        p.add_argument(f"--{name}", metavar=OUTPUT_OPTIONS[name][0], help=text)


def add_models_option(p, default) -> None:
    """Add ``--models MODEL ...``: the body models a command compares.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    default : sequence of str
        Model names used when the option is not given.
    """
    p.add_argument(
        "--models",
        nargs="+",
        default=list(default),
        metavar="MODEL",
        help="shipped model names or parameter-file paths (default: %(default)s)",
    )


def model_inputs(models) -> list:
    """The ``(option, path)`` inputs of ``--models``: those that are parameter files.

    Parameters
    ----------
    models : sequence of str
        Shipped model names or parameter-file paths.

    Returns
    -------
    list of (str, str)
        ``("--models", path)`` of every existing file, for
        :func:`bodyvib.cli.outputs.check_files` (no output may overwrite one).
    """
    return [("--models", m) for m in models if os.path.isfile(m)]


def add_seat_option(p, what="the car") -> None:
    """Add ``--seat SEAT``: a seat between a car's seat point and the occupant.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    what : str
        What the seat stands in, for the help text.
    """
    p.add_argument(
        "--seat",
        metavar="SEAT",
        help=f"a seat in {what}, between its seat point and the occupant: 'cushion', "
        "'suspension' or a seat file (default: none, the occupant sits on the seat point)",
    )


def car_and_seat(car, seat, default="quarter-car"):
    """The vehicle model of ``--car`` and ``--seat``: the car name, with ``+SEAT`` when a
    seat is given.

    Parameters
    ----------
    car : str or None
        ``--car`` (None: ``default``).
    seat : str or None
        ``--seat``.
    default : str
        The car when ``--car`` is not given.

    Returns
    -------
    str
        A name :func:`bodyvib.vehicle.quarter_car.load_car` loads.

    Examples
    --------
    >>> car_and_seat(None, "suspension")
    'quarter-car+suspension'
    >>> car_and_seat("half-car", None)
    'half-car'
    """
    from bodyvib.vehicle.seats import car_with_seat

    car = car or default
    return car_with_seat(car, seat) if seat else car


#: The ``--road-*`` options' argparse settings, by the
#: :class:`~bodyvib.vehicle.road.driven.RoadOptions` field each one sets (a key of a sweep
#: spec's ``road_options`` and of Road.fmu's road options,
#: :data:`bodyvib.vehicle.sweep.spec.ROAD_OPTION_KEYS`); the flag is :data:`ROAD_FLAGS`'s.
ROAD_ARGUMENTS = {
    "taper_m": dict(
        type=float,
        default=DEFAULT_TAPER_M,
        metavar="M",
        help="the road fades in from level over its first M metres (and out over its "
        "last), so the car starts at rest on it (default: 5; 0: none)",
    ),
    "track_m": dict(
        type=float,
        default=0.0,
        metavar="M",
        help="OpenCRG road: lateral offset of the wheel from the reference line, m, "
        "positive to the left (default: 0); a full car's wheels run half its track width "
        "to either side of it",
    ),
    "units": dict(
        metavar="DIST,ELEV",
        help="CSV/text/ERD road: units of distance and elevation when the file does not "
        "name them, e.g. m,mm (default for bare columns: m,m)",
    ),
    "envelope": dict(
        action="store_true",
        help="road file: the 250 mm moving average of the IRI standard (a profile filter; "
        "the tire is --road-contact)",
    ),
    "repeat": dict(
        action="store_true",
        help="road file: drive the profile again and again (it fades in once); a run "
        "longer than the profile repeats it anyway, with a warning",
    ),
    "contact": dict(
        choices=CONTACTS,
        default="auto",
        help="road file: the tire contact: the tandem-cam effective road of a 205/60R15 "
        "tire (tandem-cam: default shape factors; mfswift-205-60R15: the enveloping set "
        "MF-Swift measured on cleats), the profile point by point, or auto: tandem-cam on "
        "a profile sampled finer than the tire's footprint (0.111 m), point otherwise "
        "(default: auto)",
    ),
}


#: The flag of each road option: ``--road-`` and the field without its unit (``--road-taper``).
ROAD_FLAGS = {field: "--road-" + field.removesuffix("_m") for field in ROAD_ARGUMENTS}


def add_run_options(p, step="communication step") -> None:
    """``--speed``, ``--duration``, ``--step`` and ``--seed`` of a command that drives a
    car over a road (cosim, check, control).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    step : str
        What the step is called in its help (``control``: the time step of its exact
        closed loop).
    """
    p.add_argument("--speed", type=float, default=20.0, help="vehicle speed, m/s (default 20)")
    p.add_argument("--duration", type=float, default=30.0, help="simulated time, s (default 30)")
    p.add_argument("--step", type=float, default=1e-3, help=f"{step}, s (default 0.001)")
    p.add_argument("--seed", type=int, default=0, help="random-road seed (default 0)")


def add_road_options(p, taper_help=None) -> None:
    """The ``--road-*`` options of a command that drives a road (cosim, check, sweep, build).

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    taper_help : str, optional
        Help of ``--road-taper`` where the taper means something else (``build``: the
        default of Road.fmu).
    """
    for field, settings in ROAD_ARGUMENTS.items():
        if field == "taper_m" and taper_help:
            settings = dict(settings, help=taper_help)
        p.add_argument(ROAD_FLAGS[field], dest=f"road_{field}", **settings)


def road_options_from_args(args) -> RoadOptions:
    """The road options of parsed ``--road-*`` options.

    Parameters
    ----------
    args : argparse.Namespace
        A command line parsed by a parser with :func:`add_road_options`.

    Returns
    -------
    bodyvib.vehicle.road.driven.RoadOptions

    Examples
    --------
    Every option sets one field (the spec's keys and the options are the same six):

    >>> list(ROAD_ARGUMENTS) == list(ROAD_OPTION_KEYS)
    True
    >>> import argparse
    >>> p = argparse.ArgumentParser()
    >>> add_road_options(p)
    >>> road_options_from_args(p.parse_args(["--road-taper", "3", "--road-repeat"]))
    RoadOptions(taper_m=3.0, track_m=0.0, units=None, envelope=False, repeat=True, contact='auto')
    """
    return RoadOptions(**{field: getattr(args, f"road_{field}") for field in ROAD_OPTION_KEYS})


def run_settings_from_args(args) -> RunSettings:
    """The run of parsed ``--road``, ``--speed``, ``--duration``, ``--step``, ``--seed`` and
    ``--road-*`` options, as one settings object.

    Parameters
    ----------
    args : argparse.Namespace
        A command line with those options (``cosim``, ``check``, ``control``).

    Returns
    -------
    bodyvib.vehicle.road.driven.RunSettings

    Examples
    --------
    >>> import argparse
    >>> p = argparse.ArgumentParser()
    >>> add_road_options(p)
    >>> args = p.parse_args([])
    >>> args.road, args.speed, args.duration, args.step, args.seed = "C", 20.0, 30.0, 1e-3, 0
    >>> run_settings_from_args(args).speed
    20.0
    """
    return RunSettings.from_attributes(args, road_options_from_args(args))
