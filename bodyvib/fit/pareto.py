"""The refit's trade-off: Eq. 3's objective against the error of the resonance peak (NSGA-II).

The single-objective refit minimizes the paper's Eq. 3 (``J``, the impulse
responses of head and torso); its seat-to-head transmissibility peaks lower
than the reference's (1.439 against the ISO model's 1.665). This module draws
what the reduced 3-DOF chain can do about it: the Pareto front of

* ``J`` (1/s, :class:`bodyvib.fit.objective.FitTarget`), and
* the **peak error** ``e = max(|d|T|| / (0.10 |T_ref|), |df| / 0.5 Hz)``: the
  larger of the errors of the peak modulus and of the peak frequency of
  ``|X_head/X_seat|`` over 0.5-20 Hz, each in units of the tolerance of
  ``bodyvib check`` (10 % and 0.5 Hz), so that ``e <= 1`` is exactly "both
  peak criteria of the check pass" on the models' own transmissibilities.

One scalar instead of two objectives: the check judges the two together,
and on a two-objective front every point says what one unit of it costs in
``J``; the table keeps both components.

The search is NSGA-II from pymoo (``pymoo.algorithms.moo.nsga2.NSGA2``),
vectorized (one call per generation), in the aligned coordinates of
:class:`bodyvib.fit.methods.SearchSpace`; its first population holds the
single-objective optimum (the genetic algorithm's result), so the front's
min-``J`` end is the refit itself. :func:`write_pareto` writes the front as a
CSV table and a PNG plot, and a parameter file with provenance for each of
three chosen points: the min-``J`` end, the knee (farthest from the line
joining the ends, both objectives scaled to [0, 1] over the front) and the
min-peak-error end; and, when some point passes (``e <= 1``), the least ``J``
among those.
"""

import csv
import datetime
import io
import os
import sys
from dataclasses import dataclass, field
from typing import Dict, List

import numpy as np

from .. import __version__
from ..analytic import head_transmissibility
from ..models import save_model
from ..process import extras
from ..process.outputs import atomic_write_text
from ..runtime.errors import BodyvibError
from ..runtime.renames import renamed_parameters
from .config import ParetoSettings, log_bounds
from .methods import SearchSpace, nsga2_front
from .space import REDUCED_PARAMETERS, genes_to_parameters, parameters_to_genes, reduced_network

__all__ = [
    "PEAK_BAND_HZ",
    "reference_peak",
    "MODULUS_TOLERANCE",
    "FREQUENCY_TOLERANCE_HZ",
    "peaks",
    "peak_error",
    "ParetoFront",
    "pareto_front",
    "chosen_points",
    "write_pareto",
]

#: Band of the transmissibility peak, Hz (that of ``bodyvib check``'s estimate).
PEAK_BAND_HZ = (0.5, 20.0)
#: The check's tolerances on the peak: relative modulus, frequency (Hz).
MODULUS_TOLERANCE, FREQUENCY_TOLERANCE_HZ = 0.10, 0.5

_GRID = np.geomspace(*PEAK_BAND_HZ, 600)


def peaks(params) -> np.ndarray:
    """Highest seat-to-head ``|T|`` of reduced models over :data:`PEAK_BAND_HZ`, and where.

    The maximum on a 600-point logarithmic grid, refined by the parabola
    through it and its neighbours in ``ln f`` (grid step h = 0.0062; the
    error is below h^2 = 3.8e-5 relative in frequency and h^3 = 2.3e-7 in modulus).

    Parameters
    ----------
    params : array_like, shape (..., 7)
        Reduced-model parameters in :data:`bodyvib.fit.space.REDUCED_PARAMETERS` order.

    Returns
    -------
    ndarray, shape (..., 2)
        Peak modulus and peak frequency (Hz).

    Examples
    --------
    >>> from bodyvib.fit.objective import parameter_array
    >>> from bodyvib.models import load_model
    >>> m, f = peaks(parameter_array(load_model("reduced-paper")))
    >>> round(float(m), 3), round(float(f), 2)
    (1.446, 4.43)
    """
    p = np.asarray(params, dtype=float)
    cols = [p[..., i] for i in range(7)]
    T = np.abs(head_transmissibility(2j * np.pi * _GRID, *cols))
    return _refine(np.log(_GRID), T)


def _refine(logf, T):
    n = logf.size
    i = np.clip(np.argmax(T, axis=-1), 1, n - 2)
    take = lambda k: np.take_along_axis(T, k[..., None], axis=-1)[..., 0]  # noqa: E731
    y0, y1, y2 = take(i - 1), take(i), take(i + 1)
    h = logf[1] - logf[0]
    den = y0 - 2 * y1 + y2
    d = np.where(den < 0, 0.5 * (y0 - y2) / np.where(den < 0, den, -1.0), 0.0)
    d = np.clip(d, -1.0, 1.0)
    modulus = y1 - 0.25 * (y0 - y2) * d
    return np.stack([modulus, np.exp(logf[i] + d * h)], axis=-1)


def reference_peak(reference) -> np.ndarray:
    """Peak modulus and frequency of a reference model's seat-to-head ``|T|``, as :func:`peaks`."""
    from ..frequency.response import transmissibility

    return _refine(np.log(_GRID), np.abs(transmissibility(reference, _GRID)))


def peak_error(peak, ref_peak) -> np.ndarray:
    """The peak error ``max(|dM| / (0.10 M_ref), |df| / 0.5 Hz)`` (module docstring).

    Parameters
    ----------
    peak : array_like, shape (..., 2)
        Modulus and frequency (Hz), from :func:`peaks`.
    ref_peak : array_like, shape (2,)
        The reference's.

    Returns
    -------
    ndarray, shape (...)
        Dimensionless; at most 1 where both of the check's peak criteria pass.
    """
    peak, ref_peak = np.asarray(peak), np.asarray(ref_peak)
    return np.maximum(
        np.abs(peak[..., 0] - ref_peak[0]) / (MODULUS_TOLERANCE * ref_peak[0]),
        np.abs(peak[..., 1] - ref_peak[1]) / FREQUENCY_TOLERANCE_HZ,
    )


@dataclass
class ParetoFront:
    """The non-dominated set of an NSGA-II run, sorted by ``J``.

    Attributes
    ----------
    parameters : ndarray, shape (n, 7)
        Reduced-model parameters (SI).
    objective : ndarray, shape (n,)
        ``J``, 1/s.
    peak_error : ndarray, shape (n,)
    peak : ndarray, shape (n, 2)
        Peak modulus and frequency (Hz).
    reference_peak : ndarray, shape (2,)
    target : FitTarget
    seed : int
    settings : dict
        The configuration's ``pareto`` section as JSON
        (``ParetoSettings.to_dict()`` of :class:`bodyvib.fit.config.ParetoSettings`).
    evaluations : int
    elapsed_s : float
    """

    parameters: np.ndarray
    objective: np.ndarray
    peak_error: np.ndarray
    peak: np.ndarray
    reference_peak: np.ndarray
    target: object
    seed: int
    settings: dict
    evaluations: int = 0
    elapsed_s: float = 0.0
    history: List[float] = field(default_factory=list)


def pareto_front(target, config, seed: int = 1, start=None, progress: bool = False) -> ParetoFront:
    """NSGA-II on (``J``, peak error) for a reference-model target.

    Parameters
    ----------
    target : FitTarget
        From :func:`bodyvib.fit.objective.model_target` (a reference model).
    config : FitConfig
        From :func:`bodyvib.fit.config.load_config` (bounds and ``pareto``:
        ``population``, ``generations``, ``crossover_eta``, ``mutation_eta``).
    seed : int
    start : array_like, shape (7,), optional
        Parameters put into the first population (the single-objective
        optimum, so the front's min-``J`` end is at least as good).
    progress : bool
        A progress bar on stderr.

    Returns
    -------
    ParetoFront

    Raises
    ------
    BodyvibError
        The target is measured data (no reference model to take the peak from).
    bodyvib.process.extras.MissingExtraError
        The fit extra is not installed.
    """
    import time

    extras.require("the Pareto front", "fit")
    from threadpoolctl import threadpool_limits
    from tqdm import tqdm

    if target.reference is None:
        raise BodyvibError(
            "pareto_front needs a reference model (the peak error is against its "
            "transmissibility); measured data are not supported",
            parameters=("pareto_front",),
        )
    s = config.pareto
    lo, hi = log_bounds(config)
    space = SearchSpace(lo, hi, aligned=True)
    M = target.total_mass
    ref = reference_peak(target.reference)
    count = [0]

    def evaluate(z):
        p = genes_to_parameters(space.genes(z), M)
        count[0] += len(p)
        J = np.nan_to_num(target.objective(p), nan=np.inf, posinf=1e300)
        e = np.nan_to_num(peak_error(peaks(p), ref), nan=1e300, posinf=1e300)
        return np.column_stack([J, e])

    n = int(s.population)
    rng = np.random.default_rng(seed)
    X0 = space.zlo + rng.random((n, 6)) * (space.zhi - space.zlo)
    if start is not None:
        X0[0] = space.coordinates(parameters_to_genes(np.asarray(start, dtype=float)))
    bar = tqdm(
        total=int(s.generations),
        desc="Pareto front (NSGA-II)",
        unit="gen",
        file=sys.stderr,
        disable=None if progress else True,
        leave=False,
    )
    t0 = time.perf_counter()
    try:
        with threadpool_limits(1, user_api="blas"):
            Z, F = nsga2_front(
                evaluate,
                (6, space.zlo, space.zhi),
                2,
                ParetoSettings(
                    n, int(s.generations), float(s.crossover_eta), float(s.mutation_eta)
                ),
                seed=int(seed),
                sampling=X0,
                callback=lambda _a: bar.update(1),
            )
    finally:
        bar.close()
    elapsed = time.perf_counter() - t0
    F, Z = np.atleast_2d(F), np.atleast_2d(Z)
    order = np.argsort(F[:, 0])
    P = genes_to_parameters(space.genes(Z[order]), M)
    return ParetoFront(
        parameters=P,
        objective=F[order, 0],
        peak_error=F[order, 1],
        peak=peaks(P),
        reference_peak=ref,
        target=target,
        seed=int(seed),
        settings=s.to_dict(),
        evaluations=count[0],
        elapsed_s=elapsed,
    )


def chosen_points(front: ParetoFront) -> Dict[str, int]:
    """Indices of the chosen points of a front.

    Parameters
    ----------
    front : ParetoFront

    Returns
    -------
    dict of str to int
        ``min-J``, ``knee`` (farthest from the chord between the ends, both
        objectives scaled to [0, 1] over the front), ``min-peak-error`` and,
        when some point has a peak error of at most 1, ``check-pass`` (the
        least ``J`` among those).
    """
    J, e = front.objective, front.peak_error
    out = {"min-J": int(np.argmin(J)), "min-peak-error": int(np.argmin(e))}
    u = (J - J.min()) / max(np.ptp(J), 1e-300)
    v = (e - e.min()) / max(np.ptp(e), 1e-300)
    a, b = (
        np.array([u[out["min-J"]], v[out["min-J"]]]),
        np.array([u[out["min-peak-error"]], v[out["min-peak-error"]]]),
    )
    d = b - a
    dist = np.abs(d[0] * (v - a[1]) - d[1] * (u - a[0])) / max(np.hypot(*d), 1e-300)
    out["knee"] = int(np.argmax(dist))
    ok = np.flatnonzero(e <= 1.0)
    if ok.size:
        out["check-pass"] = int(ok[np.argmin(J[ok])])
    return out


def _table(front: ParetoFront) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    ref = front.reference_peak
    w.writerow(
        [
            "J_per_s",
            "peak_error",
            "peak_modulus",
            "peak_frequency_hz",
            "modulus_error_relative",
            "frequency_error_hz",
        ]
        + list(REDUCED_PARAMETERS)
    )
    for p, J, e, (m, f) in zip(front.parameters, front.objective, front.peak_error, front.peak):
        w.writerow(
            [
                f"{J:.8g}",
                f"{e:.6g}",
                f"{m:.6g}",
                f"{f:.6g}",
                f"{m / ref[0] - 1:.6g}",
                f"{f - ref[1]:.6g}",
            ]
            + [f"{v:.8g}" for v in p]
        )
    return buf.getvalue()


def _plot(front: ParetoFront, chosen: Dict[str, int], path) -> None:
    from ..frequency.response import transmissibility
    from ..plotting import new_figure, save_figure

    fig, (ax, bx) = new_figure(1, 2, figsize=(11, 4.5))
    ax.plot(front.peak_error, front.objective, ".", color="0.4", label="Pareto front (NSGA-II)")
    for name, i in chosen.items():
        ax.plot(front.peak_error[i], front.objective[i], "o", ms=8, label=name)
    ax.axvline(1.0, color="k", lw=0.8, ls="--", label="check's peak tolerance")
    ax.set_xlabel("peak error (1 = the check's tolerance: 10 % of |T| or 0.5 Hz)")
    ax.set_ylabel("J, paper Eq. 3 [1/s]")
    ax.set_xscale("log")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    f = np.geomspace(0.5, 31.5, 800)
    bx.plot(
        f,
        np.abs(transmissibility(front.target.reference, f)),
        "k",
        lw=2,
        label=front.target.reference.name,
    )
    for name, i in chosen.items():
        bx.plot(
            f,
            np.abs(transmissibility(reduced_network(front.parameters[i]), f)),
            label=f"{name}: J {front.objective[i]:.3g}, e {front.peak_error[i]:.2g}",
        )
    bx.set_xscale("log")
    bx.set_xlabel("frequency [Hz]")
    bx.set_ylabel("|X_head / X_seat|")
    bx.legend(fontsize=8)
    bx.grid(True, which="both", alpha=0.3)
    fig.suptitle(
        "The reduced model's trade-off: impulse-response fit (J) against the resonance peak"
    )
    save_figure(fig, path)


@renamed_parameters(folder="dest")
def write_pareto(dest, front: ParetoFront, command: str = "") -> List[str]:
    """Write ``pareto_front.csv``, ``pareto_front.png`` and ``pareto-<point>.json`` files.

    Each parameter file is a reduced model that every command reads, with
    provenance: method, library, seed, its objective values, the reference,
    the date and the bodyvib version. All written atomically.

    Parameters
    ----------
    dest : str or os.PathLike
        Created if missing.
    front : ParetoFront
        The front to publish, from :func:`pareto_front`.
    command : str
        The command that made it (recorded).

    Returns
    -------
    list of str
        The table, the plot and one parameter file per chosen point, in that order.
    """
    from importlib.metadata import version

    dest = os.fspath(dest)
    os.makedirs(dest, exist_ok=True)
    chosen = chosen_points(front)
    files = [os.path.join(dest, "pareto_front.csv"), os.path.join(dest, "pareto_front.png")]
    atomic_write_text(files[0], _table(front))
    _plot(front, chosen, files[1])
    t, ref = front.target, front.reference_peak
    date = datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat()
    for name, i in chosen.items():
        (m, f), J, e = front.peak[i], float(front.objective[i]), float(front.peak_error[i])
        prov = {
            "source": "a point of the Pareto front of the reduced 3-DOF model of Balci & "
            "Gundogdu (2025), Fig. 2: paper Eq. 3 against the transmissibility peak "
            "error, by NSGA-II (bodyvib.fit.pareto_front)",
            "point": name,
            "command": command,
            "date": date,
            "bodyvib_version": __version__,
            "reference_model": t.reference.name,
            "method": "NSGA-II",
            "library": f"pymoo {version('pymoo')} (pymoo.algorithms.moo.nsga2.NSGA2, SBX, "
            "polynomial mutation), first population holding the GA's optimum",
            "seed": front.seed,
            "settings": dict(front.settings),
            "objectives": {
                "J_per_s": J,
                "J_definition": "paper Eq. 3, pairs "
                + ", ".join(f"{k}={v:g}" for k, v in t.pairs.items()),
                "peak_error": e,
                "peak_error_definition": "max(|dM| / (0.10 M_ref), |df| / 0.5 Hz) of the "
                "seat-to-head |T| peak over 0.5-20 Hz",
                "peak_modulus": float(m),
                "peak_frequency_hz": float(f),
                "reference_peak_modulus": float(ref[0]),
                "reference_peak_frequency_hz": float(ref[1]),
            },
            "total_mass_kg": t.total_mass,
        }
        net = reduced_network(
            front.parameters[i],
            name=f"reduced-pareto-{name}-{t.name}",
            description=f"Reduced 3-DOF model, the '{name}' point of the "
            f"trade-off J / peak error against '{t.name}': "
            f"J {J:.4g} 1/s, |T| peak {m:.3f} at {f:.2f} Hz "
            f"(reference {ref[0]:.3f} at {ref[1]:.2f} Hz).",
            provenance=prov,
        )
        path = os.path.join(dest, f"pareto-{name}.json")
        save_model(net, path)
        files.append(path)
    return files
