"""A native FMU whose binary was cut short is refused in one line before dlopen.

``dlopen`` maps a shared library's segments as its headers describe them; of a
truncated file it maps pages past the end, and the first touch of one kills the
process with SIGBUS: ``cosim --body`` died without a message and left its temporary
folders. The command must refuse the FMU with one line naming the truncation (status 2)
and leave its temporary folder empty, for cuts anywhere in the file.
"""

import os
import subprocess
import sys
import zipfile

import pytest
from helpers import ROOT

pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def native_body(tmp_path_factory):
    from bodyvib.fmu.native import build_native_fmu
    from bodyvib.vehicle.fmus import FMUS, load_fmu_model

    kind, _, description = FMUS["HumanBody3DOF"]
    dest = tmp_path_factory.mktemp("native_body")
    return build_native_fmu(
        load_fmu_model("HumanBody3DOF"),
        kind,
        "HumanBody3DOF",
        description,
        dest,
        fmi=2,
        platforms=("linux64",),
    )


def _truncated(fmu, out, fraction):
    member = "binaries/linux64/HumanBody3DOF.so"
    with zipfile.ZipFile(fmu) as zin, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == member:
                data = data[: int(len(data) * fraction)]
            zout.writestr(item, data)
    return out


def _cosim(body, tmp_path, tmpdir):
    env = dict(os.environ, TMPDIR=str(tmpdir))
    return subprocess.run(
        [
            sys.executable,
            "-m",
            "bodyvib.cli",
            "cosim",
            "--body",
            str(body),
            "--duration",
            "1",
            "--quiet",
        ],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.mark.parametrize("fraction", [0.25, 0.5, 0.9, 0.99])
def test_truncated_native_binary_is_refused_in_one_line(native_body, tmp_path, fraction):
    body = _truncated(native_body, tmp_path / "cut.fmu", fraction)
    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    proc = _cosim(body, tmp_path, tmpdir)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, proc.stderr  # not -7 (SIGBUS)
    assert len(lines) == 1 and "truncated" in lines[0] and "HumanBody3DOF.so" in lines[0], lines
    assert os.listdir(tmpdir) == []


def test_the_whole_binary_still_runs(native_body, tmp_path):
    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    proc = _cosim(native_body, tmp_path, tmpdir)
    assert proc.returncode == 0, proc.stderr
    assert os.listdir(tmpdir) == []
