"""The files of a design: the front (CSV, Parquet), its plot, the chosen car files, a summary.

:func:`write_design` writes, into one folder:

* ``design_front.csv`` and ``design_front.parquet``: one row per design of the front
  (the tuned parameters, the objectives, each constraint's figure);
* ``design_front.png``: the objectives pairwise, the chosen designs marked;
* ``design-<label>.json``: each chosen design as a car parameter file, with its
  provenance (spec, method, predicted and verified figures), which ``bodyvib build
  --params``, ``cosim`` and ``sweep`` take as they are;
* ``design.json``: the summary (:meth:`~bodyvib.vehicle.design.optimize.DesignResult.to_dict`).
"""

import csv
import datetime
import io
import math
import os
from dataclasses import replace
from itertools import combinations
from typing import List

import numpy as np

from bodyvib import __version__
from bodyvib.models import save_model
from bodyvib.process import extras
from bodyvib.process.outputs import atomic_write_bytes, atomic_write_text, write_json
from bodyvib.runtime.renames import renamed_parameters

from ..quarter_car import load_car
from .optimize import DesignResult

__all__ = ["FILES", "front_table", "plot_front", "design_car", "write_design", "format_summary"]

#: Files of the front written by :func:`write_design` (besides one car file per chosen design).
FILES = ("design_front.csv", "design_front.parquet", "design_front.png", "design.json")


def _columns(result: DesignResult):
    s = result.spec
    names = list(result.parameter_names)
    cols = {n: result.values[:, j] for j, n in enumerate(names)}
    for j, o in enumerate(s.objectives):
        cols[o.name] = result.objectives[:, j]
    for j, (c, lim) in enumerate(s.constraints):
        cols[f"{c.name}_max"] = (result.constraints[:, j] + 1.0) * lim
    return cols


def front_table(result: DesignResult) -> str:
    """The front as CSV text: tuned parameters (SI), objectives, constraint figures."""
    cols = _columns(result)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(list(cols))
    for row in zip(*cols.values()):
        w.writerow([f"{x:.8g}" for x in row])
    return buf.getvalue()


def _parquet_bytes(result: DesignResult) -> bytes:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table({k: pa.array(np.asarray(v, dtype=float)) for k, v in _columns(result).items()})
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


def plot_front(result: DesignResult, path) -> None:
    """The objectives pairwise (one panel per pair), the chosen designs marked."""
    from bodyvib.plotting import new_figure, save_figure

    s = result.spec
    F = result.objectives
    k = F.shape[1]
    pairs = list(combinations(range(k), 2)) or [(0, 0)]
    fig, axes = new_figure(1, len(pairs), figsize=(5.5 * len(pairs), 4.5), squeeze=False)
    labels = {c.label: c for c in result.chosen}
    index = {c.label: i for i, c in enumerate(result.chosen)}
    for ax, (a, b) in zip(axes[0], pairs):
        if a == b:  # one objective: the value of the single design
            ax.plot([0], F[:, 0], "o")
            ax.set_ylabel(f"{s.objectives[0].name} [{s.objectives[0].unit}]")
            continue
        ax.plot(F[:, a], F[:, b], ".", color="0.4", label="Pareto front (NSGA-II)")
        for lab, c in labels.items():
            x, y = c.predicted[s.objectives[a].name], c.predicted[s.objectives[b].name]
            ax.plot(x, y, "o", ms=9, mfc="none", mew=2, color=f"C{index[lab]}", label=lab)
            if c.verified:
                vx, vy = c.verified[s.objectives[a].name], c.verified[s.objectives[b].name]
                ax.plot(vx, vy, "x", ms=7, color=f"C{index[lab]}")
        if result.baseline is not None:
            bp = result.baseline.predicted
            ax.plot(
                bp[s.objectives[a].name], bp[s.objectives[b].name], "ks", ms=7, label="baseline"
            )
        ax.set_xlabel(f"{s.objectives[a].name} [{s.objectives[a].unit}]")
        ax.set_ylabel(f"{s.objectives[b].name} [{s.objectives[b].unit}]")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, title="o evaluator, x time-domain run", title_fontsize=8)
    pts = ", ".join(f"{p.road} at {p.speed:g} m/s" for p in s.operating_points)
    fig.suptitle(f"Design front of '{s.car}' with '{s.body}' ({pts})", fontsize=10)
    save_figure(fig, path)


def design_car(result: DesignResult, label: str, command: str = ""):
    """A chosen design as a car network with its provenance.

    Parameters
    ----------
    result : DesignResult
    label : str
        One of the chosen designs' labels.
    command : str
        The command that made it (recorded).

    Returns
    -------
    Network
    """
    s = result.spec
    point = next(c for c in result.chosen if c.label == label)
    car = load_car(s.car).with_parameters(**point.values)
    date = datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat()
    prov = {
        "source": f"the '{label}' design of 'bodyvib design' (bodyvib.vehicle.design) from "
        f"the car '{car.name}', whose own source is: "
        + str(dict(car.provenance).get("source", "not stated")),
        "tuned": {b.name: [b.lo, b.hi, "log" if b.log else "linear"] for b in s.parameters},
        "body": s.body,
        "operating_points": [[p.road, p.speed, p.weight] for p in s.operating_points],
        "objectives": [o.name for o in s.objectives],
        "constraints": {c.name: lim for c, lim in s.constraints},
        "rattle_space_m": s.rattle_space,
        "method": s.search.method,
        "seed": s.search.seed,
        "predicted": point.predicted,
        "verified_time_domain": point.verified,
        "command": command,
        "date": date,
        "bodyvib_version": __version__,
    }
    vals = ", ".join(f"{k} {v:.5g}" for k, v in point.values.items())
    return replace(
        car,
        name=f"{car.name}-design-{label}",
        description=f"{car.description} Tuned by 'bodyvib design' ({label}): {vals}.",
        provenance=prov,
    )


@renamed_parameters(folder="dest")
def write_design(dest, result: DesignResult, command: str = "") -> List[str]:
    """Write the front, its plot, the summary and one car file per chosen design.

    Call inside :func:`bodyvib.process.outputs.staged_writes` for all-or-none.

    Parameters
    ----------
    dest : str or os.PathLike
        Created if missing (by the first file's write, so that a failed
        :func:`~bodyvib.process.outputs.staged_writes` block leaves no folder behind).
    result : DesignResult
    command : str

    Returns
    -------
    list of str
        The files written.

    Raises
    ------
    bodyvib.process.extras.MissingExtraError
        The sweep extra (its Parquet writer) is not installed.
    """
    extras.require("writing a design's front", "sweep")
    dest = os.fspath(dest)
    # no makedirs here: the atomic writers create the dest and, within staged_writes,
    # remove it again with the files if a write fails (a full disk left it empty)
    paths = [os.path.join(dest, f) for f in FILES]
    atomic_write_text(paths[0], front_table(result))
    atomic_write_bytes(paths[1], _parquet_bytes(result))
    plot_front(result, paths[2])
    write_json(paths[3], result.to_dict())
    for c in result.chosen:
        p = os.path.join(dest, f"design-{c.label}.json")
        save_model(design_car(result, c.label, command), p)
        paths.append(p)
    return paths


def _at_bound(b, v) -> str:
    """`` (at min)`` or `` (at max)`` for a value within 0.5 % of the bound's range of it."""
    u = (math.log(v / b.lo) / math.log(b.hi / b.lo)) if b.log else (v - b.lo) / (b.hi - b.lo)
    return " (at min)" if u < 0.005 else " (at max)" if u > 0.995 else ""


def format_summary(result: DesignResult) -> str:
    """Lines a user reads: the search, then each chosen design, evaluator and run side by side.

    Parameters
    ----------
    result : DesignResult

    Returns
    -------
    str
    """
    s = result.spec
    lines = [
        f"{s.search.method}: {len(result.values)} design(s) on the front, "
        f"{result.evaluations} evaluations in {result.elapsed_s:.1f} s; verification runs "
        f"{result.verify_s:.1f} s ({s.verify.duration:g} s per operating point)"
    ]
    bounds = {b.name: b for b in s.parameters}
    for c in result.chosen:
        vals = ", ".join(f"{k} {v:.5g}{_at_bound(bounds[k], v)}" for k, v in c.values.items())
        lines.append(f"{c.label}: {vals}")
        for name, pred in c.predicted.items():
            ver = c.verified.get(name)
            run = f", run {ver:.4g} ({ver / pred - 1:+.1%})" if ver is not None else ""
            lines.append(f"  {name:<22} evaluator {pred:.4g}{run}")
    if result.baseline is not None:
        b = result.baseline
        vals = ", ".join(f"{k} {v:.5g}" for k, v in b.values.items())
        figs = ", ".join(f"{k} {v:.4g}" for k, v in b.predicted.items())
        lines.append(f"baseline (the car file's values): {vals}: {figs}")
    return "\n".join(lines)
