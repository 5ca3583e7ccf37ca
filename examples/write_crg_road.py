"""Write an OpenCRG road to drive with ``bodyvib cosim --road FILE`` (a stand-in for a scan).

A 3.5 m wide, 300 m long straight road on a 1 % grade, sampled every 5 cm along and
every 0.875 m across: its right edge (v = -1.75 m) and left edge (v = +1.75 m) are two
independent ISO 8608 class C profiles (seeds 1 and 2), blended linearly across the road,
so each wheel track sees its own profile. Written with ``pycrg`` (double precision)::

    python examples/write_crg_road.py road.crg
    bodyvib cosim --road road.crg --road-track 0.875 --duration 10

tests/test_measured_roads.py runs :func:`write` and the worked example of
docs/tutorials/measured_road.md, "Measured roads".
"""

import sys

import numpy as np

__all__ = ["write"]


def write(path="road.crg", length=300.0, spacing=0.05, width=3.5):
    """Write the road.

    Parameters
    ----------
    path : str
        The ``.crg`` file to write.
    length, spacing, width : float
        m.

    Returns
    -------
    str
        ``path``.
    """
    import pycrg

    from bodyvib.vehicle.road.synthetic import random_road

    u = np.arange(0.0, length + spacing / 2, spacing)
    right = random_road("C", length + 50.0, seed=1).displacement(u)
    left = random_road("C", length + 50.0, seed=2).displacement(u)
    v = np.linspace(-width / 2, width / 2, 5)
    share = (v + width / 2) / width  # 0 at the right edge, 1 at the left
    z = right[:, None] * (1 - share) + left[:, None] * share
    pycrg.write(
        path,
        z,
        spacing,
        v,
        slope=0.01,
        fmt="KDBI",
        comment=["bodyvib example: ISO 8608 class C edges (seeds 1, 2) on a 1 % grade"],
    )
    return path


if __name__ == "__main__":
    print(write(*(sys.argv[1:2] or ["road.crg"])))
