"""``bodyvib frf``: seat-to-head transmissibility of models side by side."""

from bodyvib.frf import DEFAULT_MODELS, compare_transmissibility, format_table, plot_transmissibility
from bodyvib.runtime.fileio import write_json

__all__ = ["add_command"]


def _run(args):
    result = compare_transmissibility(args.models, args.fmin, args.fmax, args.points)
    print(format_table(result))
    if args.json:
        write_json(args.json, result)
        print(f"wrote {args.json}")
    if args.plot:
        plot_transmissibility(result, args.plot)
        print(f"wrote {args.plot}")
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

