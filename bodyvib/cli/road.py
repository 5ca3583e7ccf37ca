"""``bodyvib road``: what a road is before it is driven (length, elevation, ISO 8608 class, IRI)."""

import os

from bodyvib.process import interrupts
from bodyvib.runtime.errors import BodyvibError

from .flags import in_flags
from .options import add_output_options
from .outputs import check_files, write_result

__all__ = ["add_command", "load_road"]


def load_road(
    source: str,
    length: float = 1000.0,
    spacing: float = 0.05,
    seed: int = 0,
    track=None,
    units=None,
):
    """``(distance, elevation, name)`` of a profile file or of a synthetic ISO 8608 class.

    Parameters
    ----------
    source : str
        A file (read by :func:`bodyvib.vehicle.road.measured.load_profile`) or a class
        ``A`` ... ``H`` (when no such file exists).
    length, spacing : float
        Extent and sample spacing of a synthetic road, m.
    seed : int
        Seed of a synthetic road.
    track : float, optional
        OpenCRG: lateral offset of the track from the reference line, m.
    units : str, optional
        Units of a file that does not name them: ``"DIST,ELEV"`` (``"m,mm"``), or the
        elevation's alone with the distance in m (``"mm"``).

    Returns
    -------
    distance, elevation : ndarray
        m.
    name : str

    Raises
    ------
    BodyvibError
        Neither a file nor a class; a file reader refusing the file.
    """
    import numpy as np

    from bodyvib.vehicle.road.synthetic import ISO8608_CLASSES, random_road

    s = str(source).strip()
    if not os.path.exists(s) and len(s) == 1 and s.upper() in ISO8608_CLASSES:
        for what, v in (("--length", length), ("--spacing", spacing)):
            if not (v > 0 and np.isfinite(v)):
                raise BodyvibError(f"{what} must be a positive number of metres, got {v!r}")
        x = np.arange(int(np.floor(length / spacing)) + 1) * spacing
        road = random_road(s.upper(), length=float(length) + spacing, seed=seed)
        return x, road.displacement(x), f"{road.name} (synthetic, seed {seed})"
    from bodyvib.vehicle.road.driven import is_road_file

    if not os.path.exists(s) and not is_road_file(s):  # a file's name: the reader says
        raise BodyvibError(f"'{s}' is neither a profile file nor an ISO 8608 class A-H")
    try:
        from bodyvib.vehicle.road.measured import load_profile
    except ImportError:
        raise BodyvibError(
            "reading profile files needs bodyvib.vehicle.road.measured, which this "
            "installation lacks; give an ISO 8608 class instead"
        ) from None
    if units is not None and "," not in str(units):
        units = f"m,{units}"
    kwargs = {k: v for k, v in (("track_m", track), ("units", units)) if v is not None}
    from bodyvib.process.extras import MissingExtraError

    try:
        profile = load_profile(s, **kwargs)
    except MissingExtraError:
        raise  # its own words name the extra
    except BodyvibError as exc:  # this command's flags are --track and --units
        flags = {"track_m": "--track", "units": "--units"}
        raise BodyvibError(in_flags(str(exc), exc.parameters, flags)) from None
    return (
        np.asarray(profile.distance, float),
        np.asarray(profile.elevation, float),
        getattr(profile, "name", os.path.basename(s)),
    )


def _run(args):
    from bodyvib.vehicle.road.summary import (
        TrackSummaries,
        format_summary,
        plot_summary,
        summarize_profile,
    )

    check_files(
        args, ("json", "plot"), inputs=[("ROAD", args.road)] if os.path.isfile(args.road) else []
    )
    if args.track and not str(args.road).strip().lower().endswith(".crg"):
        raise BodyvibError(
            f"--track applies to OpenCRG (.crg) surfaces; '{args.road}' holds one profile: "
            "drop --track"
        )
    tracks = args.track or [None]
    summaries = []
    for track in tracks:
        x, z, name = load_road(args.road, args.length, args.spacing, args.seed, track, args.units)
        interrupts.check()
        summaries.append(summarize_profile(x, z, name))
    if len(summaries) == 1:
        print(format_summary(summaries[0]))
        write_result(args, summaries[0], plot_summary)
    else:
        both = TrackSummaries(tuple(summaries))
        print(both.format())
        write_result(args, both, TrackSummaries.plot)
    return 0


def add_command(subparsers):
    """Register ``bodyvib road``."""
    p = subparsers.add_parser(
        "road",
        help="a road profile's length, elevation, ISO 8608 class and IRI (text, JSON, plot)",
        description="Describe a road before driving it: length, spacing, elevation "
        "statistics, the displacement PSD fitted with ISO 8608's line (Gd(n0), waviness) "
        "and its class, and the International Roughness Index (Golden Car at 80 km/h).",
    )
    p.add_argument(
        "road",
        metavar="FILE|CLASS",
        help="a profile file (CRG, CSV, TXT, ERD) or an ISO 8608 class A-H (synthetic)",
    )
    p.add_argument(
        "--length", type=float, default=1000.0, help="length of a synthetic road, m (default 1000)"
    )
    p.add_argument(
        "--spacing",
        type=float,
        default=0.05,
        help="sample spacing of a synthetic road, m (default 0.05)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of a synthetic road (default 0)")
    p.add_argument(
        "--track",
        type=float,
        nargs="+",
        default=None,
        metavar="M",
        help="lateral offset of the wheel track in a CRG file, m, positive to the left; "
        "several (--track 0.8 -0.8: both wheel paths) describe each",
    )
    p.add_argument(
        "--units",
        default=None,
        metavar="[DIST,]ELEV",
        help="units of a profile file that does not name them: distance and elevation "
        "(m,mm), or the elevation alone with distances in m (mm)",
    )
    add_output_options(
        p, plot="write the profile and PSD plot", json="write the summary (and the PSD) as JSON"
    )
    p.set_defaults(func=_run)
    return p
