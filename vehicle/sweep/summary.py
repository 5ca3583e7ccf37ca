"""A sweep's table in a few lines: what ran, what failed, how the cars were stepped, the
range of the head's comfort.

``bodyvib sweep`` prints :func:`format_summary` at the end, so that a run read in a log
says what it found without opening the table. :func:`summary_columns` reads only the
columns it needs back from the written table (a sweep of many cases keeps no table in
memory).
"""

import os

import numpy as np

__all__ = ["SUMMARY_COLUMNS", "format_summary", "summary_columns", "lift_off_speeds"]

#: The columns :func:`format_summary` reads.
SUMMARY_COLUMNS = (
    "case_id",
    "road",
    "speed",
    "body",
    "car",
    "head_weighted_rms",
    "head_comfort",
    "head_comfort_method",
    "engine",
    "stepping",
    "lift_offs",
    "tire_force_3sigma_ratio",
    "stop_travel_3sigma_ratio",
    "error",
)


def summary_columns(path: str):
    """The summary's columns of a written sweep table (Parquet or CSV).

    Parameters
    ----------
    path : str
        The sweep's ``--out`` (``.parquet``) or ``--csv`` file.

    Returns
    -------
    pandas.DataFrame
        :data:`SUMMARY_COLUMNS` (those the table has), one row per case.
    """
    import pandas as pd

    if os.path.splitext(path)[1].lower() in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        names = set(pq.read_schema(path).names)  # a table of an earlier release lacks some
        return pd.read_parquet(path, columns=[c for c in SUMMARY_COLUMNS if c in names])
    # a CSV's headers carry their units ("speed [m/s]"): the name is before the bracket
    df = pd.read_csv(
        path, usecols=lambda c: c.split(" [")[0] in SUMMARY_COLUMNS, keep_default_na=False
    )
    df = df.rename(columns=lambda c: c.split(" [")[0])
    return df[[c for c in SUMMARY_COLUMNS if c in df]]


def lift_off_speeds(df) -> dict:
    """The speed at which each bump first lifts a wheel, per bump, body and car.

    Parameters
    ----------
    df : pandas.DataFrame
        A sweep table (its ``road``, ``body``, ``car``, ``speed``, ``lift_offs`` and
        ``error`` columns).

    Returns
    -------
    dict of (str, str, str) to float or None
        ``(road, body, car)`` -> the lowest speed of the table at which a case of that
        group lifts a wheel off the road (m/s), None where none does (a linear run
        counts none: its ``lift_offs`` are NaN).

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"road": ["hump"] * 3, "body": ["b"] * 3, "car": ["c"] * 3,
    ...     "speed": [4.0, 8.0, 6.0], "lift_offs": [0.0, 2.0, 1.0], "error": [None] * 3})
    >>> lift_off_speeds(df)
    {('hump', 'b', 'c'): 6.0}
    """
    ok = df[df["error"].fillna("").astype(str) == ""]
    out = {}
    for key, g in ok.groupby(["road", "body", "car"], sort=True):
        lifted = g.loc[g["lift_offs"].astype(float) > 0, "speed"].astype(float)
        out[tuple(key)] = float(lifted.min()) if len(lifted) else None
    return out


def _lift_off_lines(df) -> list:
    """A bump study's lines: from which speed each bump lifts a wheel."""
    from ..road.bumps import is_bump_spec

    roads = set(df["road"].astype(str))
    if "lift_offs" not in df or not roads or not all(is_bump_spec(r) for r in roads):
        return []
    top = df["speed"].astype(float).max()
    lines = []
    for (road, body, car), v in lift_off_speeds(df).items():
        at = f"lift-off from {v:g} m/s" if v is not None else f"no lift-off up to {top:g} m/s"
        lines.append(f"  {road} ({body}, {car}): {at}")
    return ["wheel lift-off over the bumps:"] + lines if lines else []


def _case(row) -> str:
    return (
        f"road {row['road']}, {row['speed']:g} m/s, body {row['body']}, car {row['car']} "
        f"(case {int(row['case_id'])})"
    )


def format_summary(df) -> str:
    """The summary of a sweep table: cases and failures, the head's Wk r.m.s. range with the
    cases at its ends, the cases where ISO 2631-1's basic method is not sufficient
    (``head_comfort_method``, clause 6.3) ahead of the cases per comfort band, and how
    many cases were stepped linear, batched (a nonlinear car where nothing switched) or
    with events, and in a bump study the speed from which each bump lifts a wheel
    (:func:`lift_off_speeds`).

    Parameters
    ----------
    df : pandas.DataFrame
        A sweep table, or at least its :data:`SUMMARY_COLUMNS`.

    Returns
    -------
    str
        A few lines, without a trailing newline.

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"case_id": [0, 1], "road": ["C", "D"], "speed": [20.0, 20.0],
    ...     "body": ["reduced-paper"] * 2, "car": ["quarter-car"] * 2,
    ...     "head_weighted_rms": [1.1239, 2.2478], "engine": ["batched"] * 2,
    ...     "head_comfort": ["uncomfortable", "extremely uncomfortable"], "error": ["", ""],
    ...     "stepping": ["batched", "events"]})
    >>> print(format_summary(df))
    sweep: 2 cases, 2 computed, 0 failed (engine batched)
    head Wk r.m.s. [m/s2]: min 1.124, median 1.686, max 2.248
      min: road C, 20 m/s, body reduced-paper, car quarter-car (case 0)
      max: road D, 20 m/s, body reduced-paper, car quarter-car (case 1)
    comfort (ISO 2631-1 C): 1 uncomfortable, 1 extremely uncomfortable
    stepping: 1 batched (nothing switched), 1 run with events
    """
    failed = df["error"].fillna("").astype(str) != ""
    ok = df[~failed & np.isfinite(df["head_weighted_rms"].astype(float))]
    engines = ", ".join(sorted(set(df["engine"].astype(str))))
    lines = [
        f"sweep: {len(df)} cases, {len(ok)} computed, {int(failed.sum())} failed (engine {engines})"
    ]
    if len(ok):
        rms = ok["head_weighted_rms"].astype(float)
        lines.append(
            f"head Wk r.m.s. [m/s2]: min {rms.min():.4g}, median {rms.median():.4g}, "
            f"max {rms.max():.4g}"
        )
        lines.append(f"  min: {_case(ok.loc[rms.idxmin()])}")
        lines.append(f"  max: {_case(ok.loc[rms.idxmax()])}")
        lines += _method_lines(ok)
        lines += _range_lines(ok)
        bands = ok.groupby(ok["head_comfort"].astype(str))["head_weighted_rms"]
        order = bands.min().sort_values().index  # the bands from the mildest
        bands = ", ".join(f"{bands.size()[b]} {b}" for b in order)
        lines.append(f"comfort (ISO 2631-1 C): {bands}")
    if "stepping" in df:  # how many cases stayed batched, how many switched
        ways = df.loc[~failed, "stepping"].fillna("").astype(str).value_counts()
        words = {"batched": "batched (nothing switched)", "events": "run with events"}
        counts = [
            f"{ways[w]} {words.get(w, w)}" for w in ("linear", "batched", "events") if w in ways
        ]
        if counts:
            lines.append(f"stepping: {', '.join(counts)}")
    lines += _lift_off_lines(df)
    if failed.any():
        first = df[failed].iloc[0]
        lines.append(f"first failure: {_case(first)}: {first['error']}")
    return "\n".join(lines)


def _method_lines(ok) -> list:
    """The line of the cases whose basic method is not sufficient (none: no line)."""
    if "head_comfort_method" not in ok:
        return []
    methods = ok["head_comfort_method"].astype(str)
    other = methods[methods.isin(("vdv", "mtvv"))]
    if other.empty:
        return []
    counts = ", ".join(f"{n} {m}" for m, n in other.value_counts().sort_index().items())
    return [
        f"ISO 2631-1 6.3: the basic method is not sufficient in {len(other)} of {len(ok)} "
        f"cases ({counts} governs: head_comfort_method); their comfort words name the "
        "r.m.s. only"
    ]


def _range_lines(ok) -> list:
    """The line of the spectral cases whose linear car leaves its range (none: no line):
    three standard deviations of the dynamic tire force beyond the static load, or of the
    suspension travel beyond the stop gap (ratio above 1)."""
    cols = [c for c in ("tire_force_3sigma_ratio", "stop_travel_3sigma_ratio") if c in ok]
    if not cols:
        return []
    ratios = ok[cols].astype(float)
    out = ratios.gt(1.0)
    if not out.any(axis=None):
        return []
    tire, travel = (
        int(out[c].sum()) if c in out else 0
        for c in ("tire_force_3sigma_ratio", "stop_travel_3sigma_ratio")
    )
    return [
        f"linear range: {int(out.any(axis=1).sum())} of {len(ok)} cases leave it (3 sigma of "
        f"the tire force beyond the static load in {tire}, of the travel beyond the stops in "
        f"{travel}: *_3sigma_ratio > 1); their wheels would lift or hit the stops: run them "
        "with the batched engine"
    ]
