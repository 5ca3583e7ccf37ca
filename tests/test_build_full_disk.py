"""``bodyvib build`` on a full disk: the FMUs and the SSP are committed together or none.

The destination is a tmpfs just large enough for the four new FMUs but not for the SSP
packed from them as well: before, the four FMUs replaced the old ones and the SSP's write
failed, leaving an old SSP beside new FMUs. Where the machine cannot mount a tmpfs (not
root), the same failure (ENOSPC) is injected at the SSP's write instead.
"""

import errno
import os
import subprocess
import sys

import pytest
from helpers import ROOT, mount_tmpfs

pytestmark = pytest.mark.integration

OLD = b"old content\n"
NAMES = (
    "HumanBody3DOF.fmu",
    "HumanBodyISO7962.fmu",
    "QuarterCar.fmu",
    "Road.fmu",
    "QuarterCarWithOccupant.ssp",
)


def _old(folder):
    for n in NAMES:
        (folder / n).write_bytes(OLD)


def _assert_all_old(folder):
    assert {n: (folder / n).read_bytes() for n in NAMES} == {n: OLD for n in NAMES}
    assert not [f for f in os.listdir(folder) if f.startswith(".tmp-")]


def test_build_on_a_full_disk_keeps_every_old_output(python_fmus, tmp_path):
    dist = os.path.dirname(python_fmus["HumanBody3DOF"])
    sizes = {n: os.path.getsize(os.path.join(dist, n)) for n in NAMES}
    fmus = sum(v for n, v in sizes.items() if n.endswith(".fmu"))
    size = fmus + sizes["QuarterCarWithOccupant.ssp"] // 2  # room for the FMUs, not the SSP
    dest = tmp_path / "dest"
    dest.mkdir()
    with mount_tmpfs(dest, size) as mounted:
        if not mounted:
            pytest.skip(
                "cannot mount a tmpfs here; test_build_write_failure_keeps_every_old_output "
                "injects the failure instead"
            )
        _old(dest)
        proc = subprocess.run(
            [sys.executable, "-m", "bodyvib.cli", "build", "--dest", str(dest)],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=600,
        )
        lines = proc.stderr.strip().splitlines()
        assert proc.returncode == 2, proc.stderr
        assert len(lines) == 1 and "No space left" in lines[0], proc.stderr
        _assert_all_old(dest)


def test_build_write_failure_keeps_every_old_output(tmp_path, monkeypatch, capsys):
    """The same failure injected at the SSP's write: ENOSPC after the four FMUs were staged."""
    import bodyvib.vehicle.ssp
    from bodyvib.cli.main import main

    real = bodyvib.vehicle.ssp.atomic_write_bytes

    def full(path, data):
        assert len(data) > 3 * len(OLD)  # packed from the FMUs just built (staged, not placed)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), os.fspath(path))

    monkeypatch.setattr(bodyvib.vehicle.ssp, "atomic_write_bytes", full)
    dest = tmp_path / "dest"
    dest.mkdir()
    _old(dest)
    assert main(["build", "--dest", str(dest)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "No space left" in err[0], err
    _assert_all_old(dest)
    monkeypatch.setattr(bodyvib.vehicle.ssp, "atomic_write_bytes", real)
    assert main(["build", "--dest", str(dest)]) == 0  # and with room, all five are new
    assert all((dest / n).read_bytes() != OLD for n in NAMES)
