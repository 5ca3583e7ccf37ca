"""The layers stay visible: who may import whom (docs/architecture.md, "Layers").

* ``bodyvib`` (the physics library) imports neither ``vehicle`` nor ``bodyvib_cli``;
* ``vehicle`` (the application) never imports ``bodyvib_cli``;
* ``bodyvib.runtime`` (what travels inside every FMU) imports only itself, numpy and
  the standard library;
* no import cycle among the project's modules.

Read off the source with :mod:`ast` (every import statement, at module level or inside a
function), so an import on a rarely used path counts as much as one at the top.
"""

import ast
import os
import sys

import pytest

from conftest import ROOT

PACKAGES = ("bodyvib", "vehicle", "bodyvib_cli", "fmu_src")


def module_files():
    """Project module name -> source path."""
    out = {}
    for pkg in PACKAGES:
        for folder, _, files in os.walk(os.path.join(ROOT, pkg)):
            for f in files:
                if f.endswith(".py"):
                    rel = os.path.relpath(os.path.join(folder, f), ROOT)[:-3].split(os.sep)
                    if rel[-1] == "__init__":
                        rel = rel[:-1]
                    out[".".join(rel)] = os.path.join(folder, f)
    return out


MODULES = module_files()


def imports_of(name):
    """Absolute names of the modules a project module imports (relative imports resolved)."""
    path = MODULES[name]
    tree = ast.parse(open(path, encoding="utf-8").read(), path)
    package = name if path.endswith("__init__.py") else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
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


def test_the_source_tree_is_what_the_checks_read():
    assert "bodyvib.runtime.engine" in MODULES and "vehicle.cosim" in MODULES
    assert "bodyvib_cli.main" in MODULES


@pytest.mark.parametrize("name", sorted(m for m in MODULES if top(m) == "bodyvib"))
def test_library_imports_neither_application_nor_command_line(name):
    bad = sorted(m for m in imports_of(name) if top(m) in ("vehicle", "bodyvib_cli"))
    assert bad == [], f"{name} imports {bad}: the physics library must not know the layers above it"


@pytest.mark.parametrize("name", sorted(m for m in MODULES if top(m) == "vehicle"))
def test_application_does_not_import_command_line(name):
    bad = sorted(m for m in imports_of(name) if top(m) == "bodyvib_cli")
    assert bad == [], f"{name} imports {bad}"


@pytest.mark.parametrize("name", sorted(m for m in MODULES if m.startswith("bodyvib.runtime")))
def test_runtime_imports_only_itself_numpy_and_stdlib(name):
    allowed_third_party = {"numpy"}
    bad = []
    for m in imports_of(name):
        if m.startswith("bodyvib.runtime") or top(m) in allowed_third_party:
            continue
        if top(m) in sys.stdlib_module_names:
            continue
        bad.append(m)
    assert bad == [], f"{name} imports {sorted(bad)}: the FMU run-time may import only itself and numpy"


def test_no_import_cycle():
    graph = {m: {i for i in imports_of(m) if i in MODULES and i != m} for m in MODULES}
    # a package's __init__ importing its own submodules is not a cycle of subjects
    for m in graph:
        graph[m] = {i for i in graph[m] if not (i.startswith(m + ".") and m in PACKAGES + ("bodyvib.runtime",))}
    state, stack, cycles = {}, [], []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                cycles.append(stack[stack.index(n):] + [n])
            elif n not in state:
                visit(n)
        stack.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)
    assert cycles == [], "import cycles: " + "; ".join(" -> ".join(c) for c in cycles)


def test_checks_can_fail():
    """The import reader sees a function-level import of the application (what the
    library test refuses) and a relative import resolved to its absolute name."""
    src = "def f():\n    from vehicle.quarter_car import load_car\nfrom .errors import X\n"
    tree = ast.parse(src)
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            names.add(("." * node.level) + (node.module or ""))
    assert names == {"vehicle.quarter_car", ".errors"}
    assert "bodyvib.runtime.errors" in imports_of("bodyvib.runtime.network")
