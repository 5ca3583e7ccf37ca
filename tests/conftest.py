"""Shared test helpers: independent reference computations; a temporary directory kept clean."""

import os
import shutil
import subprocess
import sys
import tempfile

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


@pytest.fixture(scope="session")
def project_fmus(tmp_path_factory):
    """The project's three FMUs, built once per session as a user does (``python
    build_fmu.py`` in a subprocess): name -> .fmu path."""
    dest = tmp_path_factory.mktemp("fmus")
    out = subprocess.run([sys.executable, os.path.join(ROOT, "build_fmu.py"), "--dest", str(dest)],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout + out.stderr
    return {n: str(dest / f"{n}.fmu") for n in ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar")}


@pytest.fixture
def rng():
    return np.random.default_rng(20251122)


# -- the test run leaves nothing behind in the temporary directory ------------
# Every temporary file or folder of the run -- tempfile in this process and,
# through TMPDIR, in every subprocess (fmpy's extracted FMUs, pythonfmu builds,
# libcosim, the C host) -- goes into one private folder. At the end of the
# session whatever is left there fails the run (listed) and is removed. Other
# processes on the machine cannot disturb the check; pytest's own tmp_path
# folders stay where they always are (PYTEST_DEBUG_TEMPROOT).
def pytest_configure(config):
    real = tempfile.gettempdir()
    os.environ.setdefault("PYTEST_DEBUG_TEMPROOT", real)
    private = tempfile.mkdtemp(prefix="bodyvib-tests-tmp-", dir=real)
    config._bodyvib_tmp = (private, os.environ.get("TMPDIR"), tempfile.tempdir)
    os.environ["TMPDIR"] = private
    tempfile.tempdir = private


def pytest_unconfigure(config):
    private, env, tempdir = config._bodyvib_tmp
    if env is None:
        os.environ.pop("TMPDIR", None)
    else:
        os.environ["TMPDIR"] = env
    tempfile.tempdir = tempdir
    shutil.rmtree(private, ignore_errors=True)


def pytest_sessionfinish(session, exitstatus):
    private = session.config._bodyvib_tmp[0]
    left = sorted(os.listdir(private)) if os.path.isdir(private) else []
    if left:
        tr = session.config.pluginmanager.get_plugin("terminalreporter")
        msg = (f"the test run left {len(left)} entr{'y' if len(left) == 1 else 'ies'} in the "
               f"temporary directory: {', '.join(left[:10])}{' ...' if len(left) > 10 else ''}")
        if tr is not None:
            tr.ensure_newline()
            tr.write_line(msg, red=True)
        else:
            print(msg, file=sys.stderr)
        if session.exitstatus == 0:
            session.exitstatus = pytest.ExitCode.TESTS_FAILED


@pytest.fixture(scope="session")
def native_dist(tmp_path_factory):
    """What ``build_fmu.py --native`` writes (once per session): its ``native`` folder, with
    the FMI 2.0 FMUs and SSP, and ``fmi3/`` with the FMI 3.0 ones."""
    import subprocess

    dest = tmp_path_factory.mktemp("native_fmus")
    out = subprocess.run([sys.executable, "build_fmu.py", "--native", "--dest", str(dest)],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout + out.stderr
    return dest / "native"


@pytest.fixture(scope="session")
def native_fmus(native_dist):
    """The native body and car FMUs: ``"<name>"`` (FMI 2.0) and ``"fmi3/<name>"`` -> .fmu path."""
    names = ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar")
    paths = {n: str(native_dist / f"{n}.fmu") for n in names}
    paths.update({f"fmi3/{n}": str(native_dist / "fmi3" / f"{n}.fmu") for n in names})
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
