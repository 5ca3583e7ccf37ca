"""The package as installed: a wheel, not the checkout, builds the FMUs and runs the check.

A regular install once failed at ``bodyvib build`` because the FMU slave source
did not travel with the package. This builds the wheel, checks that it carries
every file of the packages (the slave template, the run-time package, the
shipped parameter files), installs it without extras (the slim install) into a clean
virtual environment with its dependencies from the index, checks that none of the
extras' packages came with it,
and runs ``bodyvib build``, a short ``bodyvib check`` and a ``bodyvib sweep`` that names
the extra it needs, from a folder outside the checkout. ``.ci/run`` does the same.
"""

import os
import runpy
import shutil
import subprocess
import sys
import zipfile

import pytest

pytestmark = pytest.mark.integration

from helpers import ROOT, run_ok, run_text

#: Repository folder -> its place in the wheel (pyproject.toml's package-dir).
FOLDERS = {"bodyvib": "bodyvib", "vehicle": "bodyvib/vehicle", "fmu_src": "bodyvib/fmu_src"}


def _tracked(*paths):
    """Tracked files (as in the working tree; outside git, the files present), relative to ROOT."""
    out = subprocess.run(["git", "ls-files", *paths], cwd=ROOT, capture_output=True, text=True)
    if out.returncode == 0 and out.stdout.strip():
        files = out.stdout.split()
    else:
        files = [
            os.path.relpath(os.path.join(d, f), ROOT)
            for p in paths or (".",)
            for d, ds, fs in os.walk(os.path.join(ROOT, p))
            if not {".git", ".venv", "build"} & set(os.path.relpath(d, ROOT).split(os.sep))
            for f in fs
        ]
    return sorted(
        f
        for f in files
        if "__pycache__" not in f
        and not f.endswith(".pyc")
        and os.path.isfile(os.path.join(ROOT, f))
    )


def _package_files():
    """Tracked package files, as the paths they have inside the wheel."""
    out = []
    for folder, place in FOLDERS.items():
        for f in _tracked(folder):
            out.append(place + f.replace(os.sep, "/")[len(folder) :])
    return out


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    # built from a copy of the tracked files: setuptools writes build/ next to the
    # sources, and the checkout stays untouched
    src = tmp_path_factory.mktemp("src")
    for f in _tracked():
        os.makedirs(os.path.dirname(src / f), exist_ok=True)
        shutil.copy2(os.path.join(ROOT, f), src / f)
    dest = tmp_path_factory.mktemp("wheel")
    out = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", str(src), "-w", str(dest)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=str(dest),
    )
    assert out.returncode == 0, out.stdout + out.stderr
    wheels = list(dest.glob("bodyvib-*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


def test_wheel_carries_every_package_file(wheel):
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
    missing = [f for f in _package_files() if f not in names]
    assert not missing, f"not in the wheel: {missing}"
    for needed in (
        "bodyvib/fmu_src/bodyvib_fmu_slave.py",
        "bodyvib/runtime/engine.py",
        "bodyvib/data/reduced-paper.json",
        "bodyvib/data/fit/default-config.json",
        "bodyvib/vehicle/data/quarter-car.json",
        "bodyvib/cli/main.py",
    ):
        assert needed in names


def test_wheel_has_one_import_root(wheel):
    """site-packages receives bodyvib, its dist-info and nothing else."""
    with zipfile.ZipFile(wheel) as z:
        roots = {n.split("/")[0] for n in z.namelist()}
    assert {r for r in roots if not r.endswith(".dist-info")} == {"bodyvib"}, roots


def test_package_list_is_derived_from_the_tree():
    """No package list is kept by hand: setup.py derives it from the folders and
    pyproject.toml's package-dir, so a new subpackage is in the wheel without an entry."""
    tomllib = pytest.importorskip("tomllib")

    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        tool = tomllib.load(f)["tool"]["setuptools"]
    assert "packages" not in tool
    assert tool["package-dir"] == {"bodyvib.vehicle": "vehicle", "bodyvib.fmu_src": "fmu_src"}
    derived = set(runpy.run_path(os.path.join(ROOT, "setup.py"), run_name="setup")["packages"]())
    found = set()
    for folder, place in FOLDERS.items():
        for f in _tracked(folder):
            parts = place.split("/") + os.path.dirname(os.path.relpath(f, folder)).split(os.sep)
            found.add(".".join(p for p in parts if p))
    assert derived == found, (sorted(derived - found), sorted(found - derived))


#: What the slim install leaves to the extras (pyproject.toml's optional-dependencies).
NOT_SLIM = (
    "numba",
    "pyarrow",
    "dask",
    "distributed",
    "pandas",
    "asammdf",
    "pymoo",
    "deap",
    "cma",
    "pycrg",
)


def test_installed_wheel_builds_fmus_and_runs_the_check(wheel, tmp_path):
    """The slim install, as a user gets it: the wheel without extras, its dependencies from
    the index, into a clean virtual environment (about a minute from a warm pip cache)."""
    venv = tmp_path / "venv"
    subprocess.run(
        [sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120
    )
    py = venv / "bin" / "python"
    out = subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(py), "install", "-q", str(wheel)],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    present = subprocess.run(
        [
            str(py),
            "-c",
            "import importlib.util, sys; "
            "print(*[m for m in sys.argv[1:] if importlib.util.find_spec(m)])",
            *NOT_SLIM,
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    assert present.stdout.split() == [], "installed without an extra: " + present.stdout

    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env["MPLBACKEND"] = "Agg"
    where = run_ok(
        [
            str(py),
            "-c",
            "import bodyvib, bodyvib.fmu_src, bodyvib.vehicle; "
            "print(bodyvib.__file__, bodyvib.fmu_src.__file__, bodyvib.vehicle.__file__)",
        ],
        work,
        env,
        timeout=120,
    )
    assert all(p.startswith(str(venv)) for p in where.stdout.split()), where.stdout

    exe = str(venv / "bin" / "bodyvib")
    run_ok([exe, "build", "--dest", "fmus"], work, env)
    assert sorted(p.name for p in (work / "fmus").iterdir()) == [
        "FullCar.fmu",
        "FullCarWithOccupant.ssp",
        "HalfCar.fmu",
        "HalfCarWithOccupant.ssp",
        "HumanBody3DOF.fmu",
        "HumanBodyISO7962.fmu",
        "QuarterCar.fmu",
        "QuarterCarWithOccupant.ssp",
        "Road.fmu",
        "RoadFourWheel.fmu",
        "RoadFrontRear.fmu",
    ]
    check = run_ok([exe, "check", "--duration", "2", "--quiet"], work, env)
    assert "verdict: " in check.stdout
    sweep = run_text([exe, "sweep", "--grid", "speed=10,20", "--out", "r.parquet"], work, env, 120)
    assert (sweep.returncode, sweep.stdout) == (2, "")
    assert sweep.stderr.startswith(
        "bodyvib sweep needs the sweep extra: pip install 'bodyvib[sweep]'"
    )
    assert sweep.stderr.count("\n") == 1 and not (work / "r.parquet").exists()
