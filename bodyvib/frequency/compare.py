"""Seat-to-head transmissibility of several models side by side (``bodyvib frf``).

The comparison of the paper's Fig. 3 (without its experimental points):
modulus and phase of ``T = X_head / X_seat`` over 0.5-31.5 Hz, the range of
ISO 7962's data, with each model's resonance peaks.
"""

from dataclasses import dataclass
from typing import Dict, Tuple

import numpy as np

from ..models import DEFAULT_MODELS, load_model
from ..process.limits import require_memory
from ..runtime.errors import BodyvibError
from .response import Peak, find_peaks, transmissibility

__all__ = [
    "THIRD_OCTAVE_HZ",
    "ModelTransmissibility",
    "TransmissibilityComparison",
    "compare_transmissibility",
    "format_table",
    "plot_transmissibility",
    "DEFAULT_MODELS",
]

#: One-third-octave centre frequencies of ISO 7962's range, Hz.
THIRD_OCTAVE_HZ = (
    0.5, 0.63, 0.8, 1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0,
    5.0, 6.3, 8.0, 10.0, 12.5, 16.0, 20.0, 25.0, 31.5,
)  # fmt: skip

#: Working memory per frequency point and model in :func:`compare_transmissibility`,
#: bytes: the complex response, modulus and phase arrays, the two lists of Python floats,
#: the JSON text and the plot's copies (measured peak RSS of 1e6 points: about 150 B).
BYTES_PER_POINT = 200


@dataclass(frozen=True)
class ModelTransmissibility:
    """One model's seat-to-head transmissibility on the comparison's grid.

    Attributes
    ----------
    modulus : ndarray
        ``|T|`` (dimensionless).
    phase_deg : ndarray
        Phase, unwrapped, degrees (negative = head lags seat).
    peaks : tuple of Peak
        Resonance peaks, in increasing frequency.
    """

    modulus: np.ndarray
    phase_deg: np.ndarray
    peaks: Tuple[Peak, ...]

    def to_dict(self) -> dict:
        """``{"modulus": [...], "phase_deg": [...], "peaks": [{"frequency_hz", "modulus"}]}``."""
        return {
            "modulus": self.modulus.tolist(),
            "phase_deg": self.phase_deg.tolist(),
            "peaks": [p.to_dict() for p in self.peaks],
        }


@dataclass(frozen=True)
class TransmissibilityComparison:
    """Several models' transmissibility on one frequency grid (:func:`compare_transmissibility`):
    ``frequency_hz`` (the common logarithmic grid, Hz) and ``models`` (label ->
    :class:`ModelTransmissibility`, in the order given)."""

    frequency_hz: np.ndarray
    models: Dict[str, ModelTransmissibility]

    def to_dict(self) -> dict:
        """The JSON document of ``bodyvib frf --json``: ``{"frequency_hz": [...], "models":
        {NAME: {"modulus", "phase_deg", "peaks"}}}``."""
        return {
            "frequency_hz": self.frequency_hz.tolist(),
            "models": {k: m.to_dict() for k, m in self.models.items()},
        }


def compare_transmissibility(
    models=DEFAULT_MODELS, f_min=0.5, f_max=31.5, points=1200
) -> TransmissibilityComparison:
    """Transmissibility of each model on a common logarithmic frequency grid.

    Parameters
    ----------
    models : sequence of str or Network
        Shipped model names, parameter-file paths, or networks.
    f_min, f_max : float
        Frequency range in Hz.
    points : int
        Number of grid points (logarithmically spaced).

    Returns
    -------
    TransmissibilityComparison
        The grid and, per model, modulus, unwrapped phase (degrees) and peaks; its
        ``to_dict()`` is the JSON form. A model is listed under its name; models
        sharing one get their file name appended.

    Raises
    ------
    BodyvibError
        A bad range, an unknown or invalid model, or a model whose
        transmissibility is not finite (parameter values that overflow).

    Examples
    --------
    >>> r = compare_transmissibility(["reduced-paper"], points=200)
    >>> round(r.models["reduced-paper"].peaks[0].frequency_hz, 1)
    4.4
    """
    if not (0 < f_min < f_max < np.inf) or points < 10:
        raise BodyvibError(
            f"frequency range must satisfy 0 < fmin < fmax < inf with at least 10 points; "
            f"got fmin={f_min}, fmax={f_max}, points={points}"
        )
    nets = [(m, load_model(m) if isinstance(m, str) else m) for m in models]
    # per point and model: complex T, modulus, phase, and each as a list of Python floats
    require_memory(
        points * (16 + len(nets) * BYTES_PER_POINT),
        f"{points} frequency points for {len(nets)} model(s)",
        "use fewer points ('points'; 1200 resolve every peak of the shipped models)",
        parameters=("points",),
    )
    f = np.geomspace(f_min, f_max, points)
    curves = {}
    for (_m, net), label in zip(nets, _labels(nets)):
        T = transmissibility(net, f)
        if not np.all(np.isfinite(T)):
            k = int(np.argmin(np.isfinite(T)))
            raise BodyvibError(
                f"model '{label}': the transmissibility is not finite at {f[k]:.4g} Hz (the "
                "parameter values overflow the computation); check the parameter file"
            )
        mod = np.abs(T)
        curves[label] = ModelTransmissibility(
            modulus=mod,
            phase_deg=np.degrees(np.unwrap(np.angle(T))),
            peaks=tuple(find_peaks(f, mod)),
        )
    return TransmissibilityComparison(frequency_hz=f, models=curves)


def _labels(nets):
    """One label per model: its name, made unique by the file it came from when two share it.

    Every GA refit is named ``reduced-refit-<target>``; two such files compared in one
    call kept one curve under one key. Equal names get `` (file name)``, then ``#2``...
    """
    import os

    names = [net.name for _, net in nets]
    labels = []
    for (src, _net), name in zip(nets, names):
        label = name
        if names.count(name) > 1:
            where = os.path.basename(os.fspath(src)) if isinstance(src, (str, os.PathLike)) else ""
            label = f"{name} ({where})" if where and where != name else name
        base, i = label, 2
        while label in labels:
            label = f"{base} #{i}"
            i += 1
        labels.append(label)
    return labels


def format_table(result, frequencies_hz=THIRD_OCTAVE_HZ) -> str:
    """A text table: ``|T|`` and phase per model at the given frequencies, then the peaks.

    Parameters
    ----------
    result : TransmissibilityComparison
        From :func:`compare_transmissibility`.
    frequencies_hz : sequence of float
        Rows, Hz; those outside the computed range are left out (not extrapolated).

    Returns
    -------
    str
    """
    names = list(result.models)
    f = result.frequency_hz
    frequencies_hz = [fq for fq in frequencies_hz if f[0] <= fq <= f[-1]]
    w = max([20] + [len(n) for n in names])  # whole names: two may differ only at the end
    head = f"{'f [Hz]':>7}" + "".join(f" | {n:>{w}}" for n in names)
    sub = f"{'':>7}" + "".join(f" | {'|T| [-]':>{w - 12}} {'phase[deg]':>11}" for _ in names)
    lines = [head, sub, "-" * len(sub)]
    for fq in frequencies_hz:
        row = f"{fq:7.2f}"
        for n in names:
            r = result.models[n]
            mod = np.interp(np.log(fq), np.log(f), r.modulus)
            ph = np.interp(np.log(fq), np.log(f), r.phase_deg)
            row += f" | {mod:{w - 12}.3f} {ph:11.1f}"
        lines.append(row)
    lines.append("")
    for n in names:
        peaks = ", ".join(
            f"{p.modulus:.3f} at {p.frequency_hz:.2f} Hz" for p in result.models[n].peaks
        )
        lines.append(f"peaks of {n}: {peaks or 'none'}")
    return "\n".join(lines)


def plot_transmissibility(result, path, title="Seat-to-head transmissibility", ylabel=None):
    """Modulus and phase of every model in ``result``, peaks marked; saved to ``path``.

    Parameters
    ----------
    result : TransmissibilityComparison
        From :func:`compare_transmissibility`.
    path : str or os.PathLike
        Plot file (.png, .pdf or .svg).
    title : str
    ylabel : str, optional
        Label of the modulus axis (default: the seat-to-head ``|T|``).

    Raises
    ------
    BodyvibError
        An unsupported plot file extension.
    """
    from ..plotting import MODULUS_LABEL, new_figure, save_figure, transmissibility_axes

    fig, (ax1, ax2) = new_figure(2, 1, sharex=True, figsize=(7, 6))
    f = result.frequency_hz
    for name, r in result.models.items():
        (line,) = ax1.plot(f, r.modulus, label=name)
        for p in r.peaks:
            ax1.plot(p.frequency_hz, p.modulus, "o", color=line.get_color(), ms=4)
        ax2.plot(f, r.phase_deg, color=line.get_color(), label=name)
    transmissibility_axes(ax1, ax2, title=title, ylabel=ylabel or MODULUS_LABEL)
    ax1.legend()
    save_figure(fig, path)
