"""The ``bodyvib design`` command: tune car (and seat) parameters for the occupant."""

import shlex
import sys

from bodyvib.process import extras, interrupts
from bodyvib.process.outputs import check_output_path, staged_writes

__all__ = ["add_command"]


def _run(args):
    extras.require("bodyvib design", "fit", "sweep")
    from bodyvib.vehicle.design.optimize import design
    from bodyvib.vehicle.design.report import format_summary, write_design
    from bodyvib.vehicle.design.spec import load_spec

    check_output_path(args.out, "--out", inputs=[("SPEC", args.spec)], folder=True)
    spec = load_spec(args.spec, car=args.car)  # every check of the spec, before any search
    result = design(spec, verify=not args.no_verify)
    print(format_summary(result))
    command = " ".join(shlex.quote(a) for a in ["bodyvib", *sys.argv[1:]])
    with staged_writes(guard=interrupts.critical) as written:  # all files or none
        write_design(args.out, result, command=command)
        interrupts.check()
    for path in written.paths:
        print(f"wrote {path}")
    return 0


def add_command(subparsers):
    """Register ``bodyvib design``."""
    p = subparsers.add_parser(
        "design",
        help="tune car and seat parameters for the occupant on random roads (Pareto front)",
        description="Choose car (and seat) parameters within bounds to minimize occupant "
        "objectives (head or seat Wk r.m.s., body forces) against or subject to vehicle "
        "objectives (tire load ratio, suspension travel against the rattle space) over "
        "ISO 8608 roads and speeds, by exact random-response evaluation; the chosen "
        "designs are verified by time-domain runs. SPEC is a JSON file (see the "
        "design guide).",
    )
    p.add_argument("spec", metavar="SPEC", help="design specification (JSON)")
    p.add_argument(
        "--out",
        default="design",
        metavar="DIR",
        help="folder for the front (CSV, Parquet, plot), the summary and the chosen "
        "designs' car files (default: design)",
    )
    p.add_argument(
        "--car",
        metavar="CAR",
        help="the car to tune in place of the spec's 'car' (shipped name, e.g. full-car, "
        "or parameter file); the spec's parameters must be its own",
    )
    p.add_argument(
        "--no-verify",
        action="store_true",
        help="skip the time-domain runs of the chosen designs",
    )
    p.set_defaults(func=_run)
    return p
