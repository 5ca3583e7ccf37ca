"""Synthetic roads (ISO 8608 classes, bump, sweep), the fade-in, and a road as a table.

A road is a vertical profile ``z(x)`` [m] over the distance ``x`` [m]; a car
driving at a constant speed ``V`` [m/s] sees ``z(V t)`` and the road velocity
``V dz/dx(V t)`` (the ``road_velocity`` input of the quarter car, which the
exact discretization uses as the in-step slope).

* :class:`RandomRoad` -- ISO 8608:2016 classes A-H. The displacement PSD
  (one-sided, in spatial frequency ``n`` [cycle/m]) is
  ``Gd(n) = Gd(n0) (n / n0)^(-w)``, ``n0 = 0.1 cycle/m``, waviness ``w = 2``,
  with the class's geometric-mean ``Gd(n0) = 16 * 4^i * 1e-6 m^3`` (i = 0 for
  A ... 7 for H; the class limits are a factor 2 either side). The profile is
  the classical sum of harmonics on the grid ``n_i = i / L``::

      z(x) = sum_i sqrt(2 Gd(n_i) dn) cos(2 pi n_i x + phi_i),   dn = 1 / L

  with independent uniform phases from a seeded generator, over
  ``0.011 <= n <= 2.83 cycle/m`` (the band of ISO 8608's classification), so its
  PSD is the class's. Its slope is the same sum differentiated term by term:
  no numerical differentiation.
* :class:`BumpRoad` -- a single (1 - cos) bump: smooth slope.
* :class:`SweepRoad` -- a sine whose spatial frequency rises exponentially
  along the road: at a speed, a logarithmic frequency sweep.

:func:`make_road` builds any of them from a short name (``"C"``, ``"bump"``,
``"sweep"``) for a speed and a duration.
"""

import functools
import math
from dataclasses import dataclass, field
from typing import Tuple

import numpy as np

from bodyvib.process import interrupts
from bodyvib.process.limits import require_memory
from bodyvib.runtime.errors import BodyvibError

from .base import Road

__all__ = [
    "ISO8608_CLASSES",
    "N0",
    "N_BAND",
    "class_psd_n0",
    "displacement_psd",
    "RandomRoad",
    "BumpRoad",
    "SweepRoad",
    "TaperedRoad",
    "random_road",
    "track_coherence",
    "two_track_road",
    "road_source",
    "axle_road_source",
    "wheel_road_source",
    "road_table",
    "lead_in_period",
    "make_road",
    "road_input",
    "table_spacing",
]

#: ISO 8608 road classes, smoothest first.
ISO8608_CLASSES = "ABCDEFGH"
#: Reference spatial frequency of ISO 8608, cycle/m.
N0 = 0.1
#: Memory per harmonic of a random road, bytes: its index, frequency, amplitude and phase
#: while it is made, then frequency, amplitude, phase and the weights of an evaluation (the
#: chirp-z transform works through the harmonics 16384 at a time).
BYTES_PER_HARMONIC = 64

#: Band of spatial frequencies synthesized by default, cycle/m (ISO 8608's).
N_BAND = (0.011, 2.83)


def _class_index(road_class: str) -> int:
    c = str(road_class).strip().upper()
    if len(c) != 1 or c not in ISO8608_CLASSES:
        raise BodyvibError(
            f"unknown ISO 8608 road class '{road_class}'; use one of " + ", ".join(ISO8608_CLASSES)
        )
    return ISO8608_CLASSES.index(c)


def class_psd_n0(road_class: str) -> float:
    """Geometric-mean displacement PSD ``Gd(n0)`` of an ISO 8608 class, in m^3.

    Parameters
    ----------
    road_class : str
        ``"A"`` (very good) ... ``"H"`` (very poor).

    Returns
    -------
    float
        ``16 * 4^i * 1e-6`` m^3 (i = 0 for A); the class spans half to twice this.

    Examples
    --------
    >>> class_psd_n0("C")
    0.000256
    """
    return 16e-6 * 4 ** _class_index(road_class)


def displacement_psd(n, road_class: str, waviness: float = 2.0) -> np.ndarray:
    """ISO 8608 displacement PSD ``Gd(n) = Gd(n0) (n/n0)^-w`` in m^3 (one-sided).

    Parameters
    ----------
    n : array_like
        Spatial frequencies in cycle/m, positive.
    road_class : str
        ``"A"`` ... ``"H"``.
    waviness : float
        Exponent ``w`` (2 in ISO 8608).

    Returns
    -------
    ndarray
    """
    n = np.asarray(n, dtype=float)
    return class_psd_n0(road_class) * (n / N0) ** (-waviness)


@dataclass
class RandomRoad(Road):
    """A random road as a finite sum of harmonics (see the module docstring).

    Parameters
    ----------
    n : (k,) ndarray
        Spatial frequencies, cycle/m.
    amplitude : (k,) ndarray
        Harmonic amplitudes, m.
    phase : (k,) ndarray
        Phases, rad.
    length : float
        Length over which the profile is defined (it repeats after that), m.
    name : str
        Label, e.g. ``"ISO 8608 class C"``.
    info : dict
        Class, seed and band for reports.
    """

    n: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    length: float
    name: str = "random road"
    info: dict = field(default_factory=dict)

    # Work per piece, each followed by a safe point for a signal (a few ms to ~0.1 s): the
    # direct sum takes points a few at a time so that points times harmonics stays under
    # _TERMS; the chirp-z transform takes the harmonics _HARMONICS and the grid _POINTS
    # at a time. One piece of the whole grid took 1-2 s per harmonic chunk at 3e6 points.
    _TERMS = 1 << 22
    _HARMONICS = 16384
    _POINTS = 1 << 16

    def _sum(self, x, derivative: bool) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        flat = x.ravel()
        k = 2 * np.pi * self.n
        weights = self.amplitude * k if derivative else self.amplitude
        if flat.size >= 64:
            dx = (flat[-1] - flat[0]) / (flat.size - 1)
            if dx > 0 and np.max(np.abs(np.diff(flat) - dx)) <= 1e-9 * dx:
                out = np.empty_like(flat)
                for s in range(0, flat.size, self._POINTS):
                    m = min(self._POINTS, flat.size - s)
                    out[s : s + m] = self._uniform(flat[0] + s * dx, dx, m, weights, derivative)
                return out.reshape(x.shape)
        out = np.empty_like(flat)
        rows = max(1, self._TERMS // max(1, k.size))
        for s in range(0, flat.size, rows):
            interrupts.check()
            arg = np.outer(flat[s : s + rows], k) + self.phase
            out[s : s + rows] = (-np.sin(arg) if derivative else np.cos(arg)) @ weights
        return out.reshape(x.shape)

    def _uniform(self, x0, dx, count, weights, derivative):
        """The harmonic sum on ``x0 + j dx`` by a chirp-z transform (exact, O(N log N)).

        With ``n_i = (i0 + m) / L``, ``z_j = Re[e^{2 pi i (i0 j dx / L)}
        sum_m c_m e^{2 pi i m j dx / L}]``: a chirp-z transform of the complex
        amplitudes ``c_m`` along the unit circle.
        """
        step = dx / self.length
        out = np.zeros(count)
        # harmonics a chunk at a time: the transform's buffers stay (chunk + count) long
        # however long the road (a run's length sets the number of harmonics)
        for a in range(0, self.n.size, self._HARMONICS):
            interrupts.check()
            n = self.n[a : a + self._HARMONICS]
            c = weights[a : a + self._HARMONICS] * np.exp(
                1j * (self.phase[a : a + self._HARMONICS] + 2 * np.pi * n * x0)
            )
            if derivative:
                c = 1j * c
            i0 = round(n[0] * self.length)
            sums = _chirp_z(c.size, count, step)(c)
            out += np.real(_shift(count, step, i0) * sums)
        return out

    def displacement(self, x) -> np.ndarray:
        """Profile height at distances ``x`` (m), in m."""
        return self._sum(x, derivative=False)

    def slope(self, x) -> np.ndarray:
        """Exact slope ``dz/dx`` (term-by-term derivative of the harmonic sum)."""
        return self._sum(x, derivative=True)

    def describe(self) -> dict:
        return {**super().describe(), "length_m": self.length, **self.info}


# 16 set-ups of at most 2.6 MB each (16384 harmonics to 65536 points): a speed of a
# full car or a half car takes two, its rear wheels' grid starting later (fewer points)
@functools.lru_cache(maxsize=16)
def _chirp_z(points: int, count: int, step: float) -> "_ChirpZ":
    """The chirp-z transform of ``points`` amplitudes to ``count`` points ``e^{2 pi i step j}``.

    Its set-up (the chirp ``w^(k^2/2)`` and its FFT) costs twice the transform itself
    and depends only on the sizes and the step, which the roads of a sweep share
    (every class and seed at one speed and length): kept for the next road.
    """
    return _ChirpZ(points, count, np.exp(2j * np.pi * step))


class _ChirpZ:
    """Bluestein's chirp-z transform along the unit circle: ``y_j = sum_k x_k w^(j k)``.

    With ``j k = (j^2 + k^2 - (j - k)^2) / 2``, the sum is the chirp ``w^(j^2/2)``
    times the convolution of ``x_k w^(k^2/2)`` with ``w^(-k^2/2)``, done by FFTs of
    a length of small prime factors. The arithmetic is that of
    :class:`scipy.signal.CZT` (Rabiner, Schafer and Rader 1969) step for step, on
    :mod:`numpy.fft`, which imports in a millisecond where :mod:`scipy.fft` takes
    0.1-0.3 s of a sweep worker's start: since numpy 2.0 both run the same
    pocketfft code, and the transform is the same bits (a test compares them).

    Parameters
    ----------
    points : int
        Length of the input ``x``.
    count : int
        Number of outputs.
    w : complex
        The ratio between output points (here ``e^{2 pi i step}``).
    """

    def __init__(self, points: int, count: int, w: complex):
        k = np.arange(max(count, points), dtype=np.min_scalar_type(-(max(count, points) ** 2)))
        wk2 = w ** (k**2 / 2.0)
        self._nfft = _fast_length(points + count - 1)
        self._wk2_in = wk2[:points]
        self._fwk2 = np.fft.fft(1 / np.hstack((wk2[points - 1 : 0 : -1], wk2[:count])), self._nfft)
        self._wk2_out = wk2[:count]
        self._out = slice(points - 1, points + count - 1)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        y = np.fft.ifft(self._fwk2 * np.fft.fft(x * self._wk2_in, self._nfft))
        return y[self._out] * self._wk2_out


def _fast_length(n: int) -> int:
    """The least length ``>= n`` whose prime factors are 2, 3, 5, 7 and 11 (pocketfft's fast sizes).

    The choice of :func:`scipy.fft.next_fast_len` for complex transforms.

    Examples
    --------
    >>> _fast_length(61234), _fast_length(13)
    (61236, 14)
    """
    while True:
        m = n
        for p in (2, 3, 5, 7, 11):
            while m % p == 0:
                m //= p
        if m == 1:
            return n
        n += 1


@functools.lru_cache(maxsize=32)  # a grid piece's shifts for up to 32 harmonic chunks: <= 32 MB
def _shift(count: int, step: float, i0: int) -> np.ndarray:
    """``e^{2 pi i (i0 step j mod 1)}``, ``j < count``: the first harmonic's phase at each point.

    Read-only; kept, like :func:`_chirp_z`, for the next road of the same grid.
    """
    j = np.arange(count)
    shift = np.exp(2j * np.pi * ((i0 * step * j) % 1.0))
    shift.flags.writeable = False
    return shift


def random_road(
    road_class: str = "C",
    length: float = 600.0,
    seed: int = 0,
    band: Tuple[float, float] = N_BAND,
    waviness: float = 2.0,
) -> RandomRoad:
    """An ISO 8608 random road of a class, reproducible from a seed.

    Parameters
    ----------
    road_class : str
        ``"A"`` ... ``"H"``.
    length : float
        Road length in m (the harmonic spacing is ``1/length``).
    seed : int
        Seed of the phase generator (numpy ``default_rng``).
    band : (float, float)
        Spatial-frequency band in cycle/m.
    waviness : float
        PSD exponent (2 in ISO 8608).

    Returns
    -------
    RandomRoad

    Raises
    ------
    BodyvibError
        Unknown class, non-positive length, a negative seed, or a band that
        holds no harmonic.

    Examples
    --------
    >>> road = random_road("C", length=200.0, seed=1)
    >>> road.displacement([0.0, 1.0]).shape
    (2,)
    """
    idx = _class_index(road_class)
    if not (math.isfinite(length) and length > 0):
        raise BodyvibError(f"road length must be a positive number of metres, got {length!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise BodyvibError(f"road seed must be a non-negative integer, got {seed!r}")
    lo, hi = band
    if not (0 < lo < hi):
        raise BodyvibError(f"spatial-frequency band must satisfy 0 < low < high, got {band}")
    dn = 1.0 / length
    count = (hi - lo) * length
    require_memory(
        count * BYTES_PER_HARMONIC,
        f"an ISO 8608 road of {length:.4g} m ({count:.3g} harmonics)",
        "shorten the run ('duration') or lower 'speed'",
        parameters=("duration", "speed"),
    )
    i = np.arange(max(1, math.ceil(lo / dn)), math.floor(hi / dn) + 1)
    if i.size == 0:
        raise BodyvibError(
            f"a {length:g} m road holds no harmonic in {lo}-{hi} cycle/m; make it longer"
        )
    n = i * dn
    amp = np.sqrt(2 * displacement_psd(n, road_class, waviness) * dn)
    phase = np.random.default_rng(seed).uniform(0, 2 * np.pi, n.size)
    cls = ISO8608_CLASSES[idx]
    return RandomRoad(
        n=n,
        amplitude=amp,
        phase=phase,
        length=float(length),
        name=f"ISO 8608 class {cls}",
        info={
            "iso8608_class": cls,
            "Gd_n0_m3": class_psd_n0(cls),
            "seed": seed,
            "band_cycles_per_m": [lo, hi],
            "waviness": waviness,
        },
    )


def track_coherence(n, track_width: float, waviness: float = 2.0) -> np.ndarray:
    """Left/right correlation of an isotropic ISO 8608 surface, per spatial frequency.

    Two parallel tracks ``B`` apart on a homogeneous isotropic surface whose
    longitudinal PSD falls as ``n^-2`` have the real, normalised cross-spectral density

        ``rho(n) = 2 pi n B K1(2 pi n B)``

    (``K1``: the modified Bessel function of the second kind, order 1), so their
    coherence is ``rho^2`` (Dodds & Robson, 1973, *The description of road surface
    roughness*, J. Sound Vib. 31(2), 175-183, for the isotropic surface with
    waviness 2). ``rho`` is 1 at long wavelengths, where both wheels ride the same
    undulation, and falls to 0 for wavelengths short against the track width.

    Parameters
    ----------
    n : array_like
        Spatial frequencies, cycle/m (positive).
    track_width : float
        Distance between the tracks, m (positive).
    waviness : float
        The PSD exponent; the closed form holds for 2 (ISO 8608's) only.

    Returns
    -------
    ndarray
        ``rho(n)``, between 0 and 1.

    Raises
    ------
    BodyvibError
        A waviness other than 2, or a track width that is not a positive number.

    Examples
    --------
    >>> rho = track_coherence([0.01, 0.5, 5.0], 1.5)
    >>> [round(float(r), 3) for r in rho]
    [0.987, 0.026, 0.0]
    """
    if waviness != 2.0:
        raise BodyvibError(
            f"the two-track coherence model holds for waviness 2 only, got {waviness!r}"
        )
    _check_positive(track_width, "track width", "m")
    from scipy.special import k1  # only two-track roads need it

    u = 2 * np.pi * np.asarray(n, dtype=float) * float(track_width)
    with np.errstate(over="ignore", invalid="ignore"):
        rho = np.where(u > 700, 0.0, u * k1(np.minimum(u, 700)))
    return np.where(u > 0, rho, 1.0)


def two_track_road(
    road_class: str = "C",
    track_width: float = 1.5,
    length: float = 600.0,
    seed: int = 0,
    band: Tuple[float, float] = N_BAND,
) -> Tuple[RandomRoad, RandomRoad]:
    """The left and right tracks of an ISO 8608 road, correlated as an isotropic surface.

    Each track alone is :func:`random_road`'s profile of the class (the left one is
    exactly ``random_road(road_class, length, seed, band)``). The right track shares
    each harmonic's phase in the proportion :func:`track_coherence` gives and takes
    an independent phase for the rest:

        ``z_R = sum_i a_i [rho_i cos(2 pi n_i x + phi_i)
        + sqrt(1 - rho_i^2) cos(2 pi n_i x + psi_i)]``

    so the right track has the class's PSD in expectation, and their cross-spectrum is
    ``rho(n) Gd(n)``: coherence ``rho^2``.

    Parameters
    ----------
    road_class : str
        ``"A"`` ... ``"H"``.
    track_width : float
        Distance between the wheel tracks, m.
    length : float
        Road length, m.
    seed : int
        Seed of both tracks' phases.
    band : (float, float)
        Spatial-frequency band, cycle/m.

    Returns
    -------
    (RandomRoad, RandomRoad)
        The left and the right track.

    Raises
    ------
    BodyvibError
        As :func:`random_road`, or a bad track width.

    Examples
    --------
    >>> left, right = two_track_road("C", track_width=1.5, length=200.0, seed=1)
    >>> bool(np.allclose(left.displacement([0.0]), random_road("C", 200.0, 1).displacement([0.0])))
    True
    """
    left = random_road(road_class, length, seed, band)
    rho = track_coherence(left.n, track_width)
    psi = np.random.default_rng([seed, 1]).uniform(0, 2 * np.pi, left.n.size)
    c = left.amplitude * (rho * np.exp(1j * left.phase) + np.sqrt(1 - rho**2) * np.exp(1j * psi))
    right = RandomRoad(
        n=left.n,
        amplitude=np.abs(c),
        phase=np.angle(c),
        length=left.length,
        name=f"{left.name}, right track",
        info={**left.info, "track_width_m": float(track_width)},
    )
    left.name = f"{left.name}, left track"
    left.info["track_width_m"] = float(track_width)
    return left, right


@dataclass
class BumpRoad(Road):
    """A single cosine bump ``z = h (1 - cos(2 pi (x - x0) / l)) / 2`` on ``[x0, x0 + l]``.

    Parameters
    ----------
    height : float
        Bump height h, m (negative for a pothole).
    bump_length : float
        Bump length l along the road, m.
    start : float
        Distance x0 where it begins, m.
    """

    height: float = 0.03
    bump_length: float = 1.0
    start: float = 10.0
    name: str = "cosine bump"

    def _phase(self, x):
        x = np.asarray(x, dtype=float)
        return x, (x >= self.start) & (x <= self.start + self.bump_length)

    def displacement(self, x) -> np.ndarray:
        """Profile height at distances ``x`` (m), in m."""
        x, on = self._phase(x)
        return np.where(
            on,
            0.5 * self.height * (1 - np.cos(2 * np.pi * (x - self.start) / self.bump_length)),
            0.0,
        )

    def slope(self, x) -> np.ndarray:
        """Exact slope ``dz/dx``."""
        x, on = self._phase(x)
        w = 2 * np.pi / self.bump_length
        return np.where(on, 0.5 * self.height * w * np.sin(w * (x - self.start)), 0.0)

    def describe(self) -> dict:
        return {
            **super().describe(),
            "height_m": self.height,
            "length_m": self.bump_length,
            "start_m": self.start,
        }


@dataclass
class SweepRoad(Road):
    """A sine of constant amplitude whose spatial frequency rises exponentially.

    ``z(x) = A sin(phi(x))`` with local frequency ``n(x) = n_start (n_stop/n_start)^(x/L)``
    for ``0 <= x <= L`` (zero beyond), so that at a speed V the car sees a
    logarithmic sweep from ``V n_start`` to ``V n_stop`` Hz.

    Parameters
    ----------
    amplitude : float
        A, m.
    n_start, n_stop : float
        Spatial frequencies at the start and the end, cycle/m.
    length : float
        L, m.
    """

    amplitude: float = 0.005
    n_start: float = 0.025
    n_stop: float = 1.0
    length: float = 600.0
    name: str = "logarithmic sine sweep"

    def _phi(self, x):
        r = math.log(self.n_stop / self.n_start) / self.length
        return 2 * np.pi * self.n_start * np.expm1(r * x) / r, self.n_start * np.exp(r * x)

    def displacement(self, x) -> np.ndarray:
        """Profile height at distances ``x`` (m), in m."""
        x = np.asarray(x, dtype=float)
        phi, _ = self._phi(x)
        return np.where((x >= 0) & (x <= self.length), self.amplitude * np.sin(phi), 0.0)

    def slope(self, x) -> np.ndarray:
        """Exact slope ``dz/dx``."""
        x = np.asarray(x, dtype=float)
        phi, n = self._phi(x)
        return np.where(
            (x >= 0) & (x <= self.length), self.amplitude * 2 * np.pi * n * np.cos(phi), 0.0
        )

    def describe(self) -> dict:
        return {
            **super().describe(),
            "amplitude_m": self.amplitude,
            "n_start_cycles_per_m": self.n_start,
            "n_stop_cycles_per_m": self.n_stop,
            "length_m": self.length,
        }


def make_road(spec: str, speed: float, duration: float, seed: int = 0) -> Road:
    """A road from a short name, long enough for ``duration`` seconds at ``speed``.

    Parameters
    ----------
    spec : str
        ``"A"`` ... ``"H"`` (ISO 8608 class), ``"bump"`` (3 cm, 1 m long cosine
        bump 10 m ahead), ``"sweep"`` (5 mm sine sweeping 0.5-20 Hz at that
        speed over the duration) or a shape of the bump library with its
        dimensions, ``"hump:h=0.075,l=3.7"`` (:mod:`bodyvib.vehicle.road.bumps`).
    speed : float
        Vehicle speed, m/s (positive).
    duration : float
        Simulated time, s (positive).
    seed : int
        Seed for a random road.

    Returns
    -------
    Road

    Raises
    ------
    BodyvibError
        Unknown road, non-positive speed or duration, a negative seed, a bad bump
        spec or a bump that ends beyond the run's ``speed * duration``.
    """
    _check_positive(speed, "speed", "m/s")
    _check_positive(duration, "duration", "s")
    s = str(spec).strip()
    length = speed * duration
    if s.lower() == "bump":
        return BumpRoad()
    from .bumps import is_bump_spec, parse_bump

    if is_bump_spec(s):
        bump = parse_bump(s)
        if bump.end > length:
            raise BodyvibError(
                f"bump '{bump.name}' ends {bump.end:g} m down the road, but the road is "
                f"{length:g} m long ({speed:g} m/s for {duration:g} s); lengthen the run "
                "('duration'; road_length for Road.fmu) or move the bump (at=)",
                parameters=("duration", "road_length"),
            )
        return bump
    if s.lower() == "sweep":
        return SweepRoad(n_start=0.5 / speed, n_stop=20.0 / speed, length=length)
    if len(s) == 1 and s.upper() in ISO8608_CLASSES:
        # one extra metre so the last sample never wraps onto the start
        return random_road(s.upper(), length=length + 1.0, seed=seed)
    raise BodyvibError(
        f"unknown road '{spec}'; use an ISO 8608 class A-H, 'bump', 'sweep', a bump shape "
        "(hump, table, sine, halfsine, pothole, e.g. 'hump:h=0.075,l=3.7') or a road file "
        "(.crg, .csv, .txt, .erd)"
    )


def _check_positive(value, what, unit):
    try:
        ok = math.isfinite(value) and value > 0
    except TypeError:
        ok = False
    if not ok:
        raise BodyvibError(f"{what} must be a positive number of {unit}, got {value!r}")


def road_input(road: Road, speed: float, t) -> Tuple[np.ndarray, np.ndarray]:
    """Road displacement and velocity under a wheel driving at constant speed.

    Parameters
    ----------
    road : Road
    speed : float
        m/s, positive.
    t : array_like
        Times in s (the wheel is at x = speed * t).

    Returns
    -------
    displacement : ndarray
        m.
    velocity : ndarray
        m/s (``speed * dz/dx``).

    Examples
    --------
    >>> z, v = road_input(BumpRoad(height=0.02, bump_length=1.0, start=0.0), 10.0, [0.025])
    >>> round(float(z[0]), 4)
    0.01
    """
    _check_positive(speed, "speed", "m/s")
    x = speed * np.asarray(t, dtype=float)
    z, s = road.profile(x)
    return z, speed * s


@dataclass
class TaperedRoad(Road):
    """A road faded in from level over its first metres and out over its last.

    ``z(x) = w(x) z_road(x)`` with ``w = sin^2(pi x / (2 d))`` over ``[0, d]``,
    1 in between and the mirror image over ``[L - d, L]`` (0 beyond; a road of
    infinite length only fades in): a car starting at rest at ``x = 0`` meets a
    level road with zero slope, so it starts at rest on its road whatever the
    road's first height and slope (no step at ``t = 0``, which hosts that exchange
    values only after their first step would miss), and a road repeated with
    period ``L`` stays smooth. ``d = 0`` keeps the road as it is (a car starting
    on a random road then meets the road's first height as a step).

    Every road a run drives is one of these (:func:`bodyvib.vehicle.road.driven.driven_road`),
    and ``Road.fmu`` tabulates the same one, so both start the same way.

    Parameters
    ----------
    road : Road
    length : float
        L, m (``math.inf``: no fade-out).
    taper : float
        d, m (``0 <= 2 d <= L``).
    periodic : bool
        The road repeats with period ``L`` (the wheel at ``x`` sees ``x mod L``);
        None: as the road does (a :class:`RandomRoad` of period ``L``).
    """

    road: Road = None
    length: float = 601.0
    taper: float = 5.0
    periodic: bool = None

    def __post_init__(self):
        if not (
            isinstance(self.taper, (int, float)) and math.isfinite(self.taper) and self.taper >= 0
        ):
            raise BodyvibError(f"road taper must be a non-negative number of m, got {self.taper!r}")
        if not self.length > 0:
            raise BodyvibError(f"road length must be positive, got {self.length!r} m")
        if 2 * self.taper > self.length:
            raise BodyvibError(
                f"a {self.length:g} m road cannot fade in and out over "
                f"{self.taper:g} m at each end; shorten the taper (taper_m) "
                "or lengthen the road (a longer run or profile)",
                parameters=("taper_m",),
            )
        if self.periodic is None:
            self.periodic = (
                isinstance(self.road, RandomRoad)
                and abs(self.road.length - self.length) <= 1e-12 * self.length
            )
        self.periodic = bool(self.periodic) and math.isfinite(self.length)
        ends = "at each end" if math.isfinite(self.length) else "at its start"
        self.name = (
            (
                f"{self.road.name}, faded in over {self.taper:g} m"
                if not math.isfinite(self.length)
                else f"{self.road.name}, tapered over {self.taper:g} m {ends}"
            )
            if self.taper > 0
            else self.road.name
        )

    def _where(self, x):
        """Distances for the window and for the road: a random road repeats by itself, so it
        is evaluated at ``x`` (a uniform grid stays uniform, for the fast harmonic sum)."""
        x = np.asarray(x, dtype=float)
        if not self.periodic:
            return x, x
        if x.size and x.min() >= 0 and x.max() < self.length:  # a run within one period
            xw = x
        else:
            xw = np.where((x >= 0) & (x < self.length), x, np.mod(x, self.length))
        return xw, (x if isinstance(self.road, RandomRoad) else xw)

    def _window(self, x):
        d, L = self.taper, self.length
        if d == 0:
            inside = (x >= 0) & (x <= L)
            return inside.astype(float), np.zeros_like(x)
        x = np.asarray(x, dtype=float)
        u = np.clip(np.minimum(x, L - x) / d, 0.0, 1.0).reshape(-1)
        # sin^2 only over the fades: 1 beyond them (sin(pi / 2) is 1.0 exactly), 0 outside
        w = (u >= 1.0).astype(float)
        dw = np.zeros_like(u)
        fade = (u > 0) & (u < 1)
        uf = u[fade]
        w[fade] = np.sin(0.5 * np.pi * uf) ** 2
        du = np.where(x.reshape(-1)[fade] < L / 2, 1.0, -1.0) / d
        dw[fade] = 0.5 * np.pi * np.sin(np.pi * uf) * du
        return w.reshape(x.shape), dw.reshape(x.shape)

    def displacement(self, x) -> np.ndarray:
        """Profile height at distances ``x`` (m), in m."""
        xw, x = self._where(x)
        w, _ = self._window(xw)
        return w * self.road.displacement(x)

    def slope(self, x) -> np.ndarray:
        """Exact slope ``dz/dx`` (product rule)."""
        return self.profile(x)[1]

    def profile(self, x):
        """Height and slope at ``x``, the window and the inner road's height computed once."""
        xw, x = self._where(x)
        w, dw = self._window(xw)
        z = self.road.displacement(x)
        return w * z, dw * z + w * self.road.slope(x)

    def describe(self) -> dict:
        return dict(
            self.road.describe(),
            taper_m=self.taper,
            tapered_length_m=self.length if math.isfinite(self.length) else None,
            repeats=self.periodic or bool(getattr(self.road, "periodic", False)),
        )


#: Row spacing of a road table, m (:func:`road_table`): cubic Hermite between rows
#: with exact slopes; at ISO 8608's shortest wavelength (0.35 m) the interpolation
#: error is ~(2 pi dx / lambda)^4 / 384 of that harmonic's amplitude (docs/tutorials/fmu_hosts.md, "FMUs").
TABLE_SPACING = 0.02


def table_spacing(road: Road) -> float:
    """Row spacing of a road's table, m: :data:`TABLE_SPACING`, or for a sampled profile
    (a road with a ``spacing``, possibly faded in) its spacing divided by the whole number
    that brings it to :data:`TABLE_SPACING` or below, so that every row interval lies within
    one of the profile's cubic segments, which the table then reproduces exactly.

    Examples
    --------
    >>> table_spacing(BumpRoad())
    0.02
    """
    inner = getattr(road, "road", road)
    dx = getattr(inner, "spacing", None)
    if not dx:
        return TABLE_SPACING
    return dx / math.ceil(dx / TABLE_SPACING - 1e-9)


def road_table(road: Road, length: float, spacing: float = None):
    """A road as a table of heights and slopes over ``[0, length]`` (what ``Road.fmu`` carries).

    Parameters
    ----------
    road : Road
        Any road; a :class:`RandomRoad` (or a periodic :class:`TaperedRoad`) whose
        period equals ``length`` is tabulated as periodic (its harmonic sum
        repeats exactly), any other road holds its end value beyond the table.
    length : float
        Extent of the table, m.
    spacing : float, optional
        Row spacing, m (rounded so that the rows end at ``length``); default
        :func:`table_spacing`.

    Returns
    -------
    bodyvib.runtime.tabulated.HermiteTable

    Raises
    ------
    BodyvibError
        A length or spacing that is not a positive number.
    """
    from bodyvib.runtime.tabulated import HermiteTable

    _check_positive(length, "road table length", "m")
    spacing = table_spacing(road) if spacing is None else spacing
    _check_positive(spacing, "road table spacing", "m")
    rows = max(2, int(math.ceil(length / spacing - 1e-9))) + 1
    x = np.linspace(0.0, float(length), rows)
    period = lead_in_period(road)
    if period:  # faded in once, then the profile's own period again and again
        loop = int(round((length - period) / (x[1] - x[0])))
        z, s = road.displacement(x), road.slope(x)
        z[-1], s[-1] = z[loop], s[loop]
        return HermiteTable(x, z, s, periodic=True, loop=loop)
    periodic = (isinstance(road, RandomRoad) or bool(getattr(road, "periodic", False))) and abs(
        road.length - length
    ) <= 1e-12 * length
    z, s = road.displacement(x), road.slope(x)
    if periodic:  # the sum is periodic: make the end row the start row, bit for bit
        z[-1], s[-1] = z[0], s[0]
    return HermiteTable(x, z, s, periodic=periodic)


def lead_in_period(road: Road) -> float:
    """The period of a road faded in once and then repeated, else 0.

    A :class:`TaperedRoad` of infinite length over a periodic profile (a road file driven
    repeated) fades in over its first ``taper`` metres and is the profile itself from
    there on; its table (:func:`road_table`) is that lead-in and then one period that
    repeats.

    Parameters
    ----------
    road : Road

    Returns
    -------
    float
        The profile's period, m; 0 for any other road.

    Examples
    --------
    >>> lead_in_period(TaperedRoad(BumpRoad(), 50.0, 5.0))
    0.0
    """
    inner = getattr(road, "road", None)
    if (
        isinstance(road, TaperedRoad)
        and not math.isfinite(road.length)
        and getattr(inner, "periodic", False)
        and math.isfinite(getattr(inner, "length", math.inf))
    ):
        return float(inner.length)
    return 0.0


def road_source(road: Road, length: float, speed: float = 20.0, spacing: float = None):
    """The source description and table of a road FMU (``Road.fmu``).

    Parameters
    ----------
    road : Road
    length : float
        Table extent, m.
    speed : float
        Default of the FMU's ``speed`` parameter, m/s.
    spacing : float, optional
        Row spacing, m (default :func:`table_spacing`).

    Returns
    -------
    meta : dict
        For :func:`bodyvib.fmu.pythonfmu.build_source_fmu`.
    table : bodyvib.runtime.tabulated.HermiteTable
    """
    _check_positive(speed, "speed", "m/s")
    table = road_table(road, length, spacing)
    beyond = (
        f"repeats its last {table.length - table.position[table.loop]:g} m (faded in once)"
        if table.loop
        else "repeats (the harmonic sum's period)"
        if table.periodic
        else "holds its end value"
    )
    meta = {
        "name": road.name,
        "description": (
            f"{road.name}, {table.length:g} m tabulated every "
            f"{table.length / (table.position.size - 1):g} m (heights and exact slopes, "
            f"cubic Hermite between rows); beyond the table the profile {beyond}"
        ),
        "coordinate": {"name": "distance", "unit": "m"},
        "speed": {
            "name": "speed",
            "unit": "m/s",
            "start": float(speed),
            "description": "Vehicle speed: the wheel is at distance speed * time",
        },
        "signals": [
            {
                "name": "road_displacement",
                "unit": "m",
                "description": "Road profile height under the wheel (z up)",
                "rate": {
                    "name": "road_velocity",
                    "unit": "m/s",
                    "description": "Time derivative of road_displacement (speed * profile "
                    "slope of the same interpolant)",
                },
            }
        ],
        "provenance": dict(road.describe(), generator="bodyvib.vehicle.road.synthetic"),
    }
    return meta, table


def axle_road_source(
    road: Road, length: float, wheelbase: float, speed: float = 20.0, spacing: float = None
):
    """The source description and table of a two-axle road FMU (``RoadFrontRear.fmu``).

    Two profiles over the front wheel's distance: the road under the front wheel and the
    road under the rear wheel, ``wheelbase`` behind it (level before the road begins
    under it): :func:`wheel_road_source` with one track and the wheels ``front`` and
    ``rear``. The rear column is the front column moved down by the whole number of rows
    in a wheelbase: the rear signal is the front signal's own interpolant, delayed, exactly.

    Parameters
    ----------
    road : Road
    length : float
        Table extent, m (extended to a whole number of rows).
    wheelbase : float
        Distance of the rear wheel behind the front, m, positive.
    speed : float
        Default of the FMU's ``speed`` parameter, m/s.
    spacing : float, optional
        Largest row spacing, m (default :func:`table_spacing`).

    Returns
    -------
    meta : dict
        For :func:`bodyvib.fmu.pythonfmu.build_source_fmu`.
    table : bodyvib.runtime.tabulated.HermiteTable
        Columns: front, rear; not periodic (beyond the table both hold their end values).

    Raises
    ------
    BodyvibError
        A length, wheelbase or spacing that is not a positive number.

    Examples
    --------
    >>> meta, table = axle_road_source(make_road("bump", 10.0, 4.0), 40.0, 2.8)
    >>> [s["name"] for s in meta["signals"]]
    ['road_displacement_front', 'road_displacement_rear']
    >>> k = int(round(2.8 / (table.position[1] - table.position[0])))
    >>> bool((table.value[k:, 1] == table.value[:-k, 0]).all())
    True
    """
    _check_positive(wheelbase, "wheelbase", "m")
    return wheel_road_source(
        {"front": (road, 0.0), "rear": (road, wheelbase)}, length, speed, spacing
    )


def wheel_road_source(wheels: dict, length: float, speed: float = 20.0, spacing: float = None):
    """The source description and table of a road FMU with a road pair per wheel.

    ``RoadFrontRear.fmu`` (a front and a rear wheel on one track) and ``RoadFourWheel.fmu``
    (a full car's four wheels on a left and a right track). Every column is over the first
    wheel's distance ``x``: wheel ``w`` sees its track at ``x - behind_w`` (level before
    the track begins under it). The rows are spaced so that the largest distance behind
    (the wheelbase) is a whole number of rows, and a wheel that many rows behind another on
    the same track gets that wheel's column moved down by those rows: the rear signal is
    the front signal's own interpolant, delayed, exactly.

    Parameters
    ----------
    wheels : dict of str to (Road, float)
        Wheel suffix (``front_left``, the FMU's outputs are ``road_displacement_<suffix>``
        and ``road_velocity_<suffix>``) -> its track and its distance behind the first
        wheel, m (``0`` for the first), in output order.
    length : float
        Table extent, m (extended to a whole number of rows).
    speed : float
        Default of the FMU's ``speed`` parameter, m/s.
    spacing : float, optional
        Largest row spacing, m (default :func:`table_spacing` of the first track).

    Returns
    -------
    meta : dict
        For :func:`bodyvib.fmu.pythonfmu.build_source_fmu`.
    table : bodyvib.runtime.tabulated.HermiteTable
        A column per wheel; not periodic (beyond the table every profile holds its end
        value).

    Raises
    ------
    BodyvibError
        A length or spacing that is not a positive number, a negative distance behind.

    Examples
    --------
    >>> bump = make_road("bump", 10.0, 4.0)
    >>> meta, table = wheel_road_source({"a": (bump, 0.0), "b": (bump, 1.5)}, 40.0)
    >>> [s["name"] for s in meta["signals"]]
    ['road_displacement_a', 'road_displacement_b']
    """
    from bodyvib.runtime.tabulated import HermiteTable

    _check_positive(length, "road table length", "m")
    tracks = [road for road, _ in wheels.values()]
    largest = table_spacing(tracks[0]) if spacing is None else spacing
    _check_positive(largest, "road table spacing", "m")
    behind = [float(b) for _, b in wheels.values()]
    if any(not (math.isfinite(b) and b >= 0) for b in behind):
        raise BodyvibError(
            f"a wheel must be a non-negative distance behind the first, got {behind}"
        )
    wheelbase = max(behind)
    dx = wheelbase / math.ceil(wheelbase / largest - 1e-9) if wheelbase > 0 else largest
    rows = int(math.ceil(length / dx - 1e-9)) + 1
    x = np.arange(rows) * dx
    columns = {}  # (track, rows behind) -> (heights, slopes)
    z, s = np.zeros((rows, len(wheels))), np.zeros((rows, len(wheels)))
    for j, (road, b) in enumerate(wheels.values()):
        k = int(round(b / dx))
        if abs(k * dx - b) > 1e-9 * max(1.0, b):  # not a whole number of rows
            ahead = x >= b
            z[ahead, j], s[ahead, j] = road.displacement(x[ahead] - b), road.slope(x[ahead] - b)
            continue
        if id(road) not in columns:
            columns[id(road)] = (road.displacement(x), road.slope(x))
        zr, sr = columns[id(road)]
        z[k:, j], s[k:, j] = zr[: rows - k], sr[: rows - k]
    table = HermiteTable(x, z, s)
    meta, _ = road_source(tracks[0], length, speed, spacing)
    distinct = list({id(road): road for road in tracks}.values())
    names = list(dict.fromkeys(road.name for road in distinct))
    meta["description"] = (
        f"{' and '.join(names)} under the wheels "
        + ", ".join(f"{w} {b:g} m behind the first" for w, b in zip(wheels, behind) if b)
        + f"; {table.length:g} m tabulated every {dx:g} m (heights and exact slopes, cubic "
        "Hermite between rows); beyond the table the profiles hold their end values"
    )
    meta["signals"] = [
        {
            "name": f"road_displacement_{w}",
            "unit": "m",
            "description": f"Road profile height under the {w.replace('_', ' ')} wheel (z up)",
            "rate": {
                "name": f"road_velocity_{w}",
                "unit": "m/s",
                "description": f"Time derivative of road_displacement_{w} (speed * "
                "profile slope of the same interpolant)",
            },
        }
        for w in wheels
    ]
    meta["provenance"] = dict(meta["provenance"], wheelbase_m=wheelbase)
    if len(distinct) > 1:
        meta["provenance"]["tracks"] = [road.describe() for road in distinct]
    return meta, table
