"""The declared public interface: every package's ``__all__`` names what it can give.

Each package says in ``__all__`` what users import from it; the modules behind the names
are internal. These tests import every declared name the way a user does (several
packages resolve theirs on first use, so a name whose module moved is found only by
using it), check that the package lists every subpackage the wheel installs, and that
the command line's start-up still imports none of the heavy parts (a lazy name that
became an eager import would slow every ``bodyvib`` command).
"""

import importlib
import pkgutil
import runpy
import subprocess
import sys
import types

import pytest
from helpers import ROOT

#: Every package with a declared interface (bodyvib.runtime is used through its modules:
#: it is copied into FMUs under another name).
PACKAGES = (
    "bodyvib",
    "bodyvib.cli",
    "bodyvib.comfort",
    "bodyvib.fit",
    "bodyvib.fmu",
    "bodyvib.frequency",
    "bodyvib.process",
    "bodyvib.seat",
    "bodyvib.vehicle",
    "bodyvib.vehicle.road",
    "bodyvib.vehicle.design",
    "bodyvib.vehicle.sweep",
)


def test_every_installed_code_package_declares_an_interface():
    # the packages the wheel installs, as setup.py derives them from the tree
    installed = set(runpy.run_path(f"{ROOT}/setup.py", run_name="setup")["packages"]())
    # data folders, the FMU sources and the run-time have no names to declare
    without = {p for p in installed if ".data" in p or p.startswith("bodyvib.fmu_src")}
    without.add("bodyvib.runtime")
    assert installed - without == set(PACKAGES)


@pytest.mark.parametrize("name", PACKAGES)
def test_every_declared_name_imports(name):
    package = importlib.import_module(name)
    declared = package.__all__
    assert len(set(declared)) == len(declared), f"{name}.__all__ repeats a name"
    missing = [n for n in declared if not hasattr(package, n)]
    assert missing == [], f"{name}.__all__ names what the package cannot give: {missing}"
    assert set(declared) <= set(dir(package)), f"dir({name}) hides declared names"


#: Declared names that are modules by design.
MODULE_NAMES = {
    "bodyvib.process": {
        "extras",
        "interrupts",
        "limits",
        "outputs",
        "progress",
        "scratch",
        "units",
    },
    "bodyvib.vehicle": {"road", "sweep"},
}


@pytest.mark.parametrize("name", PACKAGES)
def test_a_declared_name_stays_itself_once_every_module_is_imported(name):
    # importing a submodule sets the package attribute of its name to the module, so a
    # function resolved on first use and named like its module would turn into the module
    package = importlib.import_module(name)
    for module in pkgutil.iter_modules(package.__path__):
        if not module.name.startswith("_"):  # __main__ would run the command line
            importlib.import_module(f"{name}.{module.name}")
    modules = {n for n in package.__all__ if isinstance(getattr(package, n), types.ModuleType)}
    assert modules == MODULE_NAMES.get(name, set())


def test_a_name_from_the_package_is_the_one_its_module_defines():
    from bodyvib.fmu import build
    from bodyvib.fmu.builder import build as build_in_module
    from bodyvib.vehicle import cosimulate, road
    from bodyvib.vehicle.cosim import cosimulate as cosimulate_in_module

    assert cosimulate is cosimulate_in_module and build is build_in_module
    assert road is importlib.import_module("bodyvib.vehicle.road")


def test_an_undeclared_name_is_an_attribute_error():
    import bodyvib.vehicle

    with pytest.raises(AttributeError, match="no attribute 'cosim_typo'"):
        bodyvib.vehicle.cosim_typo  # noqa: B018


#: What ``import bodyvib.cli.main`` must not load: the application's modules (each command
#: imports its own) and the heavy libraries behind them.
NOT_AT_START = (
    "bodyvib.vehicle.",
    "bodyvib.fit.",
    "bodyvib.fmu.",
    "matplotlib",
    "scipy",
    "fmpy",
    "pythonfmu",
    "dask",
    "pandas",
    "control",
    "numba",
)


@pytest.mark.integration
def test_the_command_line_starts_without_the_heavy_parts():
    out = subprocess.run(
        [sys.executable, "-c", "import sys, bodyvib.cli.main; print(*sorted(sys.modules))"],
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    )
    loaded = out.stdout.split()
    assert "bodyvib.cli.main" in loaded
    early = [m for m in loaded if m.startswith(NOT_AT_START)]
    assert early == [], f"import bodyvib.cli.main loads {early}"
