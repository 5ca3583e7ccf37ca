"""Fixtures shared by the tests (the FMU sets, built once per session) and a temporary
directory kept clean. Shared helper functions are in ``helpers.py``."""

import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import pytest
from helpers import ROOT

FMU_NAMES = ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar")


@pytest.fixture(scope="session")
def python_fmu_dir(tmp_path_factory):
    """The folder ``python build_fmu.py --dest DIR`` fills, built once per session as a user
    builds it (a subprocess): the pythonfmu FMUs, ``Road.fmu`` and the SSP. Shared by every
    test: read it, never change it (copy an FMU into ``tmp_path`` first)."""
    dest = tmp_path_factory.mktemp("python_fmus")
    out = subprocess.run(
        [sys.executable, os.path.join(ROOT, "build_fmu.py"), "--dest", str(dest)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    return dest


@pytest.fixture(scope="session")
def python_fmus(python_fmu_dir):
    """The project's three pythonfmu FMUs of ``python_fmu_dir``: name -> .fmu path."""
    return {n: str(python_fmu_dir / f"{n}.fmu") for n in FMU_NAMES}


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
        msg = (
            f"the test run left {len(left)} entr{'y' if len(left) == 1 else 'ies'} in the "
            f"temporary directory: {', '.join(left[:10])}{' ...' if len(left) > 10 else ''}"
        )
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
    dest = tmp_path_factory.mktemp("native_fmus")
    out = subprocess.run(
        [sys.executable, "build_fmu.py", "--native", "--dest", str(dest)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    return dest / "native"


@pytest.fixture(scope="session")
def native_fmus(native_dist):
    """The native body and car FMUs (the half and full cars' too): ``"<name>"`` (FMI 2.0)
    and ``"fmi3/<name>"`` -> .fmu path."""
    names = FMU_NAMES + ("HalfCar", "FullCar")
    paths = {n: str(native_dist / f"{n}.fmu") for n in names}
    paths.update({f"fmi3/{n}": str(native_dist / "fmi3" / f"{n}.fmu") for n in names})
    return paths
