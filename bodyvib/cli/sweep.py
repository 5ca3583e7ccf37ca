"""The ``bodyvib sweep`` command: many cases from a spec or a grid, one table."""

import sys

from bodyvib.process import extras
from bodyvib.process.outputs import check_outputs
from bodyvib.runtime.errors import BodyvibError

from .flags import in_flags
from .options import add_output_options, add_road_options, road_options_from_args
from .outputs import PLOT_EXTENSIONS, check_files

__all__ = ["add_command"]


def _run(args):
    extras.require("bodyvib sweep", "sweep")
    from bodyvib.vehicle.sweep.run import PARQUET_EXTENSIONS
    from bodyvib.vehicle.sweep.spec import ROAD_OPTION_KEYS, grid_spec

    if args.spec and args.grid:
        raise BodyvibError("give a SPEC file or --grid, not both")
    if not args.spec and not args.grid:
        if args.plot and args.out:  # plot an existing table
            from bodyvib.vehicle.sweep.plot import plot_sweep
            from bodyvib.vehicle.sweep.run import read_results

            check_files(args, ("plot",))  # before the table is read
            df = read_results(args.out)
            if df is None:
                raise BodyvibError(f"no sweep table at '{args.out}'")
            plot_sweep(df, args.plot)
            print(f"wrote {args.plot}")
            return 0
        raise BodyvibError(
            "give a SPEC file or --grid key=v1,v2 ... (or --out TABLE --plot FILE "
            "to plot a finished sweep)"
        )
    if not args.out and not args.csv:
        raise BodyvibError("give --out FILE.parquet (and/or --csv FILE) for the results")
    if args.scheduler and args.scheduler_file:
        raise BodyvibError("give --scheduler or --scheduler-file, not both")
    # every output checked before any work, against each other and the inputs
    check_outputs(
        [
            ("--out", args.out, PARQUET_EXTENSIONS),
            ("--csv", args.csv, None),
            ("--plot", args.plot, PLOT_EXTENSIONS),
        ],
        [("SPEC", args.spec)] if args.spec else [],
    )
    from bodyvib.vehicle.road.driven import RoadOptions

    opts = road_options_from_args(args)
    if args.spec and opts != RoadOptions():
        raise BodyvibError(
            "--road-* options go with --grid; a SPEC file gives them as "
            '"road_options": {"taper_m": 5, "track_m": 0.8, ...}'
        )
    given = {
        f: getattr(opts, f)
        for f in ROAD_OPTION_KEYS
        if getattr(opts, f) != getattr(RoadOptions(), f)
    }
    spec = args.spec if args.spec else grid_spec(args.grid, args.duration, args.step, given)
    from bodyvib.vehicle.sweep.run import SweepSettings, run_sweep

    settings = SweepSettings(
        out=args.out,
        engine=args.engine,
        scheduler=args.scheduler,
        scheduler_file=args.scheduler_file,
        workers=args.workers,
        block=args.block,
        resume=args.resume,
        retry_failed=args.retry_failed,
        overwrite=args.overwrite,
        csv=args.csv,
        progress=False if args.quiet else _status,
        connect_timeout=args.connect_timeout,
        worker_timeout=args.worker_timeout,
        table=bool(args.plot),
    )
    df = run_sweep(spec, settings)
    for f in (args.out, args.csv):
        if f:
            print(f"wrote {f}")
    if args.plot:
        from bodyvib.vehicle.sweep.plot import plot_sweep

        plot_sweep(df, args.plot)
        print(f"wrote {args.plot}")
    from bodyvib.vehicle.sweep.summary import format_summary, summary_columns

    print(format_summary(df if df is not None else summary_columns(args.out or args.csv)))
    return 0


def _seconds(text):
    import argparse
    import math

    try:
        v = float(text)
    except ValueError:
        v = 0.0
    if not (0 < v < math.inf):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text!r}")
    return v


def _positive_int(text):
    import argparse

    try:
        v = int(text)
    except ValueError:
        v = 0
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return v


def _status(line: str) -> None:
    """A sweep's status line on stderr, its settings named as flags."""
    print(in_flags(line, ("resume", "retry_failed", "out")), file=sys.stderr, flush=True)


def add_command(subparsers):
    """Register ``bodyvib sweep``."""
    p = subparsers.add_parser(
        "sweep",
        help="comfort over roads, speeds, bodies and cars (one table per sweep)",
        description="Run every case of a sweep spec (or a --grid) and write one row per case: "
        "inputs, the head's ISO 2631-1 figures, the seat's Wk r.m.s., engine and provenance. "
        "Cases run on Dask (a LocalCluster by default); finished blocks are written at once, "
        "so a killed sweep continues with --resume.",
    )
    p.add_argument("spec", nargs="?", metavar="SPEC.json", help="sweep spec (JSON)")
    p.add_argument(
        "--grid",
        nargs="+",
        metavar="KEY=V1,V2",
        help="a grid instead of a spec: road=C,D,profile.crg speed=10,20 seed=0,1 "
        "body=reduced-paper,iso7962 car=quarter-car seat=none,suspension",
    )
    p.add_argument("--duration", type=float, default=30.0, help="with --grid: run length, s (30)")
    p.add_argument("--step", type=float, default=1e-3, help="with --grid: time step, s (0.001)")
    add_road_options(p)
    p.add_argument("--out", metavar="FILE.parquet", help="results table (Parquet)")
    p.add_argument("--csv", metavar="FILE", help="the table as CSV too")
    p.add_argument(
        "--engine",
        choices=("batched", "spectral", "cosim"),
        default="batched",
        help="batched exact simulation (default), spectral expectation from the road "
        "PSD (r.m.s. only), or FMU co-simulation",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="Dask scheduler address (tcp://host:8786); default: a LocalCluster, one "
        "worker per core; 'serial' runs in this process",
    )
    p.add_argument(
        "--scheduler-file",
        metavar="FILE",
        help="connect to the scheduler of this file (dask scheduler --scheduler-file, "
        "dask-jobqueue)",
    )
    p.add_argument(
        "--connect-timeout",
        type=_seconds,
        default=10.0,
        metavar="S",
        help="seconds to wait for the scheduler to answer (10)",
    )
    p.add_argument(
        "--worker-timeout",
        type=_seconds,
        default=60.0,
        metavar="S",
        help="seconds to wait for a first worker; a running sweep with no worker for "
        "this long stops, resumable (60)",
    )
    p.add_argument("--workers", type=_positive_int, help="LocalCluster workers (default: cores)")
    p.add_argument("--block", type=_positive_int, help="cases per task (default: by engine)")
    p.add_argument(
        "--resume", action="store_true", help="keep the cases already in --out, run the rest"
    )
    p.add_argument(
        "--retry-failed",
        action="store_true",
        help="with --resume: run again the cases stored with an error",
    )
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    add_output_options(
        p,
        plot="comfort maps with the ISO 2631-1 bands (for bump roads: head peak, VDV and "
        "neck and lumbar force peaks against speed, one curve per bump)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=_run)
    return p
