"""The paper's Table 2 against a GA refit: a table, JSON and plots (``bodyvib fit --report``).

Both parameter sets are judged on the same objective (:mod:`bodyvib.fit.objective`, the
paper's Eq. 3, each pair separately and weighted), on the seat-to-head
transmissibility peaks against the target (the reference model or the
measured data) over 0.5-31.5 Hz (ISO 7962's range), and, for a reference
model, on the apparent mass (the seat force per seat acceleration), which is
what a vehicle feels in a two-way coupling.
"""

import os

import numpy as np

from ..frequency.response import apparent_mass, find_peaks, transmissibility
from ..models import load_model
from ..process.outputs import atomic_write_text, write_json
from ..runtime.renames import renamed_parameters

__all__ = [
    "F_MIN_HZ",
    "F_MAX_HZ",
    "compare_fit",
    "format_comparison",
    "plot_comparison",
    "write_report",
]

#: Frequency range of the comparison (ISO 7962's data), Hz.
F_MIN_HZ, F_MAX_HZ = 0.5, 31.5


def compare_fit(result, refit):
    """Numbers comparing Table 2 with the refit on the fit's own target.

    Parameters
    ----------
    result : bodyvib.fit.result.FitResult
    refit : Network
        The refitted model (as written by :func:`bodyvib.fit.result.write_parameter_file`).

    Returns
    -------
    dict
        ``target``, ``pairs``, ``total_mass_kg``, ``objective`` (per model:
        ``total_per_s``, ``relative``, ``by_pair_per_s``), ``transmissibility_peaks``
        (per model and for the target), ``apparent_mass`` (reference models:
        peaks and r.m.s. relative difference from the reference), and
        ``parameters`` (per model).
    """
    from .objective import parameter_array

    t = result.target
    paper = load_model("reduced-paper")
    models = {"table2": paper, "refit": refit}
    out = {
        "target": t.description,
        "pairs": dict(t.pairs),
        "total_mass_kg": t.total_mass,
        "objective": {},
        "transmissibility_peaks": {},
        "parameters": {},
    }
    for key, net in models.items():
        p = parameter_array(net)
        by_pair = {}
        for role, _wgt in t.pairs.items():
            single = _single_pair(t, role)
            by_pair[role] = float(single.objective(p))
        total = float(t.objective(p))
        out["objective"][key] = {
            "total_per_s": total,
            "relative": total / t.energy(),
            "by_pair_per_s": by_pair,
        }
        out["parameters"][key] = dict(net.parameters)
    out["objective"]["refit_over_table2"] = (
        out["objective"]["refit"]["total_per_s"] / out["objective"]["table2"]["total_per_s"]
    )
    if t.kind == "model":
        from .objective import objective_time_domain

        for key, net in models.items():
            out["objective"][key]["time_domain_per_s"] = objective_time_domain(
                t.reference, net, t.pairs, config=result.config
            )
        f = np.geomspace(F_MIN_HZ, F_MAX_HZ, 3000)
        out["transmissibility_peaks"]["target"] = _peaks(
            f, np.abs(transmissibility(t.reference, f))
        )
        am_ref = np.abs(apparent_mass(t.reference, f))
        am = {"target": {"peaks_kg": _peaks(f, am_ref)}}
        for key, net in models.items():
            a = np.abs(apparent_mass(net, f))
            am[key] = {
                "peaks_kg": _peaks(f, a),
                "rms_relative_difference": float(np.sqrt(np.mean((a / am_ref - 1) ** 2))),
            }
        out["apparent_mass"] = am
    else:
        f = np.geomspace(t.frequency_hz[0], t.frequency_hz[-1], 3000)
        out["transmissibility_peaks"]["target"] = _peaks(
            t.measured.frequency_hz, t.measured.modulus
        )
    for key, net in models.items():
        out["transmissibility_peaks"][key] = _peaks(f, np.abs(transmissibility(net, f)))
    return out


def _peaks(f, modulus):
    """:func:`find_peaks` as JSON (the comparison is a JSON document)."""
    return [p.to_dict() for p in find_peaks(f, modulus)]


def _single_pair(target, role):
    from dataclasses import replace

    return replace(target, pairs={role: 1.0})


def _fmt_peaks(peaks, unit="", digits=3):
    if not peaks:
        return "none"
    return "; ".join(
        f"{p['modulus']:.{digits}f}{unit} at {p['frequency_hz']:.2f} Hz" for p in peaks
    )


def format_comparison(cmp) -> str:
    """The comparison as a Markdown table (readable as plain text)."""
    names = ("target", "table2", "refit")
    head = "| quantity | target | paper's Table 2 | refit |"
    lines = [
        f"Target: {cmp['target']}.",
        "",
        "Pairs (role = weight): "
        + ", ".join(f"{r} = {w:g}" for r, w in cmp["pairs"].items())
        + f"; total mass pinned to {cmp['total_mass_kg']:g} kg.",
        "",
        head,
        "|---|---|---|---|",
    ]
    o = cmp["objective"]
    lines.append(
        f"| objective J [1/s] (Parseval form) | 0 | {o['table2']['total_per_s']:.5g} | "
        f"{o['refit']['total_per_s']:.5g} ({cmp['objective']['refit_over_table2']:.1%}"
        " of Table 2) |"
    )
    if "time_domain_per_s" in o["refit"]:
        lines.append(
            f"| objective J [1/s] (time-domain definition) | 0 | "
            f"{o['table2']['time_domain_per_s']:.5g} | "
            f"{o['refit']['time_domain_per_s']:.5g} |"
        )
    for role in cmp["pairs"]:
        lines.append(
            f"| J of the {role} alone [1/s] | 0 | {o['table2']['by_pair_per_s'][role]:.5g}"
            f" | {o['refit']['by_pair_per_s'][role]:.5g} |"
        )
    lines.append(
        f"| J / target energy [-] | 0 | {o['table2']['relative']:.4f} | "
        f"{o['refit']['relative']:.4f} |"
    )
    pk = cmp["transmissibility_peaks"]
    lines.append(
        "| seat-to-head \\|T\\| peaks | " + " | ".join(_fmt_peaks(pk[n]) for n in names) + " |"
    )
    if "apparent_mass" in cmp:
        am = cmp["apparent_mass"]
        lines.append(
            "| apparent mass peaks [kg] | "
            + " | ".join(_fmt_peaks(am[n]["peaks_kg"], " kg", 1) for n in names)
            + " |"
        )
        lines.append(
            f"| apparent mass, r.m.s. relative difference from target, "
            f"{F_MIN_HZ:g}-{F_MAX_HZ:g} Hz | 0 | "
            f"{am['table2']['rms_relative_difference']:.1%} | "
            f"{am['refit']['rms_relative_difference']:.1%} |"
        )
    lines += ["", "| parameter | paper's Table 2 | refit |", "|---|---|---|"]
    for k in cmp["parameters"]["refit"]:
        lines.append(
            f"| {k} | {cmp['parameters']['table2'][k]:.5g} | {cmp['parameters']['refit'][k]:.5g} |"
        )
    return "\n".join(lines) + "\n"


@renamed_parameters(folder="dest")
def plot_comparison(result, refit, dest):
    """Write ``transmissibility.png`` and ``impulse_response.png`` into ``dest``.

    Returns
    -------
    list of str
        The files written.
    """
    from ..plotting import new_figure, save_figure, transmissibility_axes
    from .objective import default_horizon, impulse_response

    t = result.target
    paper = load_model("reduced-paper")
    f = np.geomspace(F_MIN_HZ, F_MAX_HZ, 1500)
    fig, (ax1, ax2) = new_figure(2, 1, sharex=True, figsize=(7, 6))
    if t.kind == "model":
        T = transmissibility(t.reference, f)
        ax1.plot(f, np.abs(T), "k-", lw=2, label=f"{t.reference.name} (reference)")
        ax2.plot(f, np.degrees(np.unwrap(np.angle(T))), "k-", lw=2)
    else:
        m = t.measured
        ax1.plot(m.frequency_hz, m.modulus, "ko", ms=3, label="measured")
        if m.has_phase:
            ax2.plot(m.frequency_hz, m.phase_deg, "ko", ms=3)
        f = np.geomspace(m.frequency_hz[0], m.frequency_hz[-1], 1500)
    for net, label, style in ((paper, "paper's Table 2", "--"), (refit, "refit (GA)", "-")):
        T = transmissibility(net, f)
        ax1.plot(f, np.abs(T), style, label=label)
        ax2.plot(f, np.degrees(np.unwrap(np.angle(T))), style)
    transmissibility_axes(ax1, ax2, title="Seat-to-head transmissibility")
    ax1.legend()
    files = [os.path.join(dest, "transmissibility.png")]
    save_figure(fig, files[0])

    roles = list(t.pairs)
    fig, axes = new_figure(
        len(roles), 1, sharex=True, figsize=(7, 2.6 * len(roles) + 0.8), squeeze=False
    )
    step = result.config.time_domain.step
    models = [(paper, "paper's Table 2", "--"), (refit, "refit (GA)", "-")]
    if t.kind == "model":
        models.insert(0, (t.reference, f"{t.reference.name} (reference)", "k-"))
    duration = min(0.6, default_horizon(*(m for m, _, _ in models)))
    for ax, role in zip(axes[:, 0], roles):
        for net, label, style in models:
            tt, h = impulse_response(net, duration, step, role)
            ax.plot(tt, h, style, label=label, lw=2 if style == "k-" else 1.2)
        ax.set_ylabel(f"{role} position\nper seat impulse [1/s]")
        ax.grid(True, alpha=0.3)
    axes[0, 0].set_title("Impulse responses (seat displacement impulse, 1 m s)")
    axes[0, 0].legend()
    axes[-1, 0].set_xlabel("time [s]")
    files.append(os.path.join(dest, "impulse_response.png"))
    save_figure(fig, files[1])
    return files


@renamed_parameters(folder="dest")
def write_report(dest, result, refit):
    """Write ``comparison.md``, ``comparison.json`` and the plots into ``dest``.

    Parameters
    ----------
    dest : str or os.PathLike
        Created if missing.
    result : bodyvib.fit.result.FitResult
        The search's outcome (targets, parameters, objective values).
    refit : Network
        The reduced model with the refit parameters.

    Returns
    -------
    list of str
        ``comparison.md``, ``comparison.json``, then the plots.
    """
    dest = os.fspath(dest)
    os.makedirs(dest, exist_ok=True)
    cmp = compare_fit(result, refit)
    md = os.path.join(dest, "comparison.md")
    js = os.path.join(dest, "comparison.json")
    atomic_write_text(md, "# Paper's Table 2 against the GA refit\n\n" + format_comparison(cmp))
    write_json(js, cmp)
    return [md, js] + plot_comparison(result, refit, dest)
