"""Synthetic stand-ins for roads as they come from the field (no real data ships with the tests).

* :func:`cobblestone_heights` / :func:`write_cobblestone_crg`: a laser-scanned cobbled
  street on a 1 cm grid, written as a real OpenCRG file (single precision, binary, as scans
  are stored): stones 10-15 cm long in courses 12 cm wide, domed tops set at random heights
  +-3 mm, joints 1-2 cm wide whose floors lie 10-20 mm below the stones.
* :func:`write_profilometer_txt`: an ISO 8608 class C profile every 0.25 m (what IRI-grade
  profilers record) as a white-space text export: a UTF-8 byte-order mark, CRLF line ends,
  upper-case units, absolute elevations (245 m above the datum) on a 2 % grade.
"""

import numpy as np

from bodyvib.vehicle.road.synthetic import random_road

#: Grid of the cobblestone scan, m.
COBBLE_DX = 0.01
#: Grade of the profilometer profile.
PROFILER_GRADE = 0.02
#: Datum of the profilometer profile, m.
PROFILER_DATUM = 245.0


def cobblestone_heights(length=9.76, width=1.0, seed=7):
    """Heights ``z[u, v]`` (m) of a cobbled surface on a 1 cm grid, with ``u`` and ``v`` (m).

    Returns
    -------
    u : (nu,) ndarray
    v : (nv,) ndarray
        From ``-width / 2`` to ``width / 2``.
    z : (nu, nv) ndarray
    """
    rng = np.random.default_rng(seed)
    u = np.arange(int(round(length / COBBLE_DX)) + 1) * COBBLE_DX
    v = np.round(np.arange(-width / 2, width / 2 + COBBLE_DX / 2, COBBLE_DX), 10)
    z = np.empty((u.size, v.size))
    course = 0.12  # m, width of a course of stones
    for c0 in np.arange(-width / 2, width / 2, course):
        cols = (v >= c0 - 1e-9) & (v < c0 + course - 1e-9)
        s = -rng.uniform(0, 0.15)  # courses are staggered
        line = np.zeros(u.size)
        while s < length:
            stone = rng.uniform(0.10, 0.15)
            joint = rng.uniform(0.01, 0.02)
            depth = rng.uniform(0.010, 0.020)
            top = rng.uniform(-0.003, 0.003)
            on = (u >= s) & (u < s + stone)
            r = (u[on] - s - stone / 2) / (stone / 2)
            line[on] = top - 0.002 * r**2  # a domed top, 2 mm lower at its edges
            gap = (u >= s + stone) & (u < s + stone + joint)
            line[gap] = top - depth
            s += stone + joint
        z[:, cols] = line[:, None]
    return u, v, z


def write_cobblestone_crg(path, **kwargs):
    """Write :func:`cobblestone_heights` as an OpenCRG file (binary, single precision)."""
    import pycrg

    u, v, z = cobblestone_heights(**kwargs)
    pycrg.write(
        str(path),
        z.astype(np.float32).astype(float),
        COBBLE_DX,
        v,
        fmt="KRBI",
        comment=["bodyvib test: a synthetic cobblestone scan on a 1 cm grid"],
    )
    return u, v, z


def profilometer_profile(length=400.0, spacing=0.25, seed=11):
    """``(x, z)`` of the profilometer stand-in: class C, on a grade, above a datum (m)."""
    x = np.arange(int(round(length / spacing)) + 1) * spacing
    z = random_road("C", length + 10.0, seed=seed).displacement(x)
    return x, PROFILER_DATUM + PROFILER_GRADE * x + z


def write_profilometer_txt(path, length=400.0, spacing=0.25, seed=11):
    """Write :func:`profilometer_profile` as a profiler's text export; returns ``(x, z)``."""
    x, z = profilometer_profile(length, spacing, seed)
    rows = "".join(f"{a:10.2f}  {b:12.5f}\r\n" for a, b in zip(x, z))
    text = "% LONGITUDINAL PROFILE, LEFT WHEEL PATH\r\nDISTANCE [M]   ELEVATION [M]\r\n" + rows
    with open(path, "wb") as f:
        f.write(b"\xef\xbb\xbf" + text.encode("utf-8"))
    return x, z
