"""What the three SSP host examples (libcosim, Ecos, fmpy) share: the signals they record,
the record's layout and their command line. Each example imports it from its own folder."""

import sys

import numpy as np

__all__ = ["DEFAULT_SSP", "SIGNALS", "record", "main"]

#: Where ``python build_fmu.py`` writes the SSP.
DEFAULT_SSP = "dist/QuarterCarWithOccupant.ssp"

#: (component, variable) recorded at every communication point.
SIGNALS = (
    ("Body", "head_acceleration"),
    ("Body", "seat_force"),
    ("Car", "seat_displacement"),
    ("Road", "road_displacement"),
)


def record(times, rows, signals=SIGNALS):
    """A host's samples as the examples return them.

    Parameters
    ----------
    times : sequence of float
        Communication points, s.
    rows : array_like, shape (len(times), len(signals))
        The signals' values at those points, one row per point.
    signals : sequence of (str, str)
        Component and variable of each column.

    Returns
    -------
    dict of str to ndarray
        ``time`` [s] and ``"<component>.<variable>"``.
    """
    out = {"time": np.asarray(times, float)}
    for (comp, var), col in zip(signals, np.asarray(rows, float).T):
        out[f"{comp}.{var}"] = col
    return out


def main(run, argv=None):
    """``python examples/ssp_from_HOST.py [SSP] [DURATION]``: run, print the head's r.m.s.

    Parameters
    ----------
    run : callable
        The example's ``run(ssp_path, duration)``.
    argv : list of str, optional
        The arguments (default ``sys.argv[1:]``): the SSP (default :data:`DEFAULT_SSP`) and
        the simulated time in s (default 30).
    """
    args = sys.argv[1:] if argv is None else list(argv)
    res = run(args[0] if args else DEFAULT_SSP, float(args[1]) if len(args) > 1 else 30.0)
    a = res["Body.head_acceleration"]
    print(
        f"{res['time'][-1]:g} s simulated; head acceleration r.m.s. "
        f"{np.sqrt(np.mean(a**2)):.4f} m/s2"
    )
