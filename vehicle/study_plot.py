"""The study plot: head acceleration side by side and seat-to-head transmissibility."""

from typing import Optional

import numpy as np

from bodyvib.plotting import stacked_panels

from .check import Comparison
from .cosim import model_from_fmu
from .signals import UNITS, axis_label
from .study import Study

__all__ = ["plot_study"]


def plot_study(study: Study, path, comparison: Optional[Comparison] = None, window_s: float = 5.0):
    """Head acceleration side by side (a window mid-run) and transmissibility estimates.

    The legend gives each body's weighted r.m.s. and the peaks of its neck and lumbar
    forces with their times (over the whole run).

    Parameters
    ----------
    study : Study
        From :func:`bodyvib.vehicle.study.run_study`.
    path : str or os.PathLike
        Plot file (.png, .pdf or .svg).
    comparison : Comparison, optional
        From :func:`bodyvib.vehicle.check.compare` (its verdict goes into the title).
    window_s : float
        Length of the time window shown, s, if the study kept none
        (it shows the window :func:`bodyvib.vehicle.study.run_study` kept).

    Raises
    ------
    BodyvibError
        An unsupported plot file extension.
    """
    from bodyvib.frequency.response import transmissibility
    from bodyvib.plotting import transmissibility_axes

    t = study.window_time  # the window the study kept (run_study's window_s)
    window_s = float(t[-1] - t[0]) if t.size > 1 else window_s
    unit = UNITS["head_acceleration"]
    with stacked_panels(path) as (ax1, ax2):
        for label, b in study.bodies.items():
            ax1.plot(
                t,
                b.head_window,
                lw=0.9,
                label=f"{label}: a_w = {b.figures.weighted_rms:.3f} {unit}" + _force_words(b),
            )
        ax1.set_xlabel(axis_label("time"))
        ax1.set_ylabel(axis_label("head_acceleration"))
        ax1.set_title(
            f"{study.road['name']}, {study.settings.speed:g} m/s: head acceleration "
            f"({window_s:g} s window)"
        )
        ax1.grid(True, alpha=0.3)
        ax1.legend(fontsize=8, loc="upper right")
        for label, b in study.bodies.items():
            T = b.transmissibility
            (line,) = ax2.plot(T.frequency_hz, T.modulus, label=f"{label} (estimated from run)")
            if b.model is not None:
                net = model_from_fmu(b.fmu)
                f = np.asarray(T.frequency_hz)
                ax2.plot(
                    f,
                    np.abs(transmissibility(net, f)),
                    "--",
                    color=line.get_color(),
                    lw=0.8,
                    label=f"{label} (model)",
                )
        title = (
            None
            if comparison is None
            else f"seat-to-head transmissibility; check verdict: {comparison.verdict}"
        )
        transmissibility_axes(ax2, ylabel="|T| head / seat [-]", title=title)
        ax2.legend(fontsize=8)


def _force_words(body) -> str:
    """``; neck peak 14.7 N at 3.03 s, ...`` for the forces a body run has (legend text)."""
    return "".join(
        f"; {name.split('_')[0]} peak {f.peak:.1f} N at {f.peak_time_s:.2f} s"
        for name, f in body.forces.items()
    )
