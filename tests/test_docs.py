"""The documentation lives in the project: references point at sections and files that exist.

Code, tests and docs cite a documentation page followed by a section title in quotes
(``docs/getting_started.md, "The check"``); each such section must be a heading of that
page. Paths the README and the documentation pages name must exist in the tree, and the
layout page must list every top-level entry of the repository.
"""

import glob
import os
import re
import subprocess
import sys

import pytest
from helpers import ROOT

ARCH = os.path.join(ROOT, "docs", "architecture.md")


def tracked():
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True)
    if out.returncode != 0 or not out.stdout.strip():
        pytest.skip("not a git checkout")
    return [f for f in out.stdout.split() if os.path.isfile(os.path.join(ROOT, f))]


def text(path):
    with open(os.path.join(ROOT, path), encoding="utf-8", errors="replace") as f:
        return f.read()


def sections():
    return {m.group(1).strip() for m in re.finditer(r"^#+ (.+)$", text(ARCH), re.M)}


def test_every_reference_to_the_design_names_a_section_it_has():
    refs = []
    for f in tracked():
        if f.endswith((".py", ".md", ".c", ".toml", ".txt")) or f.startswith(".ci/"):
            for m in re.finditer(r'architecture\.md,?\s+"([^"]+)"', text(f)):
                refs.append((f, m.group(1)))
    assert refs, "the code cites the design"
    have = sections()
    missing = [(f, s) for f, s in refs if s not in have]
    assert not missing, missing


def test_no_reference_to_a_design_file_the_repository_lacks():
    bad = [
        f
        for f in tracked()
        if f != "tests/test_docs.py" and re.search(r"DESIGN\.md|shared/", text(f))
    ]
    assert not bad, bad


def pages():
    """The documentation's hand-written pages (the generated ones are not in git)."""
    return sorted(
        f for f in tracked() if f.startswith("docs/") and f.endswith(".md") and "/changes/" not in f
    )


def headings(path):
    """The titles of a Markdown file's headings."""
    return {m.group(1).strip() for m in re.finditer(r"^#+ (.+)$", text(path), re.M)}


CITATION = re.compile(r"""(docs/[\w./-]+\.md),?\s+["']([^"'\n]+)["']""")


def citations():
    """Every (file, page, section) a tracked code, test or docs file cites."""
    out = []
    for f in tracked():
        if f.endswith((".py", ".md", ".c", ".h", ".toml", ".txt")) or f.startswith(".ci/"):
            if f == "tests/test_docs.py":
                continue
            out += [(f, m.group(1), m.group(2)) for m in CITATION.finditer(text(f))]
    return out


def unresolved(refs):
    """The citations among ``refs`` whose page is missing or lacks the section."""
    return [
        (f, page, section)
        for f, page, section in refs
        if not os.path.isfile(os.path.join(ROOT, page)) or section not in headings(page)
    ]


def test_every_cited_docs_section_is_a_heading_of_its_page():
    refs = citations()
    assert len(refs) >= 15, refs  # the code cites the pages (the citations were found)
    assert not unresolved(refs)


@pytest.mark.parametrize(
    "citation",
    [
        'see docs/models.md, "No such section"',  # a heading the page lacks
        "see docs/no_such_page.md, 'Layout'",  # a page that does not exist
        'see docs/getting_started.md "The Check"',  # headings are matched exactly
    ],
)
def test_a_stale_citation_is_caught(citation):
    (m,) = CITATION.finditer(citation)
    assert unresolved([("x.py", m.group(1), m.group(2))])


def test_no_code_cites_the_readme():
    """The README is a short page; sections cited from code live in docs/ pages."""
    readers = {"tests/test_readme.py", "tests/test_docs.py", "pyproject.toml"}
    bad = [
        f
        for f in tracked()
        if f.endswith((".py", ".c", ".h", ".toml"))
        and f not in readers
        and "README" in text(f)
        and not f.startswith("docs/")
    ]
    assert not bad, bad


@pytest.mark.parametrize("doc", ["README.md", "CHANGELOG.md", "docs/*.md"])
def test_paths_the_docs_name_exist(doc):
    for path in pages() if doc == "docs/*.md" else [doc]:
        _check_paths(path)


#: Folders the docs build writes (git ignores them): named in the docs, absent before a build.
GENERATED = ("docs/_build/", "docs/api/", "docs/auto_examples/", "docs/_generated/")


def _check_paths(doc):
    missing = _missing_paths(text(doc))
    assert not missing, f"{doc} names paths the tree lacks: {missing}"


def _missing_paths(content):
    """The paths of the tree that ``content`` names in backquotes and the tree lacks."""
    files = set(tracked())
    dirs = {os.path.dirname(f) for f in files}
    dirs |= {d for f in list(dirs) for d in [os.path.dirname(f)] if d}
    outputs = {"params/refit.json"}  # what `bodyvib fit` writes by default, not a shipped file
    missing = []
    for token in re.findall(r"`([^`\s]+)`", content):
        token = token.rstrip(".,:;")
        top = token.split("/")[0]
        if (
            "/" not in token
            or os.path.isabs(token)  # a path of the machine (/usr/bin/chromium), not the tree
            or not os.path.exists(os.path.join(ROOT, top))
            or "<" in token
        ):
            continue  # not a path of this tree (a unit like m/s2, a URL, a placeholder)
        if (
            token.rstrip("/") in dirs
            or token in files
            or token in outputs
            or token.startswith(GENERATED)
        ):
            continue
        if not glob.glob(os.path.join(ROOT, token)):
            missing.append(token)
    return missing


def test_a_path_of_the_machine_is_no_path_of_the_tree():
    """The documentation guide names the browser's binary; the check of the tree's paths
    must not depend on whether this machine has it."""
    named = "`/usr/bin/bodyvib-no-such-browser`, `docs/no-such-page.md`, `docs/index.md`"
    assert _missing_paths(named) == ["docs/no-such-page.md"]


def test_page_titles_are_short():
    """The theme's sidebar lists every page by its title: a title names the subject, and the
    page's first paragraph says the rest."""
    long = {}
    for page in pages():
        title = re.search(r"^# (.+)$", text(page), re.M).group(1)
        if len(title) > 30:
            long[page] = title
    assert not long, long


def test_layout_page_lists_the_top_level_of_the_tree():
    layout = text("docs/layout.md")
    block = re.search(r"^## Layout\n+```\n(.*?)```", layout, re.M | re.S)
    assert block, "docs/layout.md has a Layout section with a code block"
    listed = {
        ln.split()[0].rstrip("/").split("/")[0]
        for ln in block.group(1).splitlines()
        if ln and not ln.startswith(" ")
    }
    top = {f.split("/")[0] for f in tracked()} - {".gitignore", ".pre-commit-config.yaml"}
    assert top <= listed, f"not in the layout: {sorted(top - listed)}"
    assert listed <= top, f"listed but not in the tree: {sorted(listed - top)}"
    for ln in block.group(1).splitlines():  # the modules named under bodyvib/ exist
        if ln.startswith("  ") and ln.split()[0].endswith(".py"):
            for mod in ln.split():
                if mod.endswith(".py"):
                    assert os.path.isfile(os.path.join(ROOT, "bodyvib", mod)), mod


# -- cross-references resolve -------------------------------------------------
ROLE = re.compile(r":(func|class|mod|meth|data|attr):`([^`]+)`")
PACKAGES = ("bodyvib", "bodyvib.vehicle", "bodyvib.cli")
#: Repository folder -> the package it installs as (pyproject.toml's package-dir).
FOLDERS = {"bodyvib": "bodyvib", "vehicle": "bodyvib.vehicle"}


def module_of(path):
    """The module a tracked file is, by its installed name, or None (docs, scripts)."""
    top = path.split("/")[0]
    if not path.endswith(".py") or top not in FOLDERS:
        return None
    name = FOLDERS[top] + path[len(top) : -3].replace("/", ".")
    return name[: -len(".__init__")] if name.endswith(".__init__") else name


def _walk(obj, parts):
    """getattr along ``parts``; a dataclass field or an attribute the class's numpydoc
    ``Attributes`` section lists counts (instance attributes are not on the class)."""
    import dataclasses
    import inspect

    for i, part in enumerate(parts):
        if hasattr(obj, part):
            obj = getattr(obj, part)
            continue
        last = i == len(parts) - 1
        if (
            last
            and inspect.isclass(obj)
            and (
                (
                    dataclasses.is_dataclass(obj)
                    and part in {f.name for f in dataclasses.fields(obj)}
                )
                or re.search(rf"^\s*{re.escape(part)}\b.*:", inspect.getdoc(obj) or "", re.M)
            )
        ):
            return True
        return False
    return True


def resolves(target, context):
    """Whether a Sphinx cross-reference names a real object: a dotted name from the top
    (``bodyvib.frequency.response.find_peaks``), or relative to the module it is written
    in, one of that module's classes, or its package (Sphinx's look-up order)."""
    import importlib
    import inspect

    target = target.strip().lstrip("~")
    if "<" in target:  # "title <target>"
        target = target[target.index("<") + 1 : target.rindex(">")]
    if target.startswith(".") and context:  # relative to the current package
        pkg = (
            context
            if context in PACKAGES
            or os.path.basename(importlib.import_module(context).__file__) == "__init__.py"
            else context.rpartition(".")[0]
        )
        target = f"{pkg}{target}"
    parts = target.split(".")
    for i in range(len(parts), 0, -1):
        try:
            module = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        if _walk(module, parts[i:]):
            return True
        break
    if context:
        module = importlib.import_module(context)
        scopes = [module] + [c for _, c in inspect.getmembers(module, inspect.isclass)]
        if "." in context:
            scopes.append(importlib.import_module(context.rpartition(".")[0]))
        return any(_walk(scope, parts) for scope in scopes)
    return False


def test_every_cross_reference_resolves_to_a_real_object():
    """Every :func:/:class:/:mod:/:meth:/:data:/:attr: in the library's docstrings and the
    docs names something that imports (a renamed or moved name left references behind)."""
    refs, bad = 0, []
    for f in tracked():
        if not (f.endswith(".md") or module_of(f)):
            continue
        context = module_of(f)
        for m in ROLE.finditer(text(f)):
            refs += 1
            if not resolves(m.group(2), context):
                bad.append(f"{f}: {m.group(0)}")
    assert refs > 300, refs  # the references were found
    assert not bad, bad


@pytest.mark.parametrize(
    "ref, context",
    [
        ("bodyvib.network.LinearModel.output_index", None),  # the module moved
        ("bodyvib.models.network_from_dict", None),  # the function moved
        ("SIGNALS.nope", "bodyvib.vehicle.signals"),
        ("no_such_name", "bodyvib.vehicle.cosim"),
        ("bodyvib.runtime.engine.FmuCore.no_such_attribute", None),
    ],
)
def test_a_stale_reference_is_caught(ref, context):
    assert not resolves(ref, context)


# -- the site's generated pages ------------------------------------------------------


def sitegen():
    """docs/_ext/sitegen.py, what the documentation build generates."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "sitegen", os.path.join(ROOT, "docs", "_ext", "sitegen.py")
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_api_reference_lists_every_name_of_every_public_package():
    """A package page names exactly its package's ``__all__``; every package of the wheel
    with a non-empty ``__all__`` has one (data, C sources and the CLI aside)."""
    import importlib

    gen = sitegen()
    packages = gen.public_packages()
    assert {"bodyvib", "bodyvib.comfort", "bodyvib.frequency", "bodyvib.vehicle.road"} <= set(
        packages
    )
    for package in packages:
        page = gen._package_page(package)
        entries = re.findall(r"^   (\w+)$", page, re.M)
        # a subpackage with its own page is a link to it, not a second copy
        linked = re.findall(rf"^\* :doc:`{re.escape(package)}\.(\w+)`$", page, re.M)
        assert all(f"{package}.{n}" in packages for n in linked), (package, linked)
        assert sorted(entries + linked) == sorted(importlib.import_module(package).__all__), package


def test_the_changelog_fragments_merge_by_section():
    import doctest

    gen = sitegen()
    assert doctest.testmod(gen).failed == 0
    merged = gen.merge_fragments(sorted(glob.glob(os.path.join(ROOT, "docs", "changes", "*.md"))))
    assert merged.startswith("### ") and merged.count("### Added") <= 1


@pytest.mark.integration
def test_the_development_guide_counts_the_tiers():
    """The development guide's test counts are pytest's, within 15 % (the suite grows with
    every change; a guide 50 % behind misled a reader once)."""
    page = text("docs/guide/development.md")
    fast = int(re.search(r"the fast tier collects (\d+) tests", page).group(1))
    rest = int(re.search(r"integration tier holds the other (\d+) tests", page).group(1))
    out = subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-q", "-m", "not integration"]
        + ["-p", "no:cacheprovider"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    picked, total = map(int, re.search(r"(\d+)/(\d+) tests collected", out.stdout).groups())
    counted = (picked, total - picked)
    for documented, n in zip((fast, rest), counted):
        assert abs(documented - n) <= 0.15 * n, (documented, n)
