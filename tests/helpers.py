"""Helpers the tests share: the repository's root, the command line, independent references.

Imported as ``from helpers import ...`` (``tests/`` is on ``sys.path`` under pytest's default
import mode, as ``conftest.py`` is). Fixtures live in ``conftest.py``.
"""

import os
import subprocess
import sys

import numpy as np

__all__ = ["ROOT", "run_cli", "dynamic_stiffness_response"]

#: The repository's root (where ``build_fmu.py`` is).
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_cli(*args, cwd=None, timeout=600):
    """``python -m bodyvib_cli ARGS`` as a user runs it: the finished process, output as text."""
    return subprocess.run([sys.executable, "-m", "bodyvib_cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout)


def dynamic_stiffness_response(net, f_hz, point):
    """X_point / X_base by nodal analysis in the frequency domain.

    Independent of bodyvib.runtime.network.linear_model: every spring is k, every
    damper c*s, every mass m*s^2, and the unknown displacements of all masses
    and nodes solve K(s) X = F(s) with the base displaced by 1.
    """
    springs, dampers = net.primitives()
    pts = list(net.mass_names) + list(net.node_names)
    idx = {p: i for i, p in enumerate(pts)}
    masses = net.mass_values()
    out = []
    for f in np.atleast_1d(f_hz):
        s = 2j * np.pi * f
        K = np.zeros((len(pts), len(pts)), complex)
        F = np.zeros(len(pts), complex)
        for (a, b, z) in [(a, b, k) for a, b, k in springs] + [(a, b, c * s) for a, b, c in dampers]:
            for p, q in ((a, b), (b, a)):
                if p in idx:
                    K[idx[p], idx[p]] += z
                    if q in idx:
                        K[idx[p], idx[q]] -= z
                    else:  # base, displaced by 1
                        F[idx[p]] += z
        for m, mv in masses.items():
            K[idx[m], idx[m]] += mv * s * s
        X = np.linalg.solve(K, F)
        out.append(X[idx[net.point(point)]])
    return np.array(out)
