"""``bodyvib build`` (and ``python build_fmu.py``): build the project's FMUs into dist/."""

import os
import sys
from pathlib import Path

from bodyvib.process import interrupts
from bodyvib.process.outputs import check_outputs, staged_writes
from vehicle.fmus import FMUS, ROAD_DEFAULTS, build_fmus
from vehicle.ssp import COMPONENTS, SSP_NAME, write_ssp

__all__ = ["add_command", "main"]


def _run(args) -> int:
    inputs = [("--params", args.params)] if args.params and os.path.isfile(args.params) else []
    names = list(args.fmus or FMUS)
    if args.native:
        dest = Path(args.dest) / "native"
        names = [n for n in names if FMUS[n][0] != "source"]  # Road.fmu is pythonfmu only
        check_outputs([("--dest", args.dest, None, True)]
                      + [(f"--dest native/{n}.fmu", str(dest / f"{n}.fmu"), None) for n in names]
                      + [(f"--dest native/fmi3/{n}.fmu", str(dest / "fmi3" / f"{n}.fmu"), None)
                         for n in names], inputs)
        lines = []
        with staged_writes(guard=interrupts.critical):
            build_fmus(dest, args.params, names=names, echo=lines.append, native=True)
        for line in lines:
            print(line)
        return 0
    ssp = all(name in names for name in COMPONENTS.values())
    check_outputs([("--dest", args.dest, None, True)]
                  + [(f"--dest {n}.fmu", os.path.join(args.dest, f"{n}.fmu"), None) for n in names]
                  + ([(f"--dest {SSP_NAME}.ssp", os.path.join(args.dest, f"{SSP_NAME}.ssp"), None)]
                     if ssp else []), inputs)
    road = {"road": args.road, "seed": args.road_seed, "length": args.road_length,
            "speed": args.road_speed, "taper": args.road_taper}
    lines = []
    # the FMUs and the SSP made of them are committed together or not at all: a full
    # disk at the SSP left new FMUs beside the old SSP
    with staged_writes(guard=interrupts.critical):
        built = build_fmus(args.dest, args.params, names=args.fmus, echo=lines.append, road=road)
        if ssp:
            path = write_ssp(f"{args.dest}/{SSP_NAME}.ssp",
                             {comp: str(built[name]) for comp, name in COMPONENTS.items()})
            lines.append(f"wrote {path} (Road -> QuarterCar <-> HumanBody3DOF, parameter set, "
                         "1 ms step)")
        interrupts.check()
    for line in lines:
        print(line)
    return 0


def add_command(subparsers):
    """Register ``bodyvib build``."""
    p = subparsers.add_parser(
        "build", help="build the FMUs (HumanBody3DOF, HumanBodyISO7962, QuarterCar, Road) into dist/",
        description="Build HumanBody3DOF.fmu, HumanBodyISO7962.fmu, QuarterCar.fmu and Road.fmu "
        "with pythonfmu and check them with fmpy validate, and the coupled system of Road, "
        "QuarterCar and HumanBody3DOF as QuarterCarWithOccupant.ssp (SSP 1.0). --params bakes a parameter file into "
        "HumanBody3DOF.fmu (default: the paper's Table 2); --road, --road-seed and --road-length "
        "choose the road Road.fmu tabulates.",
    )
    p.add_argument("--params", metavar="FILE", help="parameter file for HumanBody3DOF.fmu "
                   "(default: reduced-paper, the paper's Table 2)")
    p.add_argument("--dest", default="dist", help="output folder (default: dist)")
    p.add_argument("--fmus", nargs="+", choices=list(FMUS), metavar="NAME",
                   help=f"build only these ({', '.join(FMUS)})")
    p.add_argument("--native", action="store_true",
                   help="build the native C FMUs instead (FMI 2.0 into DEST/native, FMI 3.0 "
                   "into DEST/native/fmi3; linux64 + win64 binaries and sources; the host "
                   "needs no Python)")
    p.add_argument("--road", default=ROAD_DEFAULTS["road"],
                   help="Road.fmu: ISO 8608 class A-H, bump or sweep (default: C)")
    p.add_argument("--road-seed", type=int, default=ROAD_DEFAULTS["seed"], metavar="N",
                   help="Road.fmu: seed of a random road (default: 0)")
    p.add_argument("--road-length", type=float, default=ROAD_DEFAULTS["length"], metavar="M",
                   help="Road.fmu: tabulated length in m (default: 601, 30 s at 20 m/s; a random "
                   "road repeats after it)")
    p.add_argument("--road-speed", type=float, default=ROAD_DEFAULTS["speed"], metavar="V",
                   help="Road.fmu: default of its speed parameter, m/s (default: 20)")
    p.add_argument("--road-taper", type=float, default=ROAD_DEFAULTS["taper"], metavar="M",
                   help="Road.fmu: a random road fades in from level over its first M metres and "
                   "out over its last (default: 5; 0: none)")
    p.set_defaults(func=_run)
    return p


def main(argv=None) -> int:
    """``python build_fmu.py [options]``: the same as ``bodyvib build [options]``."""
    from .main import main as cli_main

    return cli_main(["build"] + list(sys.argv[1:] if argv is None else argv))
