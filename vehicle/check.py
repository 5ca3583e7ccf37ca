"""Co-simulation studies and the head-acceleration check of a body model against ISO 7962.

:func:`run_study` drives the quarter car over a road with one or more body FMUs
(:func:`vehicle.cosim.cosimulate`), runs the monolithic reference of each
(:func:`vehicle.reference.reference_run`) and reports, per body, the ISO 2631-1
figures of the head acceleration (:mod:`bodyvib.comfort`), the coupling error
and the seat-to-head transmissibility estimated from the run.

:func:`compare` is the check: the reduced body against the ISO 7962 body on the
same road and car, criterion by criterion against :data:`TOLERANCES` (the
README explains each), giving one PASS/FAIL line per criterion and a verdict.
"""

import math
import os
import sys
import tempfile
import time
from typing import Dict, List, Optional

import numpy as np

from bodyvib.comfort import comfort_figures
from bodyvib.errors import BodyvibError
from bodyvib.frequency import find_peaks

from .cosim import cosimulate, model_from_fmu, open_fmu
from .reference import nrmse, reference_run
from .roads import make_road, road_input

__all__ = [
    "TOLERANCES", "TRANSMISSIBILITY_BAND_HZ", "estimate_transmissibility", "build_default_fmus",
    "check_settings", "run_study", "compare", "format_report", "plot_study", "study_json", "coupling_error_sweep",
]

#: Check tolerances: relative difference of the reduced body's figure from the
#: ISO body's (a fraction), except the peak frequency (Hz). See README, "The check".
TOLERANCES = {
    "weighted_rms": 0.10,
    "vdv": 0.10,
    "peak": 0.20,
    "time_history_nrmse": 0.20,
    "transmissibility_peak": 0.10,
    "transmissibility_peak_frequency_hz": 0.5,
}

#: Band over which transmissibility is estimated and compared, Hz.
TRANSMISSIBILITY_BAND_HZ = (0.5, 20.0)


def estimate_transmissibility(seat_acceleration, head_acceleration, fs: float,
                              segment_s: float = 8.0) -> Dict[str, list]:
    """Seat-to-head transmissibility from a run: the H1 estimator ``P_sh / P_ss``.

    Parameters
    ----------
    seat_acceleration, head_acceleration : (n,) array_like
        Absolute accelerations in m/s2, uniformly sampled.
    fs : float
        Sampling rate, Hz.
    segment_s : float
        Welch segment length in s (Hann window, 50 % overlap); 8 s resolves
        0.125 Hz. Shortened to a quarter of the record if that is shorter.

    Returns
    -------
    dict
        ``frequency_hz``, ``modulus``, ``phase_deg``, ``coherence`` (lists over
        :data:`TRANSMISSIBILITY_BAND_HZ`) and ``peak`` (``frequency_hz``,
        ``modulus`` of the highest peak).

    Raises
    ------
    BodyvibError
        A record too short to resolve three frequencies in the band.
    """
    from scipy.signal import coherence, csd, welch

    x = np.asarray(seat_acceleration, dtype=float)
    y = np.asarray(head_acceleration, dtype=float)
    nperseg = int(min(segment_s * fs, x.size // 4))
    if nperseg < 16:
        raise BodyvibError("record too short to estimate a transmissibility; simulate longer")
    f, pxy = csd(x, y, fs=fs, nperseg=nperseg)
    _, pxx = welch(x, fs=fs, nperseg=nperseg)
    _, coh = coherence(x, y, fs=fs, nperseg=nperseg)
    lo, hi = TRANSMISSIBILITY_BAND_HZ
    sel = (f >= lo) & (f <= hi) & (pxx > 0)
    if sel.sum() < 3:
        raise BodyvibError(
            f"a {x.size / fs:g} s record resolves only {fs / nperseg:.3g} Hz, too coarse for "
            f"the transmissibility over {lo:g}-{hi:g} Hz; simulate longer (a few seconds)")
    H = pxy[sel] / pxx[sel]
    mod = np.abs(H)
    peaks = find_peaks(f[sel], mod)
    top = max(peaks, key=lambda p: p["modulus"]) if peaks else {
        "frequency_hz": float(f[sel][np.argmax(mod)]), "modulus": float(mod.max())}
    return {
        "frequency_hz": f[sel].tolist(),
        "modulus": mod.tolist(),
        "phase_deg": np.degrees(np.unwrap(np.angle(H))).tolist(),
        "coherence": coh[sel].tolist(),
        "peak": {"frequency_hz": float(top["frequency_hz"]), "modulus": float(top["modulus"])},
    }


def build_default_fmus(dest, params: Optional[str] = None, car: str = "quarter-car",
                       names=("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar"),
                       native: bool = False) -> Dict[str, str]:
    """Build the project's FMUs into ``dest`` (``build_fmu.py``'s builder).

    Parameters
    ----------
    dest : str
        Folder.
    params : str, optional
        Body parameter file (or shipped name) for ``HumanBody3DOF.fmu``.
    car : str
        Vehicle parameter file or shipped name for ``QuarterCar.fmu``.
    names : sequence of str
        Which FMUs.
    native : bool
        Build the native C FMUs (FMI 2.0, :mod:`bodyvib.native_build`) instead of
        the pythonfmu ones.

    Returns
    -------
    dict of str to str
        FMU name -> path.
    """
    models = {"HumanBody3DOF": params, "QuarterCar": car}
    if native:
        from bodyvib.native_build import build_native_fmu

        return {n: str(build_native_fmu(n, dest, models.get(n), fmi=2)) for n in names}
    from bodyvib.fmu_build import build_fmu

    return {n: str(build_fmu(n, dest, models.get(n))) for n in names}


def _say(msg, quiet):
    if not quiet:
        print(msg, file=sys.stderr, flush=True)


def check_settings(road: str, speed: float, duration: float, step: float, seed: int = 0):
    """Validate run settings before any work is done; returns the road.

    Parameters
    ----------
    road, speed, duration, step, seed
        As :func:`run_study`.

    Returns
    -------
    vehicle.roads.Road

    Raises
    ------
    BodyvibError
        A speed, duration or step that is not a positive number, a step longer
        than half the duration, an unknown road, or a negative seed.
    """
    for value, what, unit in ((speed, "speed", "m/s"), (duration, "duration", "s"),
                              (step, "step", "s")):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise BodyvibError(f"{what} must be a positive number of {unit}, got {value!r}")
    if step > duration / 2:
        raise BodyvibError(f"step {step:g} s is too long for a {duration:g} s run; use a step "
                           "of at most half the duration")
    return make_road(road, speed, duration, seed=seed)


def run_study(body_fmus: Dict[str, str], car_fmu: str, road: str = "C", speed: float = 20.0,
              duration: float = 30.0, step: float = 1e-3, seed: int = 0,
              extrapolate: bool = True, reference: bool = True, progress: bool = False,
              quiet: bool = True) -> dict:
    """Co-simulate the car with each body FMU on one road; figures, references, transmissibility.

    Parameters
    ----------
    body_fmus : dict of str to str
        Label -> body FMU path.
    car_fmu : str
        Car FMU path.
    road : str
        ISO 8608 class ``A``-``H``, ``bump`` or ``sweep`` (:func:`vehicle.roads.make_road`).
    speed : float
        m/s.
    duration : float
        s.
    step : float
        Communication step, s.
    seed : int
        Random-road seed.
    extrapolate : bool
        Seat-force extrapolation in the master (see :mod:`vehicle.cosim`).
    reference : bool
        Also run the monolithic reference and report the coupling error.
    progress : bool
        tqdm progress bars on stderr.
    quiet : bool
        No stage messages on stderr.

    Returns
    -------
    dict
        ``settings``, ``road`` (its description), ``time``, ``road_displacement``,
        ``road_velocity`` and ``bodies``: label -> ``{"fmu", "run", "reference",
        "figures", "coupling_nrmse", "transmissibility", "real_time_factor"}``.

    Raises
    ------
    BodyvibError
        Bad settings, missing or unsuitable FMUs.
    """
    rd = check_settings(road, speed, duration, step, seed)
    n = int(round(duration / step)) + 1
    t = np.arange(n) * step
    z, v = road_input(rd, speed, t)
    fs = 1.0 / step
    car_net = model_from_fmu(car_fmu) if reference else None
    out = {
        "settings": {"road": str(road), "speed_m_s": speed, "duration_s": duration,
                     "step_s": step, "seed": seed, "master": "gauss-seidel, seat force "
                     + ("extrapolated linearly" if extrapolate else "held")},
        "road": rd.describe(),
        "time": t, "road_displacement": z, "road_velocity": v,
        "bodies": {},
    }
    for label, path in body_fmus.items():
        _say(f"co-simulating {label} ({os.path.basename(path)}) on {rd.name} at {speed:g} m/s, "
             f"{duration:g} s, step {step:g} s", quiet)
        with open_fmu(car_fmu, "car", "car") as car, open_fmu(path, "body", label) as body:
            t0 = time.perf_counter()
            run = cosimulate(car, body, z, v, step, extrapolate=extrapolate, progress=progress)
            wall = time.perf_counter() - t0
        ref, err = None, None
        body_net = model_from_fmu(path) if reference else None
        if reference and body_net is not None and car_net is not None:
            _say(f"monolithic reference of {label}", quiet)
            ref = reference_run(car_net, body_net, z, v, step)
            err = nrmse(run["head_acceleration"], ref["head_acceleration"])
        out["bodies"][label] = {
            "fmu": os.fspath(path),
            "model": body_net.name if body_net is not None else None,
            "run": run,
            "reference": ref,
            "figures": comfort_figures(run["head_acceleration"], fs),
            "seat_figures": comfort_figures(run["seat_acceleration"], fs),
            "coupling_nrmse": err,
            "transmissibility": estimate_transmissibility(run["seat_acceleration"],
                                                          run["head_acceleration"], fs),
            "real_time_factor": duration / wall,
        }
    return out


def _rel(a, b):
    return abs(a - b) / abs(b) if b else float("inf")


def compare(study: dict, reduced: str, iso: str) -> dict:
    """The check: reduced body against the ISO body, criterion by criterion.

    Parameters
    ----------
    study : dict
        From :func:`run_study` with both labels.
    reduced, iso : str
        Labels of the reduced body and of the ISO 7962 body.

    Returns
    -------
    dict
        ``criteria``: list of ``{"name", "reduced", "iso", "difference",
        "tolerance", "unit", "passed"}`` (difference relative, a fraction,
        except the peak frequency in Hz; for the time-history NRMSE "reduced"
        holds the NRMSE); ``verdict``: ``"PASS"`` if every criterion passes,
        else ``"FAIL"``.
    """
    R, I = study["bodies"][reduced], study["bodies"][iso]
    crit = []

    def add(name, r, i, diff, unit="relative"):
        tol = TOLERANCES[name]
        crit.append({"name": name, "reduced": r, "iso": i, "difference": diff,
                     "tolerance": tol, "unit": unit, "passed": bool(diff <= tol)})

    for key in ("weighted_rms", "vdv", "peak"):
        r, i = R["figures"][key], I["figures"][key]
        add(key, r, i, _rel(r, i))
    e = nrmse(R["run"]["head_acceleration"], I["run"]["head_acceleration"])
    add("time_history_nrmse", e, 0.0, e)
    pr, pi = R["transmissibility"]["peak"], I["transmissibility"]["peak"]
    add("transmissibility_peak", pr["modulus"], pi["modulus"], _rel(pr["modulus"], pi["modulus"]))
    add("transmissibility_peak_frequency_hz", pr["frequency_hz"], pi["frequency_hz"],
        abs(pr["frequency_hz"] - pi["frequency_hz"]), unit="Hz")
    return {"reduced": reduced, "iso": iso, "criteria": crit,
            "verdict": "PASS" if all(c["passed"] for c in crit) else "FAIL"}


_WORDS = {
    "crest_factor": "crest factor [-]",
    "weighted_rms": "Wk-weighted r.m.s. [m/s2]",
    "vdv": "VDV [m/s^1.75]",
    "peak": "weighted peak [m/s2]",
    "time_history_nrmse": "head acceleration NRMSE",
    "transmissibility_peak": "transmissibility peak |T|",
    "transmissibility_peak_frequency_hz": "transmissibility peak frequency [Hz]",
}


def format_report(study: dict, comparison: Optional[dict] = None) -> str:
    """Text report: per-body head figures, coupling error, and the check's lines.

    Parameters
    ----------
    study : dict
        From :func:`run_study`.
    comparison : dict, optional
        From :func:`compare`.

    Returns
    -------
    str
    """
    s = study["settings"]
    lines = [f"road {study['road']['name']}, {s['speed_m_s']:g} m/s, {s['duration_s']:g} s, "
             f"step {s['step_s']:g} s ({s['master']})", ""]
    bodies = study["bodies"]
    labels = list(bodies)
    w = max(24, *(len(label) for label in labels))

    def row(title, cell):  # one line: a title, then cell(body) right-aligned per body
        return f"{title:<28}" + "".join(f"{cell(bodies[b]):>{w}}" for b in labels)

    lines.append(f"{'head acceleration':<28}" + "".join(f"{label:>{w}}" for label in labels))
    for key, fmt in (("weighted_rms", "{:.4f}"), ("vdv", "{:.4f}"), ("peak", "{:.4f}"),
                     ("crest_factor", "{:.2f}")):
        lines.append(row(_WORDS[key], lambda b: fmt.format(b["figures"][key])))
    lines.append(row("comfort (ISO 2631-1 C)", lambda b: b["figures"]["comfort"]))
    lines.append(row("transmissibility peak", lambda b: "{modulus:.3f} at {frequency_hz:.2f} Hz".format(
        **b["transmissibility"]["peak"])))
    lines.append(row("coupling NRMSE vs reference", lambda b: _pct(b["coupling_nrmse"])))
    lines.append(row("real-time factor", lambda b: f"{b['real_time_factor']:.1f}"))
    seat = study["bodies"][labels[0]]["seat_figures"]["weighted_rms"]
    lines.append(f"seat Wk-weighted r.m.s. ({labels[0]} run): {seat:.4f} m/s2")
    if comparison:
        lines += ["", f"check: {comparison['reduced']} against {comparison['iso']}"]
        for c in comparison["criteria"]:
            mark = "PASS" if c["passed"] else "FAIL"
            if c["unit"] == "Hz":
                what = (f"{c['reduced']:.2f} vs {c['iso']:.2f} Hz: difference "
                        f"{c['difference']:.2f} Hz <= {c['tolerance']:g} Hz?")
            elif c["name"] == "time_history_nrmse":
                what = f"{100 * c['difference']:.1f} % <= {100 * c['tolerance']:g} %?"
            else:
                what = (f"{c['reduced']:.4g} vs {c['iso']:.4g}: difference "
                        f"{100 * c['difference']:.1f} % <= {100 * c['tolerance']:g} %?")
            lines.append(f"  {mark}  {_WORDS[c['name']]:<38} {what}")
        lines.append(f"verdict: {comparison['verdict']}")
    return "\n".join(lines)


def _pct(x):
    return "n/a" if x is None else f"{100 * x:.4f} %"


def study_json(study: dict, comparison: Optional[dict] = None) -> dict:
    """The JSON document of a study (figures, no time histories); keys in the README.

    Parameters
    ----------
    study : dict
        From :func:`run_study`.
    comparison : dict, optional
        From :func:`compare`.

    Returns
    -------
    dict
    """
    doc = {"settings": study["settings"], "road": study["road"], "bodies": {}}
    for label, b in study["bodies"].items():
        f = b["figures"]
        doc["bodies"][label] = {
            "fmu": b["fmu"], "model": b["model"],
            "weighted_rms": f["weighted_rms"], "vdv": f["vdv"], "peak": f["peak"],
            "crest_factor": f["crest_factor"], "comfort": f["comfort"],
            "coupling_nrmse": b["coupling_nrmse"],
            "seat_weighted_rms": b["seat_figures"]["weighted_rms"],
            "transmissibility_peak": b["transmissibility"]["peak"],
            "real_time_factor": b["real_time_factor"],
        }
    if comparison is not None:
        doc["check"] = {"criteria": comparison["criteria"], "verdict": comparison["verdict"],
                        "tolerances": dict(TOLERANCES)}
        doc["verdict"] = comparison["verdict"]
    return doc


def plot_study(study: dict, path, comparison: Optional[dict] = None, window_s: float = 5.0):
    """Head acceleration side by side (a window mid-run) and transmissibility estimates.

    Parameters
    ----------
    study : dict
        From :func:`run_study`.
    path : str or os.PathLike
        Plot file (.png, .pdf or .svg).
    comparison : dict, optional
        From :func:`compare` (its verdict goes into the title).
    window_s : float
        Length of the time window shown, s.

    Raises
    ------
    BodyvibError
        An unsupported plot file extension.
    """
    from bodyvib.frequency import transmissibility
    from bodyvib.plotting import new_figure, save_figure

    fig, (ax1, ax2) = new_figure(2, 1, figsize=(8, 8))
    fig.subplots_adjust(hspace=0.35)
    t = study["time"]
    t0 = max(0.0, t[-1] / 2 - window_s / 2)
    sel = (t >= t0) & (t <= t0 + window_s)
    for label, b in study["bodies"].items():
        ax1.plot(t[sel], b["run"]["head_acceleration"][sel], lw=0.9,
                 label=f"{label}: a_w = {b['figures']['weighted_rms']:.3f} m/s2")
    ax1.set_xlabel("time [s]")
    ax1.set_ylabel("head acceleration [m/s2]")
    s = study["settings"]
    ax1.set_title(f"{study['road']['name']}, {s['speed_m_s']:g} m/s: head acceleration "
                  f"({window_s:g} s window)")
    ax1.grid(True, alpha=0.3)
    ax1.legend(fontsize=8, loc="upper right")
    for label, b in study["bodies"].items():
        T = b["transmissibility"]
        line, = ax2.plot(T["frequency_hz"], T["modulus"], label=f"{label} (estimated from run)")
        if b["model"] is not None:
            net = model_from_fmu(b["fmu"])
            f = np.asarray(T["frequency_hz"])
            ax2.plot(f, np.abs(transmissibility(net, f)), "--", color=line.get_color(), lw=0.8,
                     label=f"{label} (model)")
    ax2.set_xscale("log")
    ax2.set_xlabel("frequency [Hz]")
    ax2.set_ylabel("|T| head / seat [-]")
    ax2.grid(True, which="both", alpha=0.3)
    ax2.legend(fontsize=8)
    if comparison is not None:
        ax2.set_title(f"seat-to-head transmissibility; check verdict: {comparison['verdict']}")
    save_figure(fig, path)


def coupling_error_sweep(steps, body_fmu: str, car_fmu: str, road: str = "C", speed: float = 20.0,
                         duration: float = 10.0, seed: int = 0, extrapolate: bool = True
                         ) -> List[dict]:
    """Head-acceleration coupling NRMSE against the monolithic reference, per step.

    Parameters
    ----------
    steps : sequence of float
        Communication steps, s.
    body_fmu, car_fmu : str
        FMU paths (bodyvib FMUs: the reference comes from their parameter files).
    road, speed, duration, seed : see :func:`run_study`.
    extrapolate : bool
        Master with (True) or without seat-force extrapolation.

    Returns
    -------
    list of dict
        ``{"step_s", "coupling_nrmse", "real_time_factor"}`` per step.
    """
    rows = []
    for h in steps:
        st = run_study({"body": body_fmu}, car_fmu, road, speed, duration, float(h), seed,
                       extrapolate=extrapolate)
        b = st["bodies"]["body"]
        rows.append({"step_s": float(h), "coupling_nrmse": b["coupling_nrmse"],
                     "real_time_factor": b["real_time_factor"]})
    return rows


def default_fmu_dir():
    """A fresh temporary folder for FMUs built for one run."""
    return tempfile.mkdtemp(prefix="bodyvib-fmus-")
