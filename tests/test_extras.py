"""The slim install: the optional parts of bodyvib and the line that names a missing one.

``pip install bodyvib`` leaves out what only sweeps, fits, OpenCRG roads and MDF4 signals
need (pyproject.toml's optional-dependencies). Checked here, in the test process: the
extras :mod:`bodyvib.process.extras` knows are the ones pyproject.toml declares, no module
imports an extra's package when it is imported itself (only inside the functions that use
it), and a command whose extra is missing says which, in one line, with status 2.
``tests/test_wheel.py`` installs the wheel without extras into a clean environment.
"""

import ast
import importlib.metadata
import re

import pytest
from helpers import ROOT
from test_layers import MODULES

from bodyvib.cli.main import main
from bodyvib.process import extras

tomllib = pytest.importorskip("tomllib")


def _declared():
    """pyproject.toml's extras of the slim install -> the distributions each brings."""
    with open(f"{ROOT}/pyproject.toml", "rb") as f:
        optional = tomllib.load(f)["project"]["optional-dependencies"]
    out = {}
    for extra in extras.EXTRAS:
        names = set()
        for req in optional[extra]:
            m = re.match(r"([A-Za-z0-9_.-]+)(?:\[([^\]]*)\])?", req)
            names.add(m.group(1).lower())
            if m.group(1) == "dask" and m.group(2):  # dask[distributed] brings distributed
                names.update(m.group(2).split(","))
        out[extra] = names
    return out, optional


def test_the_extras_are_the_ones_pyproject_declares():
    """Each extra's import names belong to exactly the distributions pyproject.toml lists for
    it (importlib.metadata maps them, from the installed packages), and ``all`` is them all."""
    declared, optional = _declared()
    owners = importlib.metadata.packages_distributions()
    for extra, modules in extras.EXTRAS.items():
        dists = {d.lower() for m in modules for d in owners[m]}
        assert dists == declared[extra], extra
    (everything,) = optional["all"]
    assert set(re.fullmatch(r"bodyvib\[(.*)\]", everything).group(1).split(",")) == set(
        extras.EXTRAS
    )
    with open(f"{ROOT}/pyproject.toml", "rb") as f:
        core = tomllib.load(f)["project"]["dependencies"]
    in_core = {re.match(r"[A-Za-z0-9_.-]+", r).group(0).lower() for r in core}
    assert not in_core & set().union(*declared.values())
    assert "bodyvib[all,docs]" in optional["test"]


def _module_level_imports(path):
    """Top names imported by the statements that run when the module is imported (not
    inside a function)."""
    tree = ast.parse(open(path, encoding="utf-8").read())
    found = set()
    todo = list(tree.body)
    while todo:
        node = todo.pop()
        if isinstance(node, ast.Import):
            found.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and not node.level:
            found.add(node.module.split(".")[0])
        elif isinstance(node, (ast.If, ast.Try, ast.With, ast.ClassDef)):
            todo += [n for n in ast.iter_child_nodes(node) if isinstance(n, ast.stmt)]
    return found


OPTIONAL = set().union(*extras.EXTRAS.values())


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_module_imports_an_extra_when_imported(name):
    """So that ``import bodyvib``, the command line and every module load on the slim
    install; the functions that need an extra import it after :func:`extras.require`."""
    assert not _module_level_imports(MODULES[name]) & OPTIONAL


def test_the_module_level_check_sees_imports_in_blocks(tmp_path):
    f = tmp_path / "m.py"
    f.write_text(
        "try:\n    import pandas as pd\nexcept ImportError:\n    pass\ndef g():\n    import numba\n"
    )
    assert _module_level_imports(str(f)) == {"pandas"}


@pytest.fixture
def without(monkeypatch):
    """Make an extra missing: one of its modules is a name nothing provides."""

    def remove(extra):
        monkeypatch.setitem(extras.EXTRAS, extra, (*extras.EXTRAS[extra], "bodyvib_absent_mod"))

    return remove


def test_require_names_the_extras_and_the_command(without):
    extras.require("bodyvib sweep", "sweep", "fit")  # installed here: no error
    without("sweep")
    without("fit")
    with pytest.raises(ImportError) as info:
        extras.require("bodyvib design", "fit", "sweep")
    assert str(info.value) == (
        "bodyvib design needs the fit and sweep extras: pip install 'bodyvib[fit,sweep]' "
        "(bodyvib_absent_mod not installed)"
    )
    assert isinstance(info.value, extras.MissingExtraError) and info.value.extras == (
        "fit",
        "sweep",
    )


@pytest.mark.parametrize(
    "argv, extra",
    [
        (["sweep", "--grid", "speed=10,20", "--out", "r.parquet"], "sweep"),
        (["fit", "--out", "f.json"], "fit"),
        (["design", "spec.json", "--out", "d"], "fit,sweep"),
    ],
)
def test_a_command_without_its_extra_says_which_in_one_line(
    without, argv, extra, tmp_path, capsys, monkeypatch
):
    """Before any other check or output: one line on stderr, status 2, nothing written."""
    monkeypatch.chdir(tmp_path)
    for e in extra.split(","):
        without(e)
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1
    assert (
        err.startswith(f"bodyvib {argv[0]} needs the ") and f"pip install 'bodyvib[{extra}]'" in err
    )
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "argv, extra, task",
    [
        (["respond", "seat.mf4", "--channel", "a"], "mdf", "reading an MDF4 file"),
        (["road", "road.crg"], "roads", "reading an OpenCRG file"),
    ],
)
def test_a_file_that_needs_an_extra_names_it(
    without, argv, extra, task, tmp_path, capsys, monkeypatch
):
    """The library refuses when it meets the file; the command line prefixes its name."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / argv[1]).write_bytes(
        open(f"{ROOT}/tests/data/opencrg/handmade_straight.crg", "rb").read()
    )
    without(extra)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert (
        err
        == f"bodyvib {argv[0]}: {task} needs the {extra} extra: pip install 'bodyvib[{extra}]' (bodyvib_absent_mod not installed)\n"
    )
