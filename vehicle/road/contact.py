"""Tire contact on a measured road: the tandem-cam effective road of Schmeitz (2004).

A tire does not follow a scanned surface point by point: it bridges a 1 cm joint and
rolls onto a step over a distance of the order of its footprint. The tandem-cam model
(A. J. C. Schmeitz, PhD thesis, TU Delft 2004; H. B. Pacejka, *Tire and Vehicle
Dynamics*, 3rd ed., 2012, ch. 10) turns the profile into the *effective road* the
wheel feels, in two steps:

1. **One cam.** A rigid cam, the lower half of a super-ellipse of half-length
   ``a_e``, half-height ``b_e`` and order ``c_e``,
   ``(|d| / a_e)^c_e + (h / b_e)^c_e = 1``, rests on the profile ``z(s)``. Its lowest
   point ``x`` lies at the *basic function*

   ``w(x) = max_{|d| <= a_e} [ z(x + d) - y(d) ]``,
   ``y(d) = b_e (1 - (1 - (|d| / a_e)^c_e)^(1 / c_e))``

   (``y`` is the cam's contour above its lowest point). Over a step of height ``H``
   at ``s = 0`` it is ``max(0, H - y(x))`` ahead of the step and ``H`` beyond it.
2. **Two cams.** A tandem of two such cams a base ``l_s`` apart: the effective height
   is their mean, ``w_eff(x) = (w(x - l_s / 2) + w(x + l_s / 2)) / 2``.

The sizes come from the tire: ``a_e = p_ae r0``, ``b_e = p_be r0``, ``l_s = p_ls a``
with ``r0`` the unloaded radius and ``a`` half the footprint length
(:class:`TandemCam`, parameters from ``vehicle/data/roads/tandem-cam-205-60R15.json``, or
the enveloping set MF-Swift measured on the same tire size,
``vehicle/data/roads/mfswift-205-60R15.json``: :func:`load_tire`).
The effective road is evaluated at the profile's samples (the cam's contour at the
offsets ``j dx``) and driven through the profile's interpolant like the profile
itself.

The tandem's effective *slope* ``(w(x + l_s/2) - w(x - l_s/2)) / l_s`` turns the
wheel's force in the full model; a vertical quarter car takes only the height (and
its exact derivative), so it is not used here.
"""

import json
import math
import os
from dataclasses import dataclass

import numpy as np

from bodyvib.runtime.errors import BodyvibError

from ..records import Record

__all__ = [
    "CONTACTS",
    "TandemCam",
    "TIRES",
    "default_tire",
    "load_tire",
    "cam_contour",
    "basic_function",
    "effective_road",
]

#: The tandem-cam parameter sets a road file can be driven with, by contact name: the
#: default shape factors of a tire not measured on cleats, and the enveloping set
#: MF-Swift measured on a 205/60 R15 (TNO, 2013); both in ``vehicle/data/roads/``.
TIRES = {
    "tandem-cam": "tandem-cam-205-60R15.json",
    "mfswift-205-60R15": "mfswift-205-60R15.json",
}

#: The contact models a road file can be driven with (``--road-contact``): ``auto`` is
#: ``tandem-cam`` on a profile sampled finer than the footprint, ``point`` on a coarser
#: one; each name of :data:`TIRES` is the tandem cam with that set.
CONTACTS = ("auto", *TIRES, "point")

_TIRE_DIR = os.path.join(os.path.dirname(os.path.dirname(__file__)), "data", "roads")


@dataclass(frozen=True)
class TandemCam(Record):
    """Sizes of the tandem-cam contact (see the module docstring).

    Attributes
    ----------
    radius_m : float
        Unloaded tire radius ``r0``, m.
    footprint_m : float
        Footprint length ``2 a`` at the static load, m.
    length_factor, height_factor : float
        ``p_ae``, ``p_be``: cam half-length and half-height over ``r0``.
    order : float
        ``c_e``, the super-ellipse's order (2: an ellipse).
    shift_factor : float
        ``p_ls``: the tandem base over the footprint half-length ``a``.
    name : str
        The parameter set's contact name (:data:`TIRES`, :func:`load_tire`).

    Raises
    ------
    BodyvibError
        A size that is not a positive number.

    Examples
    --------
    >>> t = default_tire()
    >>> round(t.half_length, 3), round(t.base, 4)
    (0.313, 0.0444)
    """

    radius_m: float
    footprint_m: float
    length_factor: float = 1.0
    height_factor: float = 1.0
    order: float = 1.8
    shift_factor: float = 0.8
    name: str = "tandem-cam"

    def __post_init__(self):
        for name, value in self.to_dict().items():
            if name == "name":
                continue
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise BodyvibError(f"tire contact: {name} must be a positive number, got {value!r}")

    @property
    def half_length(self) -> float:
        """``a_e``, m."""
        return self.length_factor * self.radius_m

    @property
    def half_height(self) -> float:
        """``b_e``, m."""
        return self.height_factor * self.radius_m

    @property
    def base(self) -> float:
        """``l_s``, the distance between the two cams, m."""
        return self.shift_factor * self.footprint_m / 2


def default_tire() -> TandemCam:
    """The shipped tandem cam: a 205/60R15 under the shipped quarter car (sourced in its file).

    Returns
    -------
    TandemCam
    """
    return load_tire("tandem-cam")


def load_tire(name: str) -> TandemCam:
    """A shipped tandem-cam parameter set by its contact name (:data:`TIRES`).

    Parameters
    ----------
    name : str
        ``"tandem-cam"`` (default shape factors) or ``"mfswift-205-60R15"`` (the
        enveloping set measured by MF-Swift).

    Returns
    -------
    TandemCam
        Named ``name``.

    Raises
    ------
    BodyvibError
        A name that is not one of :data:`TIRES`.

    Examples
    --------
    >>> t = load_tire("mfswift-205-60R15")
    >>> t.name, round(t.half_length, 4), round(t.half_height, 4)
    ('mfswift-205-60R15', 0.4588, 0.2994)
    """
    if name not in TIRES:
        raise BodyvibError(f"unknown tire contact '{name}'; the sets are {', '.join(TIRES)}")
    with open(os.path.join(_TIRE_DIR, TIRES[name]), encoding="utf-8") as f:
        doc = json.load(f)
    return TandemCam(**doc["parameters"], name=name)


def cam_contour(d, half_length: float, half_height: float, order: float) -> np.ndarray:
    """The cam's contour above its lowest point at the offsets ``d`` (m): ``y(d)``, m.

    Examples
    --------
    >>> cam_contour([0.0, 0.3], 0.3, 0.3, 2.0)
    array([0. , 0.3])
    """
    r = np.minimum(np.abs(np.asarray(d, dtype=float)) / half_length, 1.0)
    return half_height * (1.0 - (1.0 - r**order) ** (1.0 / order))


def basic_function(
    elevation, spacing: float, tire: TandemCam, periodic: bool = False
) -> np.ndarray:
    """Height of one cam's lowest point resting on a profile, at each of its samples, m.

    Parameters
    ----------
    elevation : (n,) array_like
        Heights at a uniform spacing, m (held at the end values beyond the ends).
    spacing : float
        m.
    tire : TandemCam
    periodic : bool
        The profile repeats: its last sample is its first, and beyond either end the cam
        rests on the next repetition instead of the end value.

    Returns
    -------
    (n,) ndarray
        ``w`` at the samples (the maximum over the cam's offsets ``j dx``).

    Examples
    --------
    A 20 mm step under a cam 0.3 m long: the cam climbs onto its edge before it.

    >>> t = TandemCam(0.3, 0.1, order=2.0)
    >>> w = basic_function(np.r_[np.zeros(50), np.full(50, 0.02)], 0.01, t)
    >>> round(float(w[49]), 5), float(w[30]), float(w[50])
    (0.01983, 0.0, 0.02)
    """
    z = np.asarray(elevation, dtype=float)
    m = int(math.floor(tire.half_length / spacing + 1e-9))
    lift = cam_contour(
        np.arange(-m, m + 1) * spacing, tire.half_length, tire.half_height, tire.order
    )
    if periodic:  # the neighbouring repetitions: the period is z[:-1]
        period = z[:-1]
        reps = m // period.size + 1
        around = np.tile(period, reps)
        padded = np.concatenate([around[around.size - m :], z, np.tile(period, reps)[1 : m + 1]])
    else:
        padded = np.pad(z, m, mode="edge")
    w = np.full(z.size, -np.inf)
    for k, y in enumerate(lift):
        np.maximum(w, padded[k : k + z.size] - y, out=w)
    return w


def effective_road(
    elevation, spacing: float, tire: TandemCam, periodic: bool = False
) -> np.ndarray:
    """The tandem's effective height at each sample of a profile, m.

    Parameters
    ----------
    elevation, spacing, tire, periodic
        As :func:`basic_function`: the profile's heights, their spacing, the tandem and
        whether the profile repeats.

    Returns
    -------
    (n,) ndarray
        ``(w(x - l_s/2) + w(x + l_s/2)) / 2`` with ``w`` the :func:`basic_function`
        (linear between its samples).

    Examples
    --------
    A level road stays level; a straight grade stays straight.

    >>> x = np.arange(0, 5, 0.01)
    >>> bool(np.allclose(effective_road(0.01 * x, 0.01, default_tire())[60:-60], 0.01 * x[60:-60],
    ...                  atol=1e-5))
    True
    """
    z = np.asarray(elevation, dtype=float)
    x = np.arange(z.size) * spacing
    w = basic_function(z, spacing, tire, periodic)
    half = tire.base / 2
    if periodic:  # one period of samples (the last is the first again)
        x, w, period = x[:-1], w[:-1], x[-1]
        ahead = np.interp(x + half, x, w, period=period)
        behind = np.interp(x - half, x, w, period=period)
        mean = 0.5 * (ahead + behind)
        return np.append(mean, mean[0])
    return 0.5 * (np.interp(x - half, x, w) + np.interp(x + half, x, w))
