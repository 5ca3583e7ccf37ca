"""``bodyvib frf``: seat-to-head transmissibility of models side by side."""

import os

from bodyvib.frequency.compare import DEFAULT_MODELS, compare_transmissibility, format_table, plot_transmissibility
from bodyvib.process import interrupts
from bodyvib.process.outputs import check_outputs, staged_writes, write_json

from .outputs import JSON_EXTENSIONS, PLOT_EXTENSIONS

__all__ = ["add_command"]


def _run(args):
    check_outputs([("--json", args.json, JSON_EXTENSIONS), ("--plot", args.plot, PLOT_EXTENSIONS)],
                  inputs=[("--models", m) for m in args.models if os.path.isfile(m)])
    result = compare_transmissibility(args.models, args.fmin, args.fmax, args.points)
    print(format_table(result))
    with staged_writes(guard=interrupts.critical) as written:  # all outputs or none
        if args.json:
            write_json(args.json, result.to_dict())
        if args.plot:
            plot_transmissibility(result, args.plot)
        interrupts.check()  # Ctrl-C while rendering: discard, keep the old files
    for path in written.paths:
        print(f"wrote {path}")
    return 0


def add_command(subparsers):
    """Register ``bodyvib frf``."""
    p = subparsers.add_parser(
        "frf",
        help="seat-to-head transmissibility of models (table, JSON, plot)",
        description="Seat-to-head transmissibility (modulus and phase) of body models "
        "over 0.5-31.5 Hz, with each model's peaks.",
    )
    p.add_argument("--models", nargs="+", default=list(DEFAULT_MODELS), metavar="MODEL",
                   help="shipped model names or parameter-file paths (default: %(default)s)")
    p.add_argument("--fmin", type=float, default=0.5, help="lowest frequency, Hz (default 0.5)")
    p.add_argument("--fmax", type=float, default=31.5, help="highest frequency, Hz (default 31.5)")
    p.add_argument("--points", type=int, default=1200, help="grid points (default 1200)")
    p.add_argument("--plot", metavar="FILE.png", help="write the comparison plot")
    p.add_argument("--json", metavar="FILE", help="write the curves and peaks as JSON")
    p.set_defaults(func=_run)
    return p

