"""The layers stay visible: who may import whom (docs/architecture.md, "Layers").

* ``bodyvib`` (the physics library) imports neither ``vehicle`` nor ``bodyvib.cli``;
* ``vehicle`` (the application) never imports ``bodyvib.cli``;
* ``bodyvib.runtime`` (what travels inside every FMU) imports only itself, numpy and
  the standard library;
* ``bodyvib.process`` (outputs, interrupts, limits: the commands' process concerns)
  imports no physics: only the run-time's errors and the standard library;
* every subpackage says what it is about: a docstring and ``__all__``;
* no import cycle among the project's modules.

Read off the source with :mod:`ast` (every import statement, at module level or inside a
function), so an import on a rarely used path counts as much as one at the top.
"""

import ast
import functools
import importlib.util
import os
import re
import sys

import pytest
from helpers import ROOT

#: Repository folder -> the package it installs as (pyproject.toml's package-dir).
FOLDERS = {"bodyvib": "bodyvib", "vehicle": "bodyvib.vehicle", "fmu_src": "bodyvib.fmu_src"}
PACKAGES = ("bodyvib", "bodyvib.vehicle", "bodyvib.cli", "bodyvib.fmu_src")


def module_files():
    """Project module name -> source path."""
    out = {}
    for folder_name, package in FOLDERS.items():
        root = os.path.join(ROOT, folder_name)
        for folder, _, files in os.walk(root):
            for f in files:
                if f.endswith(".py"):
                    rel = os.path.relpath(os.path.join(folder, f), root)[:-3].split(os.sep)
                    if rel[-1] == "__init__":
                        rel = rel[:-1]
                    out[".".join([package, *rel])] = os.path.join(folder, f)
    return out


MODULES = module_files()


def imports_of(name):
    """Absolute names of the modules a project module imports (relative imports resolved)."""
    path = MODULES[name]
    return imports_in(open(path, encoding="utf-8").read(), name, path.endswith("__init__.py"))


def imports_in(source, name, is_package=False):
    """Absolute names of the modules ``source`` imports, read as module ``name``."""
    tree = ast.parse(source)
    package = name if is_package else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module
            found.add(mod)
            for a in node.names:  # "from . import x" may import a submodule
                if f"{mod}.{a.name}" in MODULES:
                    found.add(f"{mod}.{a.name}")
    return found


def top(mod):
    return mod.split(".")[0]


def layer(mod):
    """The layer a module belongs to: cli, application, fmu sources, or its top-level name."""
    for package, name in (
        ("bodyvib.cli", "cli"),
        ("bodyvib.vehicle", "application"),
        ("bodyvib.fmu_src", "fmu sources"),
    ):
        if mod == package or mod.startswith(package + "."):
            return name
    return top(mod)


def test_the_source_tree_is_what_the_checks_read():
    assert "bodyvib.runtime.engine" in MODULES and "bodyvib.vehicle.cosim" in MODULES
    assert "bodyvib.cli.main" in MODULES


@pytest.mark.parametrize("folder", ["vehicle", "fmu_src"])
def test_a_checkout_folder_is_no_second_package(folder):
    """``import vehicle`` from a checkout would load a second copy of bodyvib.vehicle (its
    own classes, registries and settings): the folder refuses any name but the installed one,
    which it names, and nothing is left in sys.modules."""
    package = FOLDERS[folder]
    init = os.path.join(ROOT, folder, "__init__.py")
    spec = importlib.util.spec_from_file_location(
        folder, init, submodule_search_locations=[os.path.dirname(init)]
    )
    with pytest.raises(ImportError, match=f"import {package}, not {folder}"):
        spec.loader.exec_module(importlib.util.module_from_spec(spec))
    assert folder not in sys.modules
    assert importlib.import_module(package).__file__ == init


def upward(imports):
    """The imports of a library module that reach a layer above it."""
    return sorted(m for m in imports if layer(m) in ("application", "cli"))


def outside_runtime(imports):
    """The imports of a run-time module that an FMU could not satisfy."""
    return sorted(
        m
        for m in imports
        if not (
            m.startswith("bodyvib.runtime")
            or top(m) == "numpy"
            or top(m) in sys.stdlib_module_names
        )
    )


def into_physics(imports):
    """The imports of a process module other than the run-time's errors and file check, the
    stdlib and tqdm."""
    return sorted(
        m
        for m in imports
        if not (
            m in ("bodyvib.runtime.errors", "bodyvib.runtime.inputfile")
            or m.startswith("bodyvib.process")
            or top(m) in sys.stdlib_module_names
            or m == "tqdm"
        )
    )


@pytest.mark.parametrize("name", sorted(m for m in MODULES if layer(m) == "bodyvib"))
def test_library_imports_neither_application_nor_command_line(name):
    bad = upward(imports_of(name))
    assert bad == [], f"{name} imports {bad}: the physics library must not know the layers above it"


@pytest.mark.parametrize("name", sorted(m for m in MODULES if layer(m) == "application"))
def test_application_does_not_import_command_line(name):
    bad = sorted(m for m in imports_of(name) if layer(m) == "cli")
    assert bad == [], f"{name} imports {bad}"


@pytest.mark.parametrize("name", sorted(m for m in MODULES if m.startswith("bodyvib.runtime")))
def test_runtime_imports_only_itself_numpy_and_stdlib(name):
    bad = outside_runtime(imports_of(name))
    assert bad == [], f"{name} imports {bad}: the FMU run-time may import only itself and numpy"


@pytest.mark.parametrize("name", sorted(m for m in MODULES if m.startswith("bodyvib.process")))
def test_process_concerns_import_no_physics(name):
    bad = into_physics(imports_of(name))
    assert bad == [], f"{name} imports {bad}: output checks, interrupts and limits know no physics"


SUBPACKAGES = sorted(m for m, p in MODULES.items() if p.endswith("__init__.py") and "." in m)


def test_the_subjects_are_subpackages():
    for pkg in (
        "bodyvib.comfort",
        "bodyvib.fit",
        "bodyvib.fmu",
        "bodyvib.frequency",
        "bodyvib.process",
        "bodyvib.runtime",
        "bodyvib.vehicle.road",
        "bodyvib.vehicle.sweep",
    ):
        assert pkg in SUBPACKAGES, f"{pkg} is not a subpackage"
    # bodyvib.fmu_src is the repository's fmu_src/ folder installed (its name is the layout's)
    flat = sorted(
        m
        for m in MODULES
        if m.count(".") == 1
        and "_" in m.split(".")[1]
        and m != "bodyvib.fmu_src"
        and m.split(".")[1].split("_")[0] in {"fit", "sweep", "comfort", "fmu", "native"}
    )
    assert flat == [], f"prefix-named modules instead of subpackages: {flat}"


@pytest.mark.parametrize("name", SUBPACKAGES)
def test_every_subpackage_says_what_it_is(name):
    tree = ast.parse(open(MODULES[name], encoding="utf-8").read())
    doc = ast.get_docstring(tree)
    assert doc and len(doc.split()) >= 15, (
        f"{name}/__init__.py needs a paragraph saying what it holds"
    )
    if name == "bodyvib.runtime":
        return  # copied into FMUs under another name: its modules are its interface
    assigned = {
        name.id
        for n in tree.body
        if isinstance(n, ast.Assign)
        for t in n.targets
        for name in (t.elts if isinstance(t, ast.Tuple) else [t])  # lazy_exports's triple
        if isinstance(name, ast.Name)
    }
    assert "__all__" in assigned, f"{name} has no __all__"


def test_no_import_cycle():
    graph = {m: {i for i in imports_of(m) if i in MODULES and i != m} for m in MODULES}
    # a package's __init__ importing its own submodules is not a cycle of subjects
    for m in graph:
        graph[m] = {
            i
            for i in graph[m]
            if not (i.startswith(m + ".") and m in PACKAGES + ("bodyvib.runtime",))
        }
    state, stack, cycles = {}, [], []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                cycles.append(stack[stack.index(n) :] + [n])
            elif n not in state:
                visit(n)
        stack.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)
    assert cycles == [], "import cycles: " + "; ".join(" -> ".join(c) for c in cycles)


def test_checks_can_fail():
    """The checks above flag what they guard: fed a source that breaks each rule (an
    import inside a function, a relative import), the same functions name the culprit."""
    src = (
        "def f():\n    from bodyvib.vehicle.quarter_car import load_car\n"
        "from ..frequency.response import transmissibility\nimport scipy.linalg\n"
    )
    found = imports_in(src, "bodyvib.runtime.network")
    assert "bodyvib.vehicle.quarter_car" in found and "bodyvib.frequency.response" in found
    assert upward(found) == ["bodyvib.vehicle.quarter_car"]
    assert outside_runtime(found) == [
        "bodyvib.frequency.response",
        "bodyvib.vehicle.quarter_car",
        "scipy.linalg",
    ]
    assert into_physics(
        imports_in("from ..models import load_model\n", "bodyvib.process.outputs")
    ) == ["bodyvib.models"]
    assert "bodyvib.runtime.errors" in imports_of("bodyvib.runtime.network")


# -- the library speaks Python, the command line speaks flags ---------------------------

#: A ``--flag`` in a string: two dashes, a lower-case word, more words after single dashes.
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9]*(?:-[a-z0-9]+)*(?![\w-])")

#: The library strings outside docstrings that may name a ``--flag``: the arguments of
#: other programs (a linker, pythonfmu's builder, git) and the provenance record of the
#: command that made a file (the cross-check's ``_cc.sh``). Module -> flags.
ALLOWED_FLAGS = {
    "bodyvib.fmu.crosscheck": ["--cross-check", "--cross-check", "--params", "--params"],
    "bodyvib.fmu.native": ["--no-undefined"],
    "bodyvib.fmu.pythonfmu": ["--handle-state", "--no-external-tool", "--serialize-state"],
    "bodyvib.vehicle.sweep.table": ["--porcelain", "--untracked-files"],
}


@functools.cache
def library_tree(path):
    """The parsed source of a module file (both checks below read every module)."""
    return ast.parse(open(path, encoding="utf-8").read())


def flags_in(source):
    """``(line, flag)`` of every ``--flag`` in the string literals of ``source`` (text or a
    parsed tree) outside docstrings (the parts of f-strings included)."""
    tree = ast.parse(source) if isinstance(source, str) else source
    docstrings = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (
            isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
            and body
            and isinstance(body[0], ast.Expr)
            and isinstance(body[0].value, ast.Constant)
        ):
            docstrings.add(id(body[0].value))
    return sorted(
        (node.lineno, flag)
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant)
        and isinstance(node.value, str)
        and id(node) not in docstrings
        for flag in FLAG.findall(node.value)
    )


def library_flags():
    """Module -> the flags its strings name, for every module outside ``bodyvib.cli``."""
    found = {}
    for name, path in sorted(MODULES.items()):
        if name == "bodyvib.cli" or name.startswith("bodyvib.cli."):
            continue
        flags = sorted(f for _, f in flags_in(library_tree(path)))
        if flags:
            found[name] = flags
    return found


def test_library_strings_name_no_command_line_flags():
    """The library names its own parameters (``retry_failed=True needs resume=True``, with
    the names in ``BodyvibError.parameters``); ``bodyvib.cli`` shows them as flags."""
    found = library_flags()
    assert found == ALLOWED_FLAGS, "flags in library strings: " + "; ".join(
        f"{m}: {', '.join(f)}" for m, f in found.items() if ALLOWED_FLAGS.get(m) != f
    )
    assert sum(len(f) for f in found.values()) <= 10


def test_the_flag_check_can_fail():
    src = (
        'def f(x):\n    """Docstring: --resume is fine here."""\n'
        '    raise ValueError(f"--retry-failed goes with {x} --resume")\n'
        'LABEL = ("--out", 1)\nDIAGRAM = "seat --ks-- m2"\n'
    )
    assert flags_in(src) == [(3, "--resume"), (3, "--retry-failed"), (4, "--out")]


def declared_parameters():
    """Every name a library call lists literally in ``parameters=(...)``: name -> modules."""
    found = {}
    for name, path in sorted(MODULES.items()):
        if name == "bodyvib.cli" or name.startswith("bodyvib.cli."):
            continue
        for node in ast.walk(library_tree(path)):
            for kw in getattr(node, "keywords", ()) if isinstance(node, ast.Call) else ():
                if kw.arg == "parameters" and isinstance(kw.value, (ast.Tuple, ast.List)):
                    for elt in kw.value.elts:
                        if isinstance(elt, ast.Constant) and isinstance(elt.value, str):
                            found.setdefault(elt.value, set()).add(name)
    return found


def test_every_parameter_a_library_message_names_has_its_flag():
    """The one table ``bodyvib.cli.flags.FLAGS`` knows every parameter the library names
    in a message, and each flag it gives is one the command line has."""
    from bodyvib.cli.flags import FLAGS
    from bodyvib.cli.main import build_parser

    named = declared_parameters()
    assert len(named) > 20  # the scan finds them
    missing = {p: sorted(m) for p, m in named.items() if p not in FLAGS}
    assert not missing, f"parameters without a flag in bodyvib.cli.flags.FLAGS: {missing}"
    parser = build_parser()
    options = set()
    for action in parser._actions:
        if isinstance(action.choices, dict):  # the subcommands
            for command in action.choices.values():
                options.update(o for a in command._actions for o in a.option_strings)
    for flag in FLAGS.values():
        for word in flag.split():
            assert not word.startswith("--") or word in options, (flag, word)
