"""Shared test helpers: independent reference computations."""

import os
import sys

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


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


@pytest.fixture
def rng():
    return np.random.default_rng(20251122)


@pytest.fixture(scope="session")
def native_fmus(tmp_path_factory):
    """The native FMUs, built once by ``build_fmu.py --native``: ``"<name>"`` (FMI 2.0) and
    ``"fmi3/<name>"`` -> .fmu path."""
    import subprocess

    dest = tmp_path_factory.mktemp("native_fmus")
    out = subprocess.run([sys.executable, "build_fmu.py", "--native", "--dest", str(dest)],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout + out.stderr
    names = ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar")
    paths = {n: str(dest / "native" / f"{n}.fmu") for n in names}
    paths.update({f"fmi3/{n}": str(dest / "native" / "fmi3" / f"{n}.fmu") for n in names})
    return paths


@pytest.fixture(scope="session")
def python_fmus(tmp_path_factory):
    """The pythonfmu FMUs, built once by ``build_fmu.py``: name -> .fmu path."""
    import subprocess

    dest = tmp_path_factory.mktemp("python_fmus")
    out = subprocess.run([sys.executable, "build_fmu.py", "--dest", str(dest)],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout + out.stderr
    return {n: str(dest / f"{n}.fmu") for n in ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar")}
