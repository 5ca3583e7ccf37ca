"""Seat-to-head transmissibility estimated from a run (Welch's H1 estimator).

A co-simulation gives seat and head accelerations; their cross and auto
spectra give the transmissibility the run shows, to set beside the model's
own (:func:`bodyvib.frequency.response.transmissibility`).
"""

from dataclasses import asdict, dataclass
from typing import Dict, List

import numpy as np

from ..runtime.errors import BodyvibError
from .response import Peak, find_peaks

__all__ = [
    "TRANSMISSIBILITY_BAND_HZ",
    "Peak",
    "TransmissibilityEstimate",
    "estimate_transmissibility",
    "TransmissibilityStream",
    "segment_length",
]

#: Band over which transmissibility is estimated and compared, Hz.
TRANSMISSIBILITY_BAND_HZ = (0.5, 20.0)


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


def estimate_transmissibility(
    seat_acceleration, head_acceleration, fs: float, segment_s: float = 8.0
) -> TransmissibilityEstimate:
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
    nperseg = segment_length(x.size, fs, segment_s)
    f, pxy = csd(x, y, fs=fs, nperseg=nperseg)
    _, pxx = welch(x, fs=fs, nperseg=nperseg)
    _, coh = coherence(x, y, fs=fs, nperseg=nperseg)
    return _estimate(f, pxy, pxx, coh, x.size / fs, fs / nperseg)


def segment_length(samples: int, fs: float, segment_s: float = 8.0) -> int:
    """Welch segment length of :func:`estimate_transmissibility` for a record.

    Parameters
    ----------
    samples : int
        Length of the record.
    fs : float
        Sampling rate, Hz.
    segment_s : float
        Wanted segment length, s (shortened to a quarter of the record).

    Returns
    -------
    int
        Samples per Welch segment, at least 16.

    Raises
    ------
    BodyvibError
        A record too short for 16-sample segments.
    """
    nperseg = int(min(segment_s * fs, samples // 4))
    if nperseg < 16:
        raise BodyvibError("record too short to estimate a transmissibility; simulate longer")
    return nperseg


def _estimate(f, pxy, pxx, coh, duration_s, resolution_hz) -> TransmissibilityEstimate:
    lo, hi = TRANSMISSIBILITY_BAND_HZ
    sel = (f >= lo) & (f <= hi) & (pxx > 0)
    if sel.sum() < 3:
        raise BodyvibError(
            f"a {duration_s:g} s record resolves only {resolution_hz:.3g} Hz, too coarse for "
            f"the transmissibility over {lo:g}-{hi:g} Hz; simulate longer (a few seconds)"
        )
    H = pxy[sel] / pxx[sel]
    mod = np.abs(H)
    peaks = find_peaks(f[sel], mod)
    top = (
        max(peaks, key=lambda p: p.modulus)
        if peaks
        else Peak(frequency_hz=float(f[sel][np.argmax(mod)]), modulus=float(mod.max()))
    )
    return TransmissibilityEstimate(
        frequency_hz=f[sel].tolist(),
        modulus=mod.tolist(),
        phase_deg=np.degrees(np.unwrap(np.angle(H))).tolist(),
        coherence=coh[sel].tolist(),
        peak=top,
    )


class TransmissibilityStream:
    """:func:`estimate_transmissibility` computed as the samples arrive (Welch, H1).

    The segments are those of :func:`scipy.signal.csd` with the same settings (Hann
    window, 50 % overlap, each segment's mean removed, only whole segments); their
    cross and auto spectra are summed as each segment completes, so only the last
    segment's samples are kept. The estimate ``P_sh / P_ss`` and the coherence are
    ratios of those sums: the same numbers as :func:`estimate_transmissibility` on the
    whole record, to rounding.

    Parameters
    ----------
    fs : float
        Sampling rate, Hz.
    samples : int
        Length of the whole record (it sets the segment length, as for the whole-record
        function).
    segment_s : float
        Wanted segment length, s.

    Raises
    ------
    BodyvibError
        A record too short (see :func:`segment_length`).
    """

    def __init__(self, fs: float, samples: int, segment_s: float = 8.0):
        from scipy.signal import get_window

        self.fs = float(fs)
        self.samples = int(samples)
        self.nperseg = segment_length(self.samples, self.fs, segment_s)
        self._hop = self.nperseg - self.nperseg // 2
        self._win = get_window("hann", self.nperseg)
        self._x = np.empty(0)
        self._y = np.empty(0)
        nf = self.nperseg // 2 + 1
        self._sxy = np.zeros(nf, complex)
        self._sxx = np.zeros(nf)
        self._syy = np.zeros(nf)
        self.segments = 0

    def update(self, seat_acceleration, head_acceleration) -> None:
        """Add the next samples of both signals.

        Parameters
        ----------
        seat_acceleration, head_acceleration : (m,) array_like
            The next samples, m/s2 (equal lengths).
        """
        x = np.concatenate([self._x, np.asarray(seat_acceleration, dtype=float)])
        y = np.concatenate([self._y, np.asarray(head_acceleration, dtype=float)])
        n, hop = self.nperseg, self._hop
        count = 0 if x.size < n else (x.size - n) // hop + 1
        if count:
            idx = np.arange(count)[:, None] * hop + np.arange(n)[None, :]
            xs, ys = x[idx], y[idx]
            X = np.fft.rfft((xs - xs.mean(axis=1, keepdims=True)) * self._win, axis=1)
            Y = np.fft.rfft((ys - ys.mean(axis=1, keepdims=True)) * self._win, axis=1)
            self._sxy += (np.conj(X) * Y).sum(axis=0)
            self._sxx += (np.abs(X) ** 2).sum(axis=0)
            self._syy += (np.abs(Y) ** 2).sum(axis=0)
            self.segments += count
        self._x, self._y = x[count * hop :], y[count * hop :]

    def result(self) -> TransmissibilityEstimate:
        """The estimate from the segments completed so far.

        Returns
        -------
        TransmissibilityEstimate

        Raises
        ------
        BodyvibError
            No whole segment yet, or too coarse a resolution.
        """
        if self.segments == 0:
            raise BodyvibError("record too short to estimate a transmissibility; simulate longer")
        f = np.fft.rfftfreq(self.nperseg, 1.0 / self.fs)
        with np.errstate(divide="ignore", invalid="ignore"):
            coh = np.abs(self._sxy) ** 2 / (self._sxx * self._syy)
        return _estimate(
            f, self._sxy, self._sxx, coh, self.samples / self.fs, self.fs / self.nperseg
        )
