"""Functions a reader holds at once: none over 100 lines outside the compiled kernels.

Read off the source with :mod:`ast` over the library, the application, the FMU sources'
Python and ``build_fmu.py``. A function's length runs from its ``def`` (or first
decorator) to its last line, docstring included, less the functions compiled by numba
(``@njit``) it defines: those kernels are one loop nest each and stay whole.
"""

import ast
import glob
import os

from helpers import ROOT

#: Most lines of a function (the developer guide's rule).
MAX_LINES = 100


def python_files():
    """The checked sources, relative to the repository."""
    out = []
    for folder in ("bodyvib", "vehicle"):
        out += glob.glob(os.path.join(ROOT, folder, "**", "*.py"), recursive=True)
    out += glob.glob(os.path.join(ROOT, "fmu_src", "*.py"))
    out.append(os.path.join(ROOT, "build_fmu.py"))
    return sorted(os.path.relpath(p, ROOT) for p in out)


def _compiled(node):
    """A function compiled by numba: decorated ``@njit``/``@jit`` (called or not)."""
    for d in node.decorator_list:
        target = d.func if isinstance(d, ast.Call) else d
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name in ("njit", "jit"):
            return True
    return False


def _span(node):
    first = min([node.lineno] + [d.lineno for d in node.decorator_list])
    return node.end_lineno - first + 1


def long_functions(source, path="<source>"):
    """``(path:line name, lines)`` of every function over :data:`MAX_LINES` in ``source``."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) or _compiled(node):
            continue
        kernels = sum(
            _span(n)
            for n in ast.walk(node)
            if n is not node
            and isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))
            and _compiled(n)
        )
        lines = _span(node) - kernels
        if lines > MAX_LINES:
            out.append((f"{path}:{node.lineno} {node.name}", lines))
    return out


def test_the_check_counts_lines_and_skips_kernels():
    body = "".join(f"    x{i} = {i}\n" for i in range(99))
    assert long_functions(f"def f():\n{body}") == []  # 100 lines
    assert long_functions(f"def f():\n{body}    return 1\n") == [("<source>:1 f", 101)]
    kernel = (
        f"def factory():\n    @njit(cache=True)\n    def k():\n{body.replace('    ', '        ')}"
    )
    assert long_functions(kernel) == []
    assert long_functions(
        f"class C:\n    def m(self):\n{body.replace('    ', '        ')}        return 1\n"
    ) == [("<source>:2 m", 101)]


def test_no_function_over_100_lines():
    files = python_files()
    assert "build_fmu.py" in files and any(f.startswith("fmu_src") for f in files)
    found = []
    for path in files:
        with open(os.path.join(ROOT, path), encoding="utf-8") as f:
            found += long_functions(f.read(), path)
    assert found == [], "split these functions: " + ", ".join(f"{p} ({n} lines)" for p, n in found)
