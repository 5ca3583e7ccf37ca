"""``bodyvib build`` (and ``python build_fmu.py``): build the project's FMUs into dist/."""

import sys
from pathlib import Path

from vehicle.fmus import FMUS, build_fmus

__all__ = ["add_command", "main"]


def _run(args) -> int:
    if args.native:
        build_fmus(Path(args.dest) / "native", args.params, names=args.fmus, echo=print,
                   native=True)
        return 0
    build_fmus(args.dest, args.params, names=args.fmus, echo=print)
    return 0


def add_command(subparsers):
    """Register ``bodyvib build``."""
    p = subparsers.add_parser(
        "build", help="build the FMUs (HumanBody3DOF, HumanBodyISO7962, QuarterCar) into dist/",
        description="Build HumanBody3DOF.fmu, HumanBodyISO7962.fmu and QuarterCar.fmu with "
        "pythonfmu and check them with fmpy validate. --params bakes a parameter file into "
        "HumanBody3DOF.fmu (default: the paper's Table 2).",
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
    p.set_defaults(func=_run)
    return p


def main(argv=None) -> int:
    """``python build_fmu.py [options]``: the same as ``bodyvib build [options]``."""
    from .main import main as cli_main

    return cli_main(["build"] + list(sys.argv[1:] if argv is None else argv))
