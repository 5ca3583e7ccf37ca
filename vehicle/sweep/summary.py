"""A sweep's table in a few lines: what ran, what failed, how the cars were stepped, the
range of the head's comfort.

``bodyvib sweep`` prints :func:`format_summary` at the end, so that a run read in a log
says what it found without opening the table. :func:`summary_columns` reads only the
columns it needs back from the written table (a sweep of many cases keeps no table in
memory).
"""

import os

import numpy as np

__all__ = ["SUMMARY_COLUMNS", "format_summary", "summary_columns"]

#: The columns :func:`format_summary` reads.
SUMMARY_COLUMNS = (
    "case_id",
    "road",
    "speed",
    "body",
    "car",
    "head_weighted_rms",
    "head_comfort",
    "engine",
    "stepping",
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
        :data:`SUMMARY_COLUMNS`, one row per case.
    """
    import pandas as pd

    if os.path.splitext(path)[1].lower() in (".parquet", ".pq"):
        return pd.read_parquet(path, columns=list(SUMMARY_COLUMNS))
    # a CSV's headers carry their units ("speed [m/s]"): the name is before the bracket
    df = pd.read_csv(
        path, usecols=lambda c: c.split(" [")[0] in SUMMARY_COLUMNS, keep_default_na=False
    )
    return df.rename(columns=lambda c: c.split(" [")[0])[list(SUMMARY_COLUMNS)]


def _case(row) -> str:
    return (
        f"road {row['road']}, {row['speed']:g} m/s, body {row['body']}, car {row['car']} "
        f"(case {int(row['case_id'])})"
    )


def format_summary(df) -> str:
    """The summary of a sweep table: cases and failures, the head's Wk r.m.s. range with the
    cases at its ends, the cases per ISO 2631-1 comfort band, and how many cases were
    stepped linear, batched (a nonlinear car where nothing switched) or with events.

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
    if failed.any():
        first = df[failed].iloc[0]
        lines.append(f"first failure: {_case(first)}: {first['error']}")
    return "\n".join(lines)
