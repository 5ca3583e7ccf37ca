"""``bodyvib frf``: seat-to-head transmissibility of models side by side."""

from bodyvib.frequency.compare import (
    DEFAULT_MODELS,
    compare_transmissibility,
    format_table,
    plot_transmissibility,
)

from .options import add_models_option, add_output_options, model_inputs
from .outputs import check_files, write_result

__all__ = ["add_command"]


def _run(args):
    check_files(args, ("json", "plot"), inputs=model_inputs(args.models))
    result = compare_transmissibility(args.models, args.fmin, args.fmax, args.points)
    print(format_table(result))
    write_result(args, result, plot_transmissibility)
    return 0


def add_command(subparsers):
    """Register ``bodyvib frf``."""
    p = subparsers.add_parser(
        "frf",
        help="seat-to-head transmissibility of models (table, JSON, plot)",
        description="Seat-to-head transmissibility (modulus and phase) of body models "
        "over 0.5-31.5 Hz, with each model's peaks.",
    )
    add_models_option(p, DEFAULT_MODELS)
    p.add_argument("--fmin", type=float, default=0.5, help="lowest frequency, Hz (default 0.5)")
    p.add_argument("--fmax", type=float, default=31.5, help="highest frequency, Hz (default 31.5)")
    p.add_argument("--points", type=int, default=1200, help="grid points (default 1200)")
    add_output_options(
        p, plot="write the comparison plot", json="write the curves and peaks as JSON"
    )
    p.set_defaults(func=_run)
    return p
