"""Figures of an internal force record: r.m.s., peak and the time of the peak.

The body models name the forces in their neck and lumbar elements (newtons, positive
in compression). A run reports each by its r.m.s. over the run, its peak (the largest
magnitude, compression or tension, with its sign) and the time the peak occurs.
:func:`force_figures` takes a whole record; :class:`ForceStream` the same record block
by block, so a run of any length keeps no history.
"""

import math
from dataclasses import asdict, dataclass

import numpy as np

from bodyvib.runtime.errors import BodyvibError

__all__ = ["ForceFigures", "ForceStream", "force_figures"]


@dataclass(frozen=True)
class ForceFigures:
    """Figures of one force record.

    Attributes
    ----------
    rms : float
        Root mean square over the record, N.
    peak : float
        The sample of largest magnitude, with its sign (+ compression), N.
    peak_time_s : float
        Time of that sample, s (the first one if several share it).
    """

    rms: float
    peak: float
    peak_time_s: float

    def to_dict(self) -> dict:
        """``{"rms", "peak", "peak_time_s"}``."""
        return asdict(self)


class ForceStream:
    """:func:`force_figures` of a record given block by block.

    Parameters
    ----------
    step : float
        Sample spacing, s; sample ``k`` is at ``k * step``.

    Examples
    --------
    >>> s = ForceStream(0.5)
    >>> s.update([1.0, -3.0]); s.update([2.0])
    >>> s.figures()
    ForceFigures(rms=2.160246899469287, peak=-3.0, peak_time_s=0.5)
    """

    def __init__(self, step: float):
        self._h = float(step)
        self._n = 0
        self._sq = 0.0
        self._peak = 0.0
        self._k = 0

    def update(self, force) -> None:
        """Add the next samples of the record (N)."""
        f = np.asarray(force, dtype=float).ravel()
        if f.size == 0:
            return
        i = int(np.argmax(np.abs(f)))
        if self._n == 0 or abs(f[i]) > abs(self._peak):
            self._peak, self._k = float(f[i]), self._n + i
        self._sq += float(np.dot(f, f))
        self._n += f.size

    def figures(self) -> ForceFigures:
        """The figures of the samples so far.

        Raises
        ------
        BodyvibError
            No sample given yet.
        """
        if self._n == 0:
            raise BodyvibError("no force samples: the figures need a record")
        return ForceFigures(
            rms=math.sqrt(self._sq / self._n), peak=self._peak, peak_time_s=self._k * self._h
        )


def force_figures(force, step: float) -> ForceFigures:
    """Figures of a force record sampled every ``step`` seconds from ``t = 0``.

    Parameters
    ----------
    force : array_like
        The force, N (+ compression).
    step : float
        Sample spacing, s.

    Returns
    -------
    ForceFigures

    Raises
    ------
    BodyvibError
        An empty record.

    Examples
    --------
    >>> force_figures([0.0, 4.0, -2.0], 0.1)
    ForceFigures(rms=2.581988897471611, peak=4.0, peak_time_s=0.1)
    """
    s = ForceStream(step)
    s.update(force)
    return s.figures()
