"""``bodyvib build`` (and ``python build_fmu.py``): build the project's FMUs into dist/."""

import os
import sys
from pathlib import Path

from bodyvib.process import interrupts
from bodyvib.process.outputs import check_outputs, staged_writes
from bodyvib.runtime.errors import BodyvibError
from bodyvib.vehicle.fmus import FMUS, ROAD_DEFAULTS, build_fmus
from bodyvib.vehicle.road.driven import is_road_file
from bodyvib.vehicle.road.measured import PROFILE_EXTENSIONS
from bodyvib.vehicle.ssp import PACKAGES, write_ssp
from bodyvib.vehicle.sweep.spec import ROAD_OPTION_KEYS

from .flags import in_flags
from .options import add_road_options, add_seat_option, road_options_from_args

__all__ = ["add_command", "main"]


def _run(args) -> int:
    """Every FMU asked for (pythonfmu, or with ``--native`` C for FMI 2.0 and 3.0) and, with
    all three components, the SSP of each FMI version: checked first, committed together."""
    inputs = [
        (option, path)
        for option, path in (("--params", args.params), ("--seat", args.seat))
        if path and os.path.isfile(path)
    ]
    if args.cross_check:
        return _cross_check(args, inputs)
    if args.control:
        return _active(args, inputs)
    if args.car:
        raise BodyvibError(
            "--car chooses the car of the active package: use it with --control LAW "
            "(the passive FMUs are built from quarter-car and half-car)"
        )
    names = list(args.fmus or FMUS)
    platforms = None
    if args.native:
        from bodyvib.fmu.native import choose_platforms

        choice = choose_platforms(args.platforms)  # refuses an unusable --platforms first
        platforms = choice.platforms
    dest = Path(args.dest) / "native" if args.native else Path(args.dest)
    label = "native/" if args.native else ""
    versions = ((2, ""), (3, "fmi3/")) if args.native else ((2, ""),)
    packages = [
        ssp_name
        for ssp_name, (components, _, _) in PACKAGES.items()
        if all(name in names for name in components.values())
    ]
    outs = [("--dest", args.dest, None, True)]
    for _, sub in versions:
        outs += [(f"--dest {label}{sub}{n}.fmu", str(dest / sub / f"{n}.fmu"), None) for n in names]
        for ssp_name in packages:
            outs.append(
                (f"--dest {label}{sub}{ssp_name}.ssp", str(dest / sub / f"{ssp_name}.ssp"), None)
            )
    check_outputs(outs, inputs)
    if args.native:
        for line in choice.skipped:
            print(in_flags(line, ("platforms",)), file=sys.stderr, flush=True)
    lines = []
    # the FMUs and the SSPs made of them are committed together or not at all: a full
    # disk at the SSP left new FMUs beside the old SSP
    with staged_writes(guard=interrupts.critical):
        built = build_fmus(
            dest,
            args.params,
            names=names,
            progress=lines.append,
            road=_road(args),
            native=args.native,
            platforms=platforms,
            seat=args.seat,
        )
        for ssp_name in packages:
            components = PACKAGES[ssp_name][0]
            for version, sub in versions:
                path = write_ssp(
                    dest / sub / f"{ssp_name}.ssp",
                    {comp: str(built[sub + name]) for comp, name in components.items()},
                    name=ssp_name,
                )
                kind = f"native, FMI {version}.0: " if args.native else ""
                lines.append(
                    f"wrote {path} ({kind}{components['Road']} -> {components['Car']} <-> "
                    f"{components['Body']}, parameter set, 1 ms step)"
                )
        interrupts.check()
    for line in lines:
        print(line)
    return 0


def _active(args, inputs) -> int:
    """``--control LAW``: the active package (road, active car, body, controller) in DEST/active."""
    from bodyvib.vehicle.control import parse_control
    from bodyvib.vehicle.fmus import car_fmu_name
    from bodyvib.vehicle.quarter_car import load_car
    from bodyvib.vehicle.ssp import ACTIVE_PACKAGES, PACKAGES, build_active_ssp

    if args.fmus or args.params:
        raise BodyvibError(
            "--control builds the active package's own FMUs (the reduced body, the active "
            "car, its road and the controller): drop --fmus and --params"
        )
    car = args.car or "quarter-car-active"
    controller = parse_control(args.control, load_car(car))  # refuses a car without actuators
    name = ACTIVE_PACKAGES[car_fmu_name(car)]
    road = _road(args)
    platforms = None
    if args.native or args.platforms:
        from bodyvib.fmu.native import choose_platforms

        platforms = choose_platforms(args.platforms).platforms
    dest = Path(args.dest) / ("native/active" if args.native else "active")
    outs = [("--dest", args.dest, None, True)]
    outs += [(f"--dest {n}.fmu", str(dest / f"{n}.fmu"), None) for n in PACKAGES[name][0].values()]
    outs.append((f"--dest {name}.ssp", str(dest / f"{name}.ssp"), None))
    if args.car and os.path.isfile(args.car):
        inputs = inputs + [("--car", args.car)]
    check_outputs(outs, inputs)
    build_active_ssp(
        dest,
        controller,
        road=road,
        native=args.native,
        platforms=platforms,
        progress=print,
        car=car,
    )
    return 0


def _cross_check(args, inputs) -> int:
    """``--cross-check DIR``: the native body FMU in the FMI cross-check layout."""
    from bodyvib.fmu.crosscheck import write_cross_check
    from bodyvib.models import load_model

    if args.fmus or args.native or args.platforms or args.seat or args.car:
        raise BodyvibError(
            "--cross-check builds the native FMI 2.0 HumanBody3DOF.fmu for linux64 (its "
            "model from --params); drop --fmus, --native, --platforms, --seat and --car"
        )
    check_outputs([("--cross-check", args.cross_check, None, True)], inputs)
    model = args.params or "reduced-paper"
    network = load_model(model)
    with staged_writes(guard=interrupts.critical):
        made = write_cross_check(args.cross_check, network, model)
        interrupts.check()
    print(
        f"wrote {made.folder}: {made.fmu.name}, {made.inputs.name}, {made.reference.name} "
        f"(exact), {made.options.name}, _cc.sh/_cc.bat, {made.readme.name}"
    )
    for twin in made.entries[1:]:
        print(f"wrote {twin}: the same files (the FMU is also a model-exchange FMU)")
    return 0


def _road(args) -> dict:
    """The road options of Road.fmu (pythonfmu or native), checked."""
    if args.road_length is not None and is_road_file(args.road):
        raise BodyvibError(
            "--road-length sets a synthetic road's length; Road.fmu tabulates a "
            "road file over its own length: drop --road-length"
        )
    opts = road_options_from_args(args)
    return {
        "road": args.road,
        "seed": args.road_seed,
        "length": ROAD_DEFAULTS["length"] if args.road_length is None else args.road_length,
        "speed": args.road_speed,
        **{field: getattr(opts, field) for field in ROAD_OPTION_KEYS},
    }


def _add_road_arguments(p):
    """The options of the road Road.fmu tabulates."""
    p.add_argument(
        "--road",
        default=ROAD_DEFAULTS["road"],
        help="Road.fmu: ISO 8608 class A-H, bump, sweep, a bump shape (hump:h=0.075,l=3.7; "
        "table, sine, halfsine, pothole) or a road file ("
        + ", ".join(PROFILE_EXTENSIONS)
        + ") (default: C)",
    )
    for flag, kind, default, metavar, text in (
        ("--road-seed", int, ROAD_DEFAULTS["seed"], "N", "seed of a random road (default: 0)"),
        (
            "--road-length",
            float,
            None,
            "M",
            "tabulated length in m (default: 601, 30 s at 20 m/s; a random road repeats after it)",
        ),
        (
            "--road-speed",
            float,
            ROAD_DEFAULTS["speed"],
            "V",
            "default of its speed parameter, m/s (default: 20)",
        ),
    ):
        p.add_argument(flag, type=kind, default=default, metavar=metavar, help="Road.fmu: " + text)


def add_command(subparsers):
    """Register ``bodyvib build``."""
    p = subparsers.add_parser(
        "build",
        help="build the FMUs (HumanBody3DOF, HumanBodyISO7962, QuarterCar, HalfCar, FullCar, "
        "Road, RoadFrontRear, RoadFourWheel) into dist/",
        description="Build HumanBody3DOF.fmu, HumanBodyISO7962.fmu, QuarterCar.fmu, HalfCar.fmu, "
        "FullCar.fmu, Road.fmu, RoadFrontRear.fmu and RoadFourWheel.fmu with pythonfmu and check "
        "them with fmpy validate, and the coupled systems of Road, QuarterCar and HumanBody3DOF "
        "as QuarterCarWithOccupant.ssp, of RoadFrontRear, HalfCar and HumanBody3DOF as "
        "HalfCarWithOccupant.ssp and of RoadFourWheel, FullCar and HumanBody3DOF as "
        "FullCarWithOccupant.ssp (SSP 1.0). "
        "--params bakes a parameter file into "
        "HumanBody3DOF.fmu (default: the paper's Table 2); --road, --road-seed and --road-length "
        "choose the road Road.fmu tabulates (and RoadFrontRear.fmu and RoadFourWheel.fmu: "
        "RoadFourWheel's left and right tracks are those of bodyvib cosim --car full-car).",
    )
    p.add_argument(
        "--params",
        metavar="FILE",
        help="parameter file for HumanBody3DOF.fmu (default: reduced-paper, the paper's Table 2)",
    )
    add_seat_option(p, "QuarterCar.fmu and HalfCar.fmu")
    p.add_argument("--dest", default="dist", help="output folder (default: dist)")
    p.add_argument(
        "--fmus",
        nargs="+",
        choices=list(FMUS),
        metavar="NAME",
        help=f"build only these ({', '.join(FMUS)})",
    )
    p.add_argument(
        "--native",
        action="store_true",
        help="build the native C FMUs instead (FMI 2.0 into DEST/native, FMI 3.0 "
        "into DEST/native/fmi3, each with its QuarterCarWithOccupant.ssp; binaries "
        "and sources; the host needs no Python)",
    )
    p.add_argument(
        "--platforms",
        metavar="LIST",
        help="with --native: binaries to compile, comma-separated among linux64, "
        "win64 (default: every platform whose compiler is on PATH; the others are "
        "reported as skipped)",
    )
    _add_road_arguments(p)
    p.add_argument(
        "--control",
        metavar="LAW",
        help="instead: the active package in DEST/active (DEST/native/active with --native): "
        "Road, QuarterCar from quarter-car-active, HumanBody3DOF, SkyhookController (native "
        "C) and ActiveQuarterCarWithOccupant.ssp wiring the controller between the car's "
        "actuator velocities and its actuator force; LAW as for cosim --control "
        "(skyhook, groundhook, hybrid; c=, g=, semi)",
    )
    p.add_argument(
        "--car",
        metavar="MODEL",
        help="with --control: the car with actuators, quarter-car-active (default), "
        "half-car-active (HalfCar and RoadFrontRear, a controller per axle, "
        "ActiveHalfCarWithOccupant.ssp), full-car-active (FullCar and RoadFourWheel, a "
        "controller per corner, ActiveFullCarWithOccupant.ssp) or a parameter file",
    )
    p.add_argument(
        "--cross-check",
        metavar="DIR",
        help="instead: write the native FMI 2.0 HumanBody3DOF.fmu into DIR in the FMI "
        "cross-check layout (fmus/2.0/cs/linux64/bodyvib/VERSION/HumanBody3DOF/ and the same "
        "under me/: the FMU, its _in.csv seat sine, the exact _ref.csv, _ref.opt, "
        "_cc.sh/.bat that rebuild the tree, and ReadMe.md)",
    )
    add_road_options(
        p,
        taper_help="Road.fmu: the road fades in from level over its first M "
        "metres and out over its last, as every run's road (default: 5; 0: none)",
    )
    p.set_defaults(func=_run)
    return p


def main(argv=None) -> int:
    """``python build_fmu.py [options]``: the same as ``bodyvib build [options]``."""
    from .main import main as cli_main

    return cli_main(["build"] + list(sys.argv[1:] if argv is None else argv))
