"""Reliability of the commands against a hostile but realistic user: outputs
checked before work, ignored options refused, incomplete FMUs refused, failed builds that
keep the previous FMUs. Interrupts are in tests/test_interrupts.py."""

import os
import subprocess
import sys
import zipfile

import pytest
from helpers import ROOT, run_cli


def _one_line_error(p, words):
    assert p.returncode == 2, (p.stdout, p.stderr)
    assert words in p.stderr, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and "Traceback" not in p.stderr, p.stderr


@pytest.mark.integration
@pytest.mark.parametrize(
    "args, words",
    [
        # a given body FMU runs as built: a parameter file beside it would go unused
        (["--body", "X.fmu", "--params", "p.json"], "--params bakes a parameter file"),
        (["--car-fmu", "X.fmu", "--car", "quarter-car-cushion"], "--car chooses the model"),
        # the output destroyed the input with exit status 0
        (["--body", "X.fmu", "--json", "X.fmu"], "--json 'X.fmu' is the input of --body"),
        (["--body", "X.fmu", "--csv", "./X.fmu"], "is the input of --body"),
        (["--json", "a.json", "--csv", "a.json"], "must end in .csv"),
        (["--json", "same.json", "--plot", "same.json"], "must end in .png"),
        (["--json", "keep.json", "--plot", "result.txt"], "--plot 'result.txt' must end in .png"),
        (["--csv", "pipe.csv"], "is a FIFO"),
        (["--json", "adir"], "must end in .json"),
        (["--json", "adir.json"], "is a folder"),
    ],
)
@pytest.mark.parametrize("command", ["cosim", "check"])
def test_cosim_and_check_refuse_before_any_work(tmp_path, command, args, words):
    (tmp_path / "X.fmu").write_bytes(b"PK not really an FMU")
    (tmp_path / "keep.json").write_text("keep")
    (tmp_path / "adir.json").mkdir()
    (tmp_path / "adir").mkdir()
    os.mkfifo(tmp_path / "pipe.csv")
    p = run_cli(command, "--quiet", "--duration", "2", *args, cwd=tmp_path)
    _one_line_error(p, words)
    assert p.stdout == ""  # no work done, nothing printed
    assert (tmp_path / "X.fmu").read_bytes() == b"PK not really an FMU"
    assert (tmp_path / "keep.json").read_text() == "keep"


@pytest.mark.integration
def test_build_refuses_an_fmu_path_that_is_a_folder(tmp_path):
    (tmp_path / "dist" / "QuarterCar.fmu").mkdir(parents=True)
    p = run_cli("build", "--dest", "dist", cwd=tmp_path)
    _one_line_error(p, "QuarterCar.fmu' is a folder")


@pytest.mark.integration
def test_failed_build_keeps_the_folders_previous_fmus(tmp_path):
    """A build that fails half-way (here the car model names a parameter like an interface
    variable: it loads, and the FMU build refuses it) leaves the FMUs of the previous build
    in place: all FMUs are committed together at the end."""
    import json

    from bodyvib.runtime.modelfile import network_to_dict
    from bodyvib.vehicle.quarter_car import load_car

    dest = tmp_path / "dist"
    dest.mkdir()
    (dest / "HumanBody3DOF.fmu").write_bytes(b"the previous, good FMU")
    car = network_to_dict(load_car())
    old = next(iter(car["parameters"]))
    car["parameters"]["tire_force"] = car["parameters"].pop(old)
    text = json.dumps(car).replace(f'"{old}"', '"tire_force"')
    (tmp_path / "car.json").write_text(text)
    script = (
        "import sys; from bodyvib.vehicle.fmus import build_fmus; "
        "build_fmus(sys.argv[1], car=sys.argv[2], names=['HumanBody3DOF', 'QuarterCar'])"
    )
    p = subprocess.run(
        [sys.executable, "-c", script, str(dest), str(tmp_path / "car.json")],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert p.returncode != 0 and "tire_force are variables of the car FMU" in p.stderr
    assert (dest / "HumanBody3DOF.fmu").read_bytes() == b"the previous, good FMU"
    assert sorted(os.listdir(dest)) == ["HumanBody3DOF.fmu"]  # no temporaries left


@pytest.mark.integration
@pytest.mark.parametrize(
    "drop, words",
    [
        (lambda n: n.startswith("resources/"), "no resources/slavemodule.txt"),
        (lambda n: n.startswith("resources/bodyvib_fmu_"), "its slave script) is missing"),
        (lambda n: n.startswith("binaries/linux64/"), "no binary for this platform"),
    ],
)
def test_fmu_without_its_resources_is_refused_not_a_segfault(python_fmu_dir, tmp_path, drop, words):
    """An FMU without its resources folder segfaulted `bodyvib cosim`."""
    src = python_fmu_dir / "HumanBody3DOF.fmu"
    bad = tmp_path / "Broken.fmu"
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(bad, "w") as zout:
        for info in zin.infolist():
            if not drop(info.filename):
                zout.writestr(info, zin.read(info))
    p = run_cli(
        "cosim",
        "--quiet",
        "--duration",
        "2",
        "--body",
        str(bad),
        "--car-fmu",
        str(python_fmu_dir / "QuarterCar.fmu"),
        cwd=tmp_path,
    )
    _one_line_error(p, words)
    assert not [f for f in os.listdir(tmp_path) if f.startswith("core")]


@pytest.mark.integration
@pytest.mark.parametrize(
    "command, args, words",
    [
        ("frf", ["--points", "100000000"], "100000000 frequency points for 2 model(s) needs about"),
        ("cosim", ["--speed", "1e300"], "harmonics) needs about"),
        ("cosim", ["--road", "A", "--duration", "3e8", "--step", "1"], "harmonics) needs about"),
    ],
)
def test_sizes_beyond_memory_are_refused_up_front_naming_the_limit(tmp_path, command, args, words):
    """frf --points 1e8 took 22 GB and a traceback, 1e9 met the OOM killer; cosim --duration 1e9
    and --speed 1e300 gave tracebacks."""
    p = run_cli(command, *args, cwd=tmp_path)
    _one_line_error(p, words)
    assert "the limit is" in p.stderr and "half the memory available" in p.stderr


@pytest.mark.integration
@pytest.mark.parametrize(
    "args, words",
    [
        (["--duration", "1e9"], "1e+12 communication points; the limit is 1e+09"),
        (["--road", "bump", "--duration", "1e300"], "the limit is 1e+09"),
    ],
)
def test_runs_beyond_the_step_limit_are_refused(tmp_path, args, words):
    """cosim --duration 1e9 gave a traceback (a 7 TB time axis). A streamed run needs no
    memory per step; what limits it is time, named in the message."""
    _one_line_error(run_cli("cosim", *args, cwd=tmp_path), words)
