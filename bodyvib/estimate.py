"""Seat-to-head transmissibility estimated from a run (Welch's H1 estimator).

A co-simulation gives seat and head accelerations; their cross and auto
spectra give the transmissibility the run shows, to set beside the model's
own (:func:`bodyvib.frequency.transmissibility`).
"""

from dataclasses import asdict, dataclass
from typing import Dict, List

import numpy as np

from .frequency import find_peaks
from .runtime.errors import BodyvibError

__all__ = ["TRANSMISSIBILITY_BAND_HZ", "Peak", "TransmissibilityEstimate",
           "estimate_transmissibility"]

#: Band over which transmissibility is estimated and compared, Hz.
TRANSMISSIBILITY_BAND_HZ = (0.5, 20.0)


@dataclass(frozen=True)
class Peak:
    """A peak of a transmissibility modulus: where (Hz) and how high (dimensionless)."""

    frequency_hz: float
    modulus: float

    def to_dict(self) -> Dict[str, float]:
        """``{"frequency_hz", "modulus"}`` for JSON."""
        return asdict(self)


@dataclass(frozen=True)
class TransmissibilityEstimate:
    """Seat-to-head transmissibility estimated from a run (:func:`estimate_transmissibility`).

    Attributes
    ----------
    frequency_hz, modulus, phase_deg, coherence : list of float
        Over :data:`TRANSMISSIBILITY_BAND_HZ`: frequency (Hz), modulus and
        unwrapped phase (degrees) of the H1 estimate, and the seat-head coherence.
    peak : Peak
        The highest peak of the modulus.
    """

    frequency_hz: List[float]
    modulus: List[float]
    phase_deg: List[float]
    coherence: List[float]
    peak: Peak

    def to_dict(self) -> Dict[str, object]:
        """The estimate as a JSON-ready dict (lists and the peak as a dict)."""
        return asdict(self)


def estimate_transmissibility(seat_acceleration, head_acceleration, fs: float,
                              segment_s: float = 8.0) -> TransmissibilityEstimate:
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
    TransmissibilityEstimate
        ``frequency_hz``, ``modulus``, ``phase_deg``, ``coherence`` (lists over
        :data:`TRANSMISSIBILITY_BAND_HZ`) and ``peak`` (the highest peak).

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
    return TransmissibilityEstimate(
        frequency_hz=f[sel].tolist(),
        modulus=mod.tolist(),
        phase_deg=np.degrees(np.unwrap(np.angle(H))).tolist(),
        coherence=coh[sel].tolist(),
        peak=Peak(frequency_hz=float(top["frequency_hz"]), modulus=float(top["modulus"])),
    )
