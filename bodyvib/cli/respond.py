"""``bodyvib respond``: a measured seat acceleration through body models; figures of seat and head."""

import io

import numpy as np

from bodyvib.process import interrupts
from bodyvib.runtime.errors import BodyvibError

from .options import add_models_option, add_output_options, model_inputs
from .outputs import check_files, write_result

__all__ = ["add_command", "format_response", "format_axes", "plot_response"]

_ROWS = (
    ("weighted_rms", "Wk r.m.s. [m/s2]", "{:.4f}"),
    ("vdv", "VDV [m/s^1.75]", "{:.4f}"),
    ("mtvv", "MTVV, 1 s running [m/s2]", "{:.4f}"),
    ("peak", "weighted peak [m/s2]", "{:.4f}"),
    ("crest_factor", "crest factor [-]", "{:.2f}"),
)


def format_response(result) -> str:
    """The table ``bodyvib respond`` prints: figures of seat and heads, the bodies' neck and
    lumbar forces (r.m.s., peak and its time, N and s), and the standard's checks.

    Parameters
    ----------
    result : bodyvib.seat.response.Response
        What :func:`bodyvib.seat.response.respond` gives.

    Returns
    -------
    str
    """
    from bodyvib.comfort import comfort_verdict

    s = result.signal
    cols = [("seat", result.seat_figures, result.seat_checks)] + [
        (f"head, {k}", b.figures, b.checks) for k, b in result.bodies.items()
    ]
    comfort = [comfort_verdict(c[1], s.duration)["comfort_words"] for c in cols]
    w = max(16, *(len(c[0]) + 2 for c in cols), *(len(x) + 2 for x in comfort))
    lines = [
        f"signal {s.name}: {s.acceleration.size} samples at {s.fs:.6g} Hz ({s.duration:.6g} s)",
        "",
        f"{'':<28}" + "".join(f"{c[0]:>{w}}" for c in cols),
    ]
    for key, words, fmt in _ROWS:
        lines.append(
            f"{words:<28}" + "".join(f"{fmt.format(getattr(c[1], key)):>{w}}" for c in cols)
        )
    lines.append(f"{'comfort (ISO 2631-1 C)':<28}" + "".join(f"{x:>{w}}" for x in comfort))
    if result.seat_msdv is not None:
        lines.append(f"{'seat MSDV (Wf) [m/s^1.5]':<28}{result.seat_msdv:>{w}.4f}")
        lines.append(f"{'seat Lee & Pradko power [W]':<28}{result.lee_pradko_power_w:>{w}.4f}")
    if result.spinal is not None:
        sp = result.spinal
        lines.append(f"{'ISO 2631-5 Dz [m/s2]':<28}{sp.dose:>{w}.4f}")
        lines.append(
            f"{'  daily Dzd (8 h), Sd':<28}{sp.daily_dose:>{w}.4f} m/s2, {sp.compression:.4f} MPa"
        )
    bodies = list(result.bodies.values())
    for name in dict.fromkeys(k for b in bodies for k in b.force_figures):
        words = name.replace("_", " ")
        for title, cell in (
            (f"{words} r.m.s. [N]", lambda f: f"{f.rms:.1f}"),
            (f"{words} peak [N]", lambda f: f"{f.peak:.1f} at {f.peak_time_s:.3f} s"),
        ):
            lines.append(
                f"{title:<28}"
                + f"{'':>{w}}"  # the seat column
                + "".join(
                    f"{(cell(b.force_figures[name]) if name in b.force_figures else 'n/a'):>{w}}"
                    for b in bodies
                )
            )
    lines.append("")
    lines.append(
        "ISO 2631-1 6.3, basic method enough if crest factor <= 9, MTVV / a_w <= 1.5, "
        "VDV / (a_w T^1/4) <= 1.75:"
    )
    for name, figures, checks in cols:
        over = [
            f"{c['what']} = {c['value']:.2f} > {c['limit']:g}"
            for c in checks.values()
            if c["exceeded"]
        ]
        values = ", ".join(f"{c['value']:.2f}" for c in checks.values())
        verdict = (
            "basic method enough"
            if not over
            else "basic method not sufficient, "
            f"{comfort_verdict(figures, s.duration)['comfort_method'].upper()} "
            "governs (" + "; ".join(over) + ")"
        )
        lines.append(f"  {name}: {values} -> {verdict}")
    return "\n".join(lines)


_ZONE_WORDS = {"below": "below", "caution": "in", "above": "above"}


def format_axes(result) -> str:
    """The ISO 2631-1 lines of every measured axis: figures, totals and health guidance.

    Parameters
    ----------
    result : bodyvib.seat.response.Response

    Returns
    -------
    str
        One row per axis (weighting, comfort factor ``k``, weighted r.m.s., VDV, MTVV and
        the ISO 2631-1 method that governs it, clause 6.3),
        the point and overall vibration total values for comfort, and the seat's
        health value against the caution zone of Annex B.
    """
    tot, channels = result.axes, result.signal.channels
    lines = [
        "ISO 2631-1 per axis (m/s2; rotations rad/s2, k in m/rad):",
        f"  {'axis':<11}{'weighting':>10}{'k':>6}{'a_w':>10}{'VDV':>10}{'MTVV':>10}"
        f"{'method':>8}  channel",
    ]
    for axis, f in tot.axes.items():
        lines.append(
            f"  {axis:<11}{f.weighting:>10}{f.k_comfort:>6.2f}{f.weighted_rms:>10.4f}"
            f"{f.vdv:>10.4f}{f.mtvv:>10.4f}{f.comfort_method:>8}  {channels.get(axis, '')}"
        )
    points = ", ".join(f"{p} {v:.4f}" for p, v in tot.points.items())
    lines.append(f"point vibration total values (comfort, m/s2): {points}")
    lines.append(f"overall vibration total value: {tot.overall:.4f} m/s2 ({tot.comfort})")
    h = tot.health
    if h is not None:
        lines.append(
            f"health (Annex B, max of 1.4 a_wx, 1.4 a_wy, a_wz of the seat): {h.value:.4f} m/s2, "
            f"{_ZONE_WORDS[h.zone]} the caution zone ({h.lower:.3g} to {h.upper:.3g} m/s2 "
            f"at {h.exposure_s / 3600:g} h a day)"
        )
    return "\n".join(lines)


def plot_response(result, path) -> None:
    """Seat and head accelerations over time, their 1 s running r.m.s. (the MTVV's), and the
    bodies' neck and lumbar forces.

    Parameters
    ----------
    result : bodyvib.seat.response.Response
    path : str or os.PathLike
        Plot file (.png, .pdf or .svg).
    """
    from bodyvib.comfort.figures import running_rms, weighted_acceleration
    from bodyvib.plotting import new_figure, save_figure

    s = result.signal
    t = s.time - s.time[0]
    forces = any(b.forces for b in result.bodies.values())
    panels = 2 + bool(forces) + bool(s.axes)
    fig, axes = new_figure(panels, 1, figsize=(9, 3 + 2.8 * panels), sharex=True)
    ax1, ax2 = axes[0], axes[1]
    series = [("seat", s.acceleration, result.seat_figures)] + [
        (f"head, {k}", b.head_acceleration, b.figures) for k, b in result.bodies.items()
    ]
    for name, a, f in series:
        ax1.plot(t, a, lw=0.5, label=name)
        ax2.plot(
            t,
            running_rms(weighted_acceleration(a, s.fs), s.fs),
            lw=0.9,
            label=f"{name}: a_w = {f.weighted_rms:.3f}, MTVV = {f.mtvv:.3f} m/s2",
        )
    ax1.set_ylabel("acceleration [m/s2]")
    ax1.set_title(s.name)
    ax1.legend(fontsize=8)
    ax1.grid(True, alpha=0.3)
    ax2.set_ylabel("1 s running r.m.s. of a_w [m/s2]")
    ax2.legend(fontsize=8)
    ax2.grid(True, alpha=0.3)
    if s.axes:
        _plot_other_axes(axes[2], t, result)
    if forces:
        ax3 = axes[-1]
        for k, b in result.bodies.items():
            for name, f in b.forces.items():
                peak = b.force_figures[name]
                ax3.plot(
                    t,
                    f,
                    lw=0.6,
                    label=f"{name.replace('_', ' ')}, {k}: peak {peak.peak:.1f} N "
                    f"at {peak.peak_time_s:.2f} s",
                )
        ax3.set_ylabel("internal force, + compression [N]")
        ax3.legend(fontsize=8)
        ax3.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time from the record's start [s]")
    save_figure(fig, path)


def _plot_other_axes(ax, t, result) -> None:
    """The record's axes other than seat z: the 1 s running r.m.s. of each weighted with its
    own weighting (ISO 2631-1), labelled with its a_w and MTVV."""
    from bodyvib.comfort import running_rms, weighted_axis

    s = result.signal
    for name, a in s.axes.items():
        f = result.axes.axes[name]
        ax.plot(
            t,
            running_rms(weighted_axis(a, s.fs, f.weighting), s.fs),
            lw=0.8,
            label=f"{name} ({f.weighting}): a_w = {f.weighted_rms:.3f}, "
            f"MTVV = {f.mtvv:.3f} {f.unit}",
        )
    ax.set_ylabel("1 s running r.m.s., other axes\n[m/s2; rad/s2 for rotations]")
    ax.legend(fontsize=7, ncol=2, loc="best", framealpha=0.9)
    ax.grid(True, alpha=0.3)


def _csv_text(result) -> str:
    from bodyvib.comfort import SEATED_AXES

    s = result.signal
    names = list(result.bodies)
    cols = [s.time, s.acceleration] + list(s.axes.values())
    cols += [result.bodies[k].head_acceleration for k in names]
    forces = [(k, f) for k in names for f in result.bodies[k].forces]
    cols += [result.bodies[k].forces[f] for k, f in forces]
    buf = io.StringIO()
    buf.write(
        ",".join(
            ["time [s]", "seat_acceleration [m/s2]"]
            + [f"{a} [{SEATED_AXES[a][3]}]" for a in s.axes]
            + [f"head_acceleration_{k} [m/s2]" for k in names]
            + [f"{f}_{k} [N]" for k, f in forces]
        )
        + "\n"
    )
    np.savetxt(buf, np.column_stack(cols), delimiter=",", fmt="%.10g")
    return buf.getvalue()


def _run(args):
    from bodyvib.models import load_model
    from bodyvib.seat.response import respond
    from bodyvib.seat.signal import parse_channels, read_signal

    if not (np.isfinite(args.exposure) and args.exposure > 0):
        raise BodyvibError(f"--exposure must be a positive number of hours, got {args.exposure:g}")
    channels = parse_channels(args.channels) if args.channels else None
    check_files(
        args, ("json", "plot", "csv"), inputs=[("SIGNAL", args.signal)] + model_inputs(args.models)
    )
    for m in args.models:  # an unknown model is refused before the signal is read
        load_model(m)
    signal = read_signal(args.signal, args.channel, channels)
    interrupts.check()
    result = respond(signal, args.models, exposure_s=args.exposure * 3600.0)
    print(format_response(result))
    print()
    print(format_axes(result))
    write_result(args, result, plot_response, csv_text=_csv_text)
    return 0


def add_command(subparsers):
    """Register ``bodyvib respond``."""
    from bodyvib.models import DEFAULT_MODELS

    p = subparsers.add_parser(
        "respond",
        help="a measured seat acceleration through body models: ISO 2631-1 figures of "
        "seat and head",
        description="Run a measured seat-pan vertical acceleration (CSV with a time column, or "
        "an MDF4 file) through each body model exactly, and give the ISO 2631-1 "
        "figures (Wk r.m.s., VDV, MTVV, peak, crest factor) of the seat and of each head, with "
        "the standard's checks of when the basic method is not enough. Every other axis "
        "measured (seat x, y and rotations, backrest, feet: columns or channels named "
        "seat_x, seat_rx, backrest_z, feet_y, ..., or mapped with --channels) gets its "
        "weighted figures, and all of them the point and overall vibration total values "
        "and the health guidance of ISO 2631-1.",
    )
    p.add_argument(
        "signal",
        metavar="SIGNAL",
        help="CSV file (header with a 'time' column in s; acceleration in m/s2) or "
        "MDF4 file (.mf4)",
    )
    p.add_argument(
        "--channel",
        metavar="NAME",
        help="the seat's vertical acceleration column (CSV) or channel (MDF4); needed "
        "when there is more than one and none is named seat_z",
    )
    p.add_argument(
        "--channels",
        metavar="AXIS=NAME,...",
        help="the columns or channels of the axes, e.g. seat_z=AccZ,seat_x=AccX,"
        "backrest_x=BackX; axes: seat_x, seat_y, seat_z, seat_rx, seat_ry, seat_rz, "
        "backrest_x/y/z, feet_x/y/z (columns already named so are read without it)",
    )
    p.add_argument(
        "--exposure",
        type=float,
        default=8.0,
        metavar="HOURS",
        help="daily exposure for the ISO 2631-1 Annex B health guidance (default 8 h)",
    )
    add_models_option(p, DEFAULT_MODELS)
    add_output_options(
        p,
        plot="write accelerations and running r.m.s.",
        csv="write time, seat and head accelerations, the record's other axes, and the bodies' "
        "neck and lumbar forces",
        json="write the figures and checks as JSON",
    )
    p.set_defaults(func=_run)
    return p
