"""Plots of a sweep: comfort maps over speed and road, and bump studies over speed.

:func:`plot_sweep` picks the plot a table asks for: :func:`plot_bump_study` when every
road is a bump shape (``hump:h=0.075,l=3.7``), :func:`plot_comfort_maps` otherwise.
"""

from typing import Optional

import numpy as np

from bodyvib.comfort.figures import COMFORT_SCALE
from bodyvib.runtime.errors import BodyvibError

__all__ = ["plot_comfort_maps", "plot_bump_study", "plot_sweep", "BUMP_PANELS"]

#: The bump study's panels: column and axis label.
BUMP_PANELS = (
    ("head_peak", "head peak weighted acceleration [m/s2]"),
    ("head_vdv", "head VDV [m/s^1.75]"),
    ("neck_force_peak", "neck force peak |F| [N]"),
    ("lumbar_force_peak", "lumbar force peak |F| [N]"),
)

_BAND_COLOURS = ("#2ca02c", "#9acd32", "#ffd700", "#ff8c00", "#e34a33", "#b30000")


def plot_comfort_maps(df, path, figure: str = "head_weighted_rms", title: Optional[str] = None):
    """One panel per body (and car): weighted r.m.s. against speed, one line per road.

    Where a panel holds several cases per road and speed (seeds, parameter
    sets), the line is their median and the shaded band their 5-95 % range.
    Behind the lines: the comfort bands of ISO 2631-1 Annex C
    (:data:`bodyvib.comfort.figures.COMFORT_SCALE`; the standard's bands overlap, and
    so do the shadings).

    Parameters
    ----------
    df : pandas.DataFrame
        A sweep table (:func:`bodyvib.vehicle.sweep.run.run_sweep`).
    path : str
        Plot file (.png, .pdf or .svg).
    figure : str
        Column plotted (``head_weighted_rms`` or ``seat_weighted_rms``).
    title : str, optional
        The figure's title; by default ``ISO 2631-1 comfort map (<engines> engine)``.

    Raises
    ------
    BodyvibError
        No successful case, an unknown column, or a bad file extension.
    """
    from bodyvib.plotting import new_figure, save_figure

    if figure not in df.columns:
        raise BodyvibError(f"the sweep table has no column '{figure}'")
    ok = df[df["error"].isna() & np.isfinite(df[figure].astype(float))]
    if ok.empty:
        raise BodyvibError("no successful case to plot")
    panels = list(ok.groupby(["body", "car"], sort=False).groups)
    ncol = min(3, len(panels))
    nrow = int(np.ceil(len(panels) / ncol))
    fig, axes = new_figure(nrow, ncol, figsize=(5.2 * ncol, 4.2 * nrow), squeeze=False)
    top = max(2.5, float(ok[figure].max()) * 1.3)
    bottom = min(0.1, float(ok[figure].min()) / 1.3)
    for ax in axes.flat[len(panels) :]:
        ax.set_visible(False)
    for ax, (body, car) in zip(axes.flat, panels):
        for (lo, hi, words), colour in zip(COMFORT_SCALE, _BAND_COLOURS):
            ax.axhspan(max(lo, bottom), min(hi, top), color=colour, alpha=0.13, lw=0)
            ax.text(
                1.01,
                np.sqrt(max(lo, bottom) * min(hi, top)),
                words,
                fontsize=6,
                transform=ax.get_yaxis_transform(),
                va="center",
            )
        sel = ok[(ok["body"] == body) & (ok["car"] == car)]
        for road, g in sel.groupby("road", sort=True):
            stats = g.groupby("speed")[figure].quantile([0.05, 0.5, 0.95]).unstack()
            (line,) = ax.plot(stats.index, stats[0.5], "o-", ms=3, label=f"road {road}")
            if (g.groupby("speed").size() > 1).any():
                ax.fill_between(
                    stats.index, stats[0.05], stats[0.95], color=line.get_color(), alpha=0.25, lw=0
                )
        ax.set_yscale("log")
        ax.set_ylim(bottom, top)
        ax.set_xlabel("speed [m/s]")
        ax.set_ylabel(f"{figure.split('_')[0]} Wk r.m.s. [m/s2]")
        ax.set_title(f"{body} on {car}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    engines = ", ".join(sorted(set(ok["engine"])))
    fig.suptitle(title or f"ISO 2631-1 comfort map ({engines} engine)", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)


def _successful(df):
    return df[df["error"].isna()]


def plot_sweep(df, path, title: Optional[str] = None) -> None:
    """The plot of a sweep table: a bump study if every road is a bump shape, else comfort maps.

    Parameters
    ----------
    df : pandas.DataFrame
        A sweep table (:func:`bodyvib.vehicle.sweep.run.run_sweep`).
    path, title
        As the chosen plot takes them.

    Raises
    ------
    BodyvibError
        What the chosen plot refuses.
    """
    from ..road.bumps import is_bump_spec

    roads = set(_successful(df)["road"])
    if roads and all(is_bump_spec(r) for r in roads):
        plot_bump_study(df, path, title=title)
    else:
        plot_comfort_maps(df, path, title=title)


def _lift_offs(ok, others) -> dict:
    """Per curve (road, then the ``others`` columns' values) the lowest speed at which
    a case lifts a wheel (:func:`bodyvib.vehicle.sweep.summary.lift_off_speeds`)."""
    from .summary import lift_off_speeds

    if "lift_offs" not in ok:
        return {}
    out: dict = {}
    for (road, body, car), v in lift_off_speeds(ok).items():
        key = (road,) + tuple({"body": body, "car": car}[k] for k in others)
        if v is not None:
            out[key] = v if out.get(key) is None else min(out[key], v)
    return out


def plot_bump_study(df, path, title: Optional[str] = None) -> None:
    """A bump study: head peak, VDV and the neck and lumbar force peaks against speed.

    One panel per figure of :data:`BUMP_PANELS`, one curve per bump (a colour each) and,
    when the table has several, per body and car (a line style each); where a curve holds
    several cases per speed (parameter sets), it is their median. A vertical line in the
    curve's colour and style marks the speed from which that bump lifts a wheel off the
    road, named in the legend ("lift-off from 8 m/s").

    Parameters
    ----------
    df : pandas.DataFrame
        A sweep table whose roads are bump shapes.
    path : str
        Plot file (.png, .pdf or .svg).
    title : str, optional
        The figure's title; by default ``bump study (<engines> engine)``.

    Raises
    ------
    BodyvibError
        No successful case, or a bad file extension.
    """
    from bodyvib.plotting import new_figure, save_figure

    ok = _successful(df)
    if ok.empty:
        raise BodyvibError("no successful case to plot")
    others = [k for k in ("body", "car") if ok[k].nunique() > 1]
    roads = sorted(set(ok["road"]))
    kinds = sorted(set(map(tuple, ok[others].to_numpy()))) if others else [()]
    colours = {r: f"C{i % 10}" for i, r in enumerate(roads)}  # a colour per bump
    styles = {k: ("-", "--", ":", "-.")[i % 4] for i, k in enumerate(kinds)}  # a line per body
    lift = _lift_offs(ok, others)
    fig, axes = new_figure(2, 2, figsize=(10.4, 7.6), squeeze=False)
    for ax, (column, label) in zip(axes.flat, BUMP_PANELS):
        for group, g in ok.groupby(["road"] + others, sort=True):
            group = group if isinstance(group, tuple) else (group,)
            y = g.groupby("speed")[column].median()
            if np.all(np.isnan(y.to_numpy(dtype=float))):
                continue
            colour, style = colours[group[0]], styles[tuple(group[1:])]
            v = lift.get(group)
            words = f", lift-off from {v:g} m/s" if v is not None else ""
            ax.plot(
                y.index,
                y.to_numpy(dtype=float),
                marker="o",
                ms=3,
                color=colour,
                ls=style,
                label=", ".join(group) + words,
            )
            if v is not None:  # the speed from which the bump lifts a wheel
                ax.axvline(v, color=colour, ls=style, lw=0.8, alpha=0.6)
        ax.set_xlabel("speed [m/s]")
        ax.set_ylabel(label)
        ax.set_ylim(bottom=0)
        ax.grid(True, alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    engines = ", ".join(sorted(set(ok["engine"])))
    fig.suptitle(title or f"bump study ({engines} engine)", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)
