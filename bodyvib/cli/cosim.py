"""``bodyvib cosim`` and ``bodyvib check``: co-simulation of a car with body FMUs.

``cosim`` drives a car (the quarter car by default, ``--car half-car``, a car with a seat or
actuators) over a road with one body FMU and reports the
head acceleration's ISO 2631-1 figures and the coupling error against the
monolithic reference. ``check`` does the same with the reduced body and the
ISO 7962 body and prints the verdict of the reduced model against the ISO one.
FMUs not given on the command line are built for the run into a temporary
folder (about a second each) and deleted afterwards.
"""

import os
import shutil
import sys

from bodyvib.models import load_model
from bodyvib.process.outputs import write_json
from bodyvib.runtime.errors import BodyvibError
from bodyvib.vehicle.check import compare
from bodyvib.vehicle.cosim import check_fmu
from bodyvib.vehicle.fmus import build_fmus, car_fmu_name, linear_car_file, temporary_fmu_dir
from bodyvib.vehicle.report import format_report, study_json
from bodyvib.vehicle.study import StudyCsv, check_settings, run_study
from bodyvib.vehicle.study_plot import plot_study

from .flags import in_flags
from .options import (
    add_output_options,
    add_road_options,
    add_run_options,
    add_seat_option,
    car_and_seat,
    run_settings_from_args,
)
from .outputs import check_files, write_outputs

__all__ = ["add_command"]


def _moot_options(args):
    """``(given, would be ignored, message)`` of each option another one makes moot."""
    built = "the run; with --car-fmu FMU it would be ignored"
    return (
        (
            args.body,
            args.params is not None,
            "--params bakes a parameter file into the HumanBody3DOF.fmu built for "
            "the run; with --body FMU it would be ignored: give one of them",
        ),
        (
            args.car_fmu,
            args.car is not None,
            f"--car chooses the model of the QuarterCar.fmu built for {built}: give one of them",
        ),
        (
            args.car_fmu,
            getattr(args, "linear", False),
            f"--linear linearizes the car FMU built for {built}: give one of them",
        ),
        (
            args.car_fmu,
            args.seat is not None,
            f"--seat goes into the car FMU built for {built}: build that FMU with the seat, "
            "or leave out --car-fmu",
        ),
    )


def _check_options(args):
    """Refuse options that would be silently ignored, and outputs that cannot be written."""
    for given, ignored, message in _moot_options(args):
        if given is not None and ignored:
            raise BodyvibError(message)
    inputs = [
        ("--body", args.body),
        ("--car-fmu", args.car_fmu),
        ("--iso-body", getattr(args, "iso_body", None)),
        ("--params", args.params),
        ("--car", args.car),
        ("--seat", args.seat),
        ("--road", args.road),
    ]
    check_files(
        args,
        ("json", "plot", "csv"),
        inputs=[(o, p) for o, p in inputs if p is not None and os.path.isfile(p)],
    )


#: CSV bytes per communication point and body: 9 to 13 columns of up to 17 characters.
CSV_BYTES_PER_ROW = 220


def _check_disk(path, rows):
    """Refuse a CSV the disk cannot hold, before the run."""
    from bodyvib.process.limits import format_bytes

    folder = os.path.dirname(os.path.abspath(path))
    while not os.path.isdir(folder):
        folder = os.path.dirname(folder)
    need, free = rows * CSV_BYTES_PER_ROW, shutil.disk_usage(folder).free
    if need > free:
        raise BodyvibError(
            f"--csv '{path}': {rows:.3g} rows need about {format_bytes(need)} of "
            f"disk, {format_bytes(free)} free there: shorten the run or write "
            "the CSV elsewhere"
        )


def _check_fmu_file(path, option, kind):
    """Refuse an FMU option's path that is not an FMU file of that kind, naming the option."""
    if os.path.isdir(path):
        raise BodyvibError(f"'{path}' is a folder, not an FMU ({option}); give the .fmu file in it")
    if not os.path.isfile(path):
        raise BodyvibError(f"FMU file '{path}' does not exist ({option})")
    check_fmu(path, kind)  # the wrong kind of FMU, named before anything is built


def _fmus(args, want_iso: bool):
    """Paths of (reduced body, ISO body or None, car) and a temporary folder to delete."""
    for opt, kind in (("body", "body"), ("car_fmu", "car"), ("iso_body", "body")):
        p = getattr(args, opt, None)
        if p is not None:
            _check_fmu_file(p, f"--{opt.replace('_', '-')}", kind)
    need = []
    if args.body is None:
        need.append("HumanBody3DOF")
    if want_iso and args.iso_body is None:
        need.append("HumanBodyISO7962")
    car_name = None
    if args.car_fmu is None:
        # refuses a bad --car now, not after building the FMUs before it
        car_name = car_fmu_name(car_and_seat(args.car, args.seat))
        need.append(car_name)
    # refuse a bad --params now, not after building the FMUs before it
    if "HumanBody3DOF" in need and args.params:
        load_model(args.params)
    tmp, built = None, {}
    car_model = car_and_seat(args.car, args.seat) if args.car_fmu is None else None
    if need:
        tmp = temporary_fmu_dir()
        if car_model is not None and args.linear:  # the car as a file of its linear model
            car_model = linear_car_file(car_model, tmp)
        if not args.quiet:
            print(f"building {', '.join(need)} into {tmp}", file=sys.stderr, flush=True)
        try:
            built = {
                n: str(p)
                for n, p in build_fmus(
                    tmp,
                    args.params,
                    car_model,
                    need,
                    native=args.native,
                    fmi=(2,),
                ).items()
            }
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
    body = args.body or built["HumanBody3DOF"]
    iso = (args.iso_body or built["HumanBodyISO7962"]) if want_iso else None
    car = args.car_fmu or built[car_name]
    return body, iso, car, tmp


def _controller(args):
    """The ``--control`` law or ``--control-fmu`` path for the car of the run, or None."""
    if args.control is not None and args.control_fmu is not None:
        raise BodyvibError("--control and --control-fmu both choose the controller: give one")
    if args.control_fmu is not None:
        _check_fmu_file(args.control_fmu, "--control-fmu", "controller")  # a car FMU: now
        return args.control_fmu
    if args.control is None:
        return None
    from bodyvib.vehicle.control import check_coupling, parse_control
    from bodyvib.vehicle.cosim import model_from_fmu
    from bodyvib.vehicle.quarter_car import load_car

    car = model_from_fmu(args.car_fmu) if args.car_fmu else load_car(args.car or "quarter-car")
    controller = parse_control(args.control, car)
    check_coupling(controller, car, args.step)  # gains the coupling cannot follow: now
    return controller


def _vehicle(args, controller) -> dict:
    """The car, seat and controller of the run, as the report and the JSON name them."""
    from bodyvib.vehicle.control import describe

    if controller is None:
        control = None
    elif isinstance(controller, str):  # a controller FMU
        control = {"fmu": controller}
    else:
        control = {
            "law": describe(controller),
            "given": args.control,
            "c_sky_N_s_m": controller.c_sky,
            "c_ground_N_s_m": controller.c_ground,
            "semi_active": controller.semi_active,
        }
    return {
        "car": args.car_fmu or args.car or "quarter-car",
        "seat": args.seat,
        "control": control,
    }


def _check_step(args, want_iso):
    """Refuse a step the figures do not allow before building: the models built for the
    run (those of FMUs given are checked by the study, from the FMUs)."""
    from bodyvib.vehicle.quarter_car import load_car
    from bodyvib.vehicle.study import check_study_step

    car = load_car(car_and_seat(args.car, args.seat)) if args.car_fmu is None else None
    bodies = [] if args.body is not None else [load_model(args.params or "reduced-paper")]
    if want_iso and getattr(args, "iso_body", None) is None:
        bodies.append(load_model("iso7962"))
    check_study_step(args.step, car, bodies)


def _nonlinear_car(args):
    """With ``--linear``: the car with its nonlinear elements (the run's range), else None."""
    if not getattr(args, "linear", False):
        return None
    from bodyvib.vehicle.quarter_car import load_car

    return load_car(car_and_seat(args.car, args.seat))


def _label(path, default):
    base = os.path.splitext(os.path.basename(path))[0]
    return base or default


def _run(args, want_iso):
    _check_options(args)
    settings = run_settings_from_args(args)
    from bodyvib.vehicle.quarter_car import load_car

    car = None if args.car_fmu else load_car(args.car or "quarter-car")  # its tracks, too
    check_settings(settings, bodies=2 if want_iso else 1, car=car)  # before building
    _check_step(args, want_iso)
    if args.csv:
        _check_disk(args.csv, (args.duration / args.step + 1) * (2 if want_iso else 1))
    controller = _controller(args)  # refused before building
    body, iso, car, tmp = _fmus(args, want_iso)
    try:
        bodies = {_label(body, "body"): body}
        if want_iso:
            iso_label = _label(iso, "iso")
            if iso_label in bodies:
                iso_label += "-iso"
            bodies[iso_label] = iso
        csv = StudyCsv(args.csv, list(bodies)) if args.csv else None
        try:
            study = run_study(
                bodies,
                car,
                settings,
                extrapolate=not args.hold,
                progress=not args.quiet,
                csv=csv,
                controller=controller,
                linear_of=_nonlinear_car(args),
            )
            comparison = compare(study, *bodies) if want_iso else None
            vehicle = _vehicle(args, controller)
            print(in_flags(format_report(study, comparison, vehicle), ("pareto_front", "linear")))
            write_outputs(
                [
                    (
                        args.json,
                        lambda path: write_json(path, study_json(study, comparison, vehicle)),
                    ),
                    (args.plot, lambda path: plot_study(study, path, comparison)),
                    # streamed during the run, staged with the others
                    (args.csv, lambda path: csv.place()),
                ]
            )
        finally:
            if csv is not None:
                csv.discard()  # no-op once placed
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)
    if comparison is not None and args.strict and comparison.verdict != "PASS":
        return 1
    return 0


def _common(p):
    p.add_argument(
        "--road",
        default="C",
        help="ISO 8608 class A-H, 'bump', 'sweep', a bump shape with its dimensions in m "
        "(hump, table, sine, halfsine, pothole, e.g. hump:h=0.075,l=3.7,at=10) or a road "
        "file: OpenCRG .crg, CSV .csv or text .txt columns (distance_m,elevation_mm) or ERD "
        ".erd (default C)",
    )
    add_road_options(p)
    add_run_options(p)
    p.add_argument(
        "--body",
        metavar="FMU",
        help="body FMU with the body interface of the FMU contract (default: HumanBody3DOF "
        "built from --params)",
    )
    p.add_argument(
        "--params",
        metavar="FILE",
        help="body parameter file baked into the default HumanBody3DOF.fmu "
        "(default: the paper's Table 2)",
    )
    p.add_argument(
        "--car",
        metavar="MODEL",
        help="vehicle model for the car FMU built for the run: 'quarter-car', "
        "'quarter-car-cushion', 'half-car' (built as HalfCar.fmu) or a parameter file "
        "(default quarter-car)",
    )
    add_seat_option(p, "the car FMU built for the run")
    p.add_argument("--car-fmu", metavar="FMU", help="a car FMU instead of building QuarterCar.fmu")
    p.add_argument(
        "--native",
        action="store_true",
        help="build the native C FMUs for the run instead of the pythonfmu ones "
        "(FMUs given with --body/--car-fmu/--iso-body are used as they are)",
    )
    p.add_argument(
        "--control",
        metavar="LAW",
        help="drive the car's actuators (a car with actuators: quarter-car-active, "
        "half-car-active, full-car-active): skyhook, groundhook or hybrid, with options "
        "after ':' "
        "c=<N s/m> (skyhook gain; default the body's critical damping on the suspension "
        "springs), g=<N s/m> (groundhook gain; default the passive suspension damper's "
        "coefficient), semi (on-off semi-active clipping); e.g. skyhook:c=3000",
    )
    p.add_argument(
        "--control-fmu",
        metavar="FMU",
        help="drive the car's actuators by a controller FMU (FMI 2.0 co-simulation with "
        "inputs upper_velocity, lower_velocity and output actuator_force per actuator: "
        "SkyhookController.fmu from bodyvib build --control)",
    )
    p.add_argument(
        "--linear",
        action="store_true",
        help="run the car linearized about static equilibrium (a tire that never leaves "
        "the road, no suspension stops: the linear car of earlier releases)",
    )
    p.add_argument(
        "--hold",
        action="store_true",
        help="plain master: hold the seat force over each step (first order)",
    )
    add_output_options(
        p,
        plot="write the plot",
        csv="write the time histories as CSV",
        json="write the figures as JSON",
    )
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")


def add_command(subparsers):
    """Register ``bodyvib cosim`` and ``bodyvib check``."""
    p = subparsers.add_parser(
        "cosim",
        help="a car co-simulated with a body FMU over a road (ISO 2631-1 figures)",
        description="Drive a car FMU (the quarter car by default; --car half-car, a car with a "
        "seat or with actuators) over a road with a body FMU (fmpy, two-way "
        "coupled), report the head acceleration's ISO 2631-1 figures and the coupling error "
        "against the monolithic reference.",
    )
    _common(p)
    p.set_defaults(func=lambda a: _run(a, want_iso=False), iso_body=None, strict=False)

    c = subparsers.add_parser(
        "check",
        help="head acceleration of the reduced body against the ISO 7962 body",
        description="Co-simulate the same road and car with the reduced body and the ISO 7962 "
        "body; compare head-acceleration figures, time histories and transmissibility against "
        "the documented tolerances and print the verdict.",
    )
    _common(c)
    c.add_argument(
        "--iso-body",
        metavar="FMU",
        help="ISO body FMU (default: HumanBodyISO7962 built from iso7962)",
    )
    c.add_argument("--strict", action="store_true", help="exit with status 1 on a FAIL verdict")
    c.set_defaults(func=lambda a: _run(a, want_iso=True))
    return p
