"""The seat surface's ISO 2631-1 axes in a car run: x, y, z and the rotations.

A car whose seat point has a height ``h`` above its body's centre of mass (the half
and the full car) gives the seat's forward and leftward accelerations ``a_x = -h
theta''`` and ``a_y = -h phi''`` (inertial, small angles, gravity not included: an
accelerometer fixed to the tilting seat would also read ``g theta`` and ``g phi``).
The seat is fixed to the body, so it pitches and rolls with it: its rotational
accelerations are ``theta'' = -a_x / h`` and ``phi'' = -a_y / h``. :func:`seat_axes`
weights them all (Wd, Wk, We) and sums them with the comfort factors of ISO 2631-1
(:func:`bodyvib.comfort.vibration_totals`); a run (:func:`bodyvib.vehicle.run_study`)
and a sweep's rows report them beside the head's figures.
"""

from typing import Dict, List, Optional, Tuple

import numpy as np

from bodyvib.comfort.axes import vibration_totals

__all__ = [
    "SEAT_FIGURES",
    "seat_axes",
    "seat_totals",
    "seat_figures",
    "seat_method_warnings",
    "seat_height",
    "seat_point",
]

#: The seat's figures a run and a sweep row report (:func:`seat_axes`).
SEAT_FIGURES = (
    "seat_aw_x",
    "seat_aw_y",
    "seat_aw_z",
    "seat_av",
    "seat_aw_rx",
    "seat_aw_ry",
    "seat_rotation_av",
)


def seat_axes(x, y, z, fs: float, seat=None) -> Dict[str, float]:
    """The seat surface's ISO 2631-1 figures in x, y, z and its rotations.

    The seat is fixed to the car body, so it turns with it: its pitch and roll
    accelerations are the body's, read from the seat's horizontal accelerations
    ``a_x = -h theta''`` and ``a_y = -h phi''`` (``h``: the seat's height above the
    body's centre of mass; the same inertial convention, gravity not included).

    Parameters
    ----------
    x, y, z : (n,) array_like
        The seat's forward, leftward and vertical accelerations, m/s2.
    fs : float
        Sampling rate, Hz.
    seat : (float, bool), optional
        The seat's height above the centre of mass (m) and whether the body rolls
        (:func:`seat_height`); None: no rotations.

    Returns
    -------
    dict of str to float
        ``seat_aw_x``, ``seat_aw_y`` (Wd), ``seat_aw_z`` (Wk), the point vibration total
        value of the translations for comfort ``seat_av`` (k = 1, 1, 1), and with
        ``seat`` the pitch's ``seat_aw_ry`` (and a rolling body's ``seat_aw_rx``) (We,
        rad/s2) and the rotations' point value ``seat_rotation_av`` (k = 0.63, 0.40
        m/rad), from :func:`bodyvib.comfort.vibration_totals`.

    Examples
    --------
    >>> t = np.arange(20000) / 1000.0
    >>> ax = 0.1 * np.sin(2 * np.pi * t)
    >>> f = seat_axes(ax, 0 * t, 0 * t, 1000.0, seat=(0.1, False))
    >>> # 1/h times We/Wd at 1 Hz: 10 x 0.880 / 1.011 = 8.70 by ISO 2631-1 Tables 3, 4
    >>> round(f["seat_aw_x"], 3), round(f["seat_aw_ry"] / f["seat_aw_x"], 2)
    (0.071, 8.71)
    """
    return seat_figures(seat_totals(x, y, z, fs, seat))


def seat_figures(totals) -> Dict[str, float]:
    """The figures :func:`seat_axes` reports, from the seat's :func:`seat_totals`."""
    out = {f"seat_aw_{a[5:]}": f.weighted_rms for a, f in totals.axes.items()}
    out["seat_av"] = totals.points["seat"]
    if "seat_rotation" in totals.points:
        out["seat_rotation_av"] = totals.points["seat_rotation"]
    return out


def seat_totals(x, y, z, fs: float, seat=None):
    """:func:`bodyvib.comfort.vibration_totals` of the seat's axes and rotations.

    Parameters
    ----------
    x, y, z, fs, seat
        As :func:`seat_axes`.

    Returns
    -------
    bodyvib.comfort.VibrationTotals
    """
    signals = {"seat_x": x, "seat_y": y, "seat_z": z}
    if seat is not None:
        h, rolls = seat
        signals["seat_ry"] = -np.asarray(x) / h
        if rolls:
            signals["seat_rx"] = -np.asarray(y) / h
    return vibration_totals(signals, fs)


def seat_method_warnings(totals, duration: float) -> List[str]:
    """A line for each seat axis where ISO 2631-1's basic method is not sufficient.

    Clause 6.3 (:func:`bodyvib.comfort.governing_method`): above a crest factor of 9,
    ``MTVV / a_w`` of 1.5 or ``VDV / (a_w T^1/4)`` of 1.75, the axis's weighted r.m.s.
    understates it, and its VDV or MTVV governs.

    Parameters
    ----------
    totals : bodyvib.comfort.VibrationTotals
        The seat's :func:`seat_totals`.
    duration : float
        The record's duration, s.

    Returns
    -------
    list of str
        One line per such axis (none: every axis is within the basic method).

    Examples
    --------
    >>> t = np.arange(100000) / 1000.0
    >>> burst = np.where(t < 1.0, np.sin(2 * np.pi * t), 0.0)  # 1 s in 100 s
    >>> totals = seat_totals(burst, 0 * t, np.sin(2 * np.pi * t), 1000.0)
    >>> for line in seat_method_warnings(totals, 100.0):
    ...     print(line)
    seat x: ISO 2631-1's basic method is not sufficient (crest factor 15.7, ...): the MTVV governs, 0.6233 m/s2
    """
    lines = []
    for axis, f in totals.axes.items():
        if f.comfort_method == "basic":
            continue
        value = f.mtvv if f.comfort_method == "mtvv" else f.vdv
        ratio = f.vdv / (f.weighted_rms * duration**0.25)
        lines.append(
            f"seat {axis[5:]}: ISO 2631-1's basic method is not sufficient (crest factor "
            f"{f.crest_factor:.1f}, MTVV/a_w {f.mtvv / f.weighted_rms:.1f}, "
            f"VDV/(a_w T^1/4) {ratio:.2f}): the {f.comfort_method.upper()} governs, "
            f"{value:.4f} {f.unit if f.comfort_method == 'mtvv' else _vdv_unit(f.unit)}"
        )
    return lines


def _vdv_unit(unit: str) -> str:
    """The VDV's unit for an axis whose acceleration is in ``unit``."""
    return "m/s1.75" if unit == "m/s2" else "rad/s1.75"


def seat_point(car) -> str:
    """The role of the car body's point under the seat, as outputs are named by it:
    ``floor`` on a car with a seat mounted (its pan moves only up and down on the
    floor: fore-aft and sideways it moves with it), else ``seat``.

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> seat_point(load_car("half-car")), seat_point(load_car("half-car+cushion"))
    ('seat', 'floor')
    """
    return "floor" if "floor" in car.roles else "seat"


def seat_height(car) -> Optional[Tuple[float, bool]]:
    """A car's seat height above its body's centre of mass and whether the body rolls.

    Parameters
    ----------
    car : Network or None
        A car model (None: a foreign car FMU).

    Returns
    -------
    (float, bool) or None
        None for a car whose seat point has no height (or no model).

    Examples
    --------
    >>> from bodyvib.vehicle.quarter_car import load_car
    >>> seat_height(load_car("half-car")), seat_height(load_car("full-car"))
    ((0.1, False), (0.1, True))
    """
    if car is None:
        return None
    place = car.body_point_heights.get(car.roles.get(seat_point(car), ""))
    if place is None or place[3] is None or not place[3]:
        return None
    return place[3], car.bodies[place[0]].roll_inertia is not None
