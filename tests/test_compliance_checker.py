"""The FMU Compliance Checker (modelica-tools/FMUComplianceChecker, on Modelon's FMI Library)
on the FMI 2.0 FMUs: the native ones in co-simulation and model exchange, the pythonfmu ones in
co-simulation (with the interpreter's libpython preloaded).

The checker is a C host that knows nothing of Python: it loads the FMU, checks its model
description, simulates it and unloads it. Its summary must report no error and no warning,
from the checker or the FMU, and the process must exit 0 (a pythonfmu FMU whose interpreter is
torn down in the wrong order at exit ended it with SIGABRT after a correct simulation, 10 of 10
runs; bodyvib.runtime.teardown now releases it from a C exit handler, nothing asked of the
host).

The project does not build the checker. The tests run when ``fmuCheck.linux64`` is on ``PATH``
or the ``FMUCHECK`` environment variable names it, and skip with that reason otherwise.
"""

import os
import re
import shutil
import subprocess
import sysconfig

import pytest
from conftest import FMU_NAMES

CHECKER = os.environ.get("FMUCHECK") or shutil.which("fmuCheck.linux64")

pytestmark = [
    pytest.mark.integration,
    pytest.mark.skipif(
        CHECKER is None,
        reason="no FMU Compliance Checker: put fmuCheck.linux64 on PATH or set FMUCHECK "
        "(build modelica-tools/FMUComplianceChecker from source)",
    ),
]


def _libpython():
    """The shared libpython of this interpreter: pythonfmu's binary does not link it, so a C
    host preloads it (as pythonfmu's own documentation says)."""
    return os.path.join(sysconfig.get_config_var("LIBDIR"), sysconfig.get_config_var("LDLIBRARY"))


def _check(path, mode, tmp_path, env=None):
    """Run the checker on one FMU: (exit status, its log, the result CSV's rows)."""
    out = tmp_path / "result.csv"
    p = subprocess.run(
        [CHECKER, "-k", mode, "-h", "1e-3", "-s", "1", "-l", "4", "-o", str(out), path],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
        env=env,
    )
    rows = out.read_text().splitlines() if out.exists() else []
    return p.returncode, p.stdout + p.stderr, rows


def _summary(log):
    counts = {}
    for what, pattern in (
        ("fmu", r"(\d+) warning\(s\) and error\(s\)"),
        ("warnings", r"\t(\d+) Warning\(s\)"),
        ("errors", r"\t(\d+) Error\(s\)"),
    ):
        m = re.search(pattern, log)
        counts[what] = int(m.group(1)) if m else None
    return counts


@pytest.mark.parametrize("mode", ["cs", "me"])
@pytest.mark.parametrize("name", FMU_NAMES + ("Road",))
def test_native_fmi2_fmus_pass_the_compliance_checker(native_dist, tmp_path, name, mode):
    status, log, rows = _check(str(native_dist / f"{name}.fmu"), mode, tmp_path)
    assert status == 0, log[-2000:]
    assert _summary(log) == {"fmu": 0, "warnings": 0, "errors": 0}, log[-2000:]
    assert len(rows) > 10  # a header and the simulated points


@pytest.mark.parametrize("name", FMU_NAMES)
def test_pythonfmu_fmus_pass_the_compliance_checker_and_exit_cleanly(python_fmus, tmp_path, name):
    env = {**os.environ, "LD_PRELOAD": _libpython()}
    status, log, rows = _check(python_fmus[name], "cs", tmp_path, env)
    assert _summary(log) == {"fmu": 0, "warnings": 0, "errors": 0}, log[-2000:]
    assert len(rows) > 10
    assert status == 0, f"exit status {status} after a complete check:\n{log[-1000:]}"
