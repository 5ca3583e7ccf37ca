"""``bodyvib frf``: seat-to-head transmissibility of models side by side, or with ``--seat``
the floor-to-pan and floor-to-head transmissibility of a seat with each model on it."""

import os

from bodyvib.frequency.compare import (
    DEFAULT_MODELS,
    compare_transmissibility,
    format_table,
    plot_transmissibility,
)
from bodyvib.runtime.errors import BodyvibError

from .options import add_models_option, add_output_options, model_inputs
from .outputs import check_files, write_result

__all__ = ["add_command"]


def _run(args):
    if args.car and not args.seat:
        raise BodyvibError("--car is the car of a seat's SEAT value: give it with --seat")
    inputs = model_inputs(args.models)
    inputs += [(o, p) for o, p in (("--seat", args.seat), ("--car", args.car)) if p]
    inputs = [(o, p) for o, p in inputs if os.path.isfile(p)]
    check_files(args, ("json", "plot"), inputs=inputs)
    if args.seat:
        from bodyvib.vehicle.seat_response import seat_transmissibility
        from bodyvib.vehicle.seats import load_seat

        seat = load_seat(args.seat)
        result = seat_transmissibility(
            seat, args.models, args.fmin, args.fmax, args.points, car=args.car or "quarter-car"
        )
        title = f"Seat transmissibility: {seat.name} seat, floor to pan and to head"
        ylabel = "|X_pan / X_floor|, |X_head / X_floor| [-]"
    else:
        result = compare_transmissibility(args.models, args.fmin, args.fmax, args.points)
        title, ylabel = "Seat-to-head transmissibility", None
    print(format_table(result))
    if args.seat:
        print(result.summary())
    write_result(
        args, result, lambda r, path: plot_transmissibility(r, path, title=title, ylabel=ylabel)
    )
    return 0


def add_command(subparsers):
    """Register ``bodyvib frf``."""
    p = subparsers.add_parser(
        "frf",
        help="seat-to-head transmissibility of models, or a seat's (table, JSON, plot)",
        description="Seat-to-head transmissibility (modulus and phase) of body models "
        "over 0.5-31.5 Hz, with each model's peaks; with --seat, the floor-to-pan and "
        "floor-to-head transmissibility of that seat with each model sitting on it (the "
        "pan curve's peak is the seat's resonance).",
    )
    add_models_option(p, DEFAULT_MODELS)
    p.add_argument(
        "--seat",
        metavar="SEAT",
        help="a seat ('cushion', 'suspension' or a seat file): its transmissibility from "
        "the floor, with each --models body on it",
    )
    p.add_argument(
        "--car",
        metavar="MODEL",
        help="with --seat: the car (driven at one road point) of the SEAT value, the seat "
        "on its seat point (default quarter-car)",
    )
    p.add_argument("--fmin", type=float, default=0.5, help="lowest frequency, Hz (default 0.5)")
    p.add_argument("--fmax", type=float, default=31.5, help="highest frequency, Hz (default 31.5)")
    p.add_argument("--points", type=int, default=1200, help="grid points (default 1200)")
    add_output_options(
        p, plot="write the comparison plot", json="write the curves and peaks as JSON"
    )
    p.set_defaults(func=_run)
    return p
