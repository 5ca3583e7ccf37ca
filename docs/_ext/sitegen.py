"""What the documentation site generates at build time, and one reference resolver.

- :func:`write_api_pages`: the API reference, one page per public package, from its
  ``__all__``;
- :func:`write_unreleased`: the changelog's unreleased part, merged from ``docs/changes/``;
- :func:`resolve_in_defining_module`: names in a re-exported object's docstring resolved
  as its own module sees them.

``docs/conf.py`` calls them; ``tests/test_docs.py`` tests them without building.
"""

import importlib
import os
import pkgutil

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROOT = os.path.dirname(HERE)

# -- the API reference, from the packages' __all__ ------------------------------------
#: Packages installed but not documented as API: data, C sources, the command line
#: (its reference is the CLI page, generated from the parsers).
NOT_API = {
    "bodyvib.data",
    "bodyvib.data.fit",
    "bodyvib.fmu_src",
    "bodyvib.fmu_src.native",
    "bodyvib.cli",
}


def _listed_packages():
    """The packages the wheel installs, as ``setup.py`` derives them from the tree, sorted."""
    import runpy

    return runpy.run_path(os.path.join(ROOT, "setup.py"), run_name="setup")["packages"]()


def public_packages():
    """The packages of ``pyproject.toml`` whose ``__all__`` names something, in order."""
    out = []
    for name in _listed_packages():
        if name in NOT_API:
            continue
        if getattr(importlib.import_module(name), "__all__", None):
            out.append(name)
    return out


def modules_of(package):
    """Every module below ``package`` (its implementation, documented as internal)."""
    pkg = importlib.import_module(package)
    if not hasattr(pkg, "__path__"):
        return []
    return sorted(
        m.name
        for m in pkgutil.iter_modules(pkg.__path__, package + ".")
        if not m.ispkg and not m.name.rpartition(".")[2].startswith("__")
    )


def public_modules():
    """Modules that a public package exports by name (documented on its page)."""
    out = []
    for package in public_packages():
        mod = importlib.import_module(package)
        out += [f"{package}.{n}" for n in mod.__all__ if isinstance(getattr(mod, n), type(mod))]
    return out


def _title(text, char):
    return f"{text}\n{char * len(text)}\n"


def _package_page(package):
    mod = importlib.import_module(package)
    lines = [_title(f"``{package}``", "="), f".. automodule:: {package}", "   :no-members:", ""]
    groups = {"Modules": [], "Classes": [], "Functions": [], "Data": []}
    for name in mod.__all__:
        obj = getattr(mod, name)
        if isinstance(obj, type(mod)):
            groups["Modules"].append(name)
        elif isinstance(obj, type):
            groups["Classes"].append(name)
        elif callable(obj):
            groups["Functions"].append(name)
        else:
            groups["Data"].append(name)
    # a subpackage with a page of its own is linked, not documented a second time
    public = set(public_packages())
    subpackages = [n for n in groups["Modules"] if f"{package}.{n}" in public]
    groups["Modules"] = [n for n in groups["Modules"] if n not in subpackages]
    if subpackages:
        lines += [_title("Subpackages", "-")]
        lines += [f"* :doc:`{package}.{n}`" for n in subpackages] + [""]
    for group, names in groups.items():
        if not names:
            continue
        lines += [_title(group, "-"), f".. currentmodule:: {package}", ""]
        lines += [".. autosummary::", "   :toctree: generated", ""]
        lines += [f"   {name}" for name in names] + [""]
    return "\n".join(lines)


def _internals_page(packages):
    lines = [
        _title("Internal modules", "="),
        "The modules behind the public names. They are documented so that the design",
        "notes and docstrings can point into them; their names and contents may change",
        "between releases without notice: import from the packages above.",
        "",
    ]
    seen = set(public_modules())
    public = set(public_packages())
    for package in packages:
        if package not in public:
            lines += [
                _title(f"``{package}``", "-"),
                f".. automodule:: {package}",
                "   :no-members:",
                "",
            ]
        for module in modules_of(package):
            if module in seen:
                continue
            seen.add(module)
            lines += [
                _title(f"``{module}``", "-"),
                f".. automodule:: {module}",
                "   :members:",
                "   :undoc-members:",
                "   :ignore-module-all:",
                "",
            ]
    return "\n".join(lines)


def internal_roots():
    """Packages whose modules are documented as internals: every package of ``pyproject.toml``
    that holds Python modules (the CLI's too), so a new subpackage needs no edit here."""
    data_only = {"bodyvib.data", "bodyvib.data.fit", "bodyvib.fmu_src", "bodyvib.vehicle.data"}
    return [name for name in _listed_packages() if name not in data_only]


API_DIR = os.path.join(HERE, "api")
UNRELEASED = os.path.join(HERE, "_generated", "unreleased.md")


def write_api_pages(dest=API_DIR):
    """Write the API reference's reST pages into ``dest`` (generated, not kept in git).

    Returns
    -------
    list of str
        The public packages, one page each.
    """
    os.makedirs(dest, exist_ok=True)
    packages = public_packages()
    pages = {}
    for package in packages:
        pages[f"{package}.rst"] = _package_page(package)
    pages["internals.rst"] = _internals_page(internal_roots())
    toc = "\n".join(f"   {p}" for p in packages)
    pages["index.rst"] = (
        _title("API reference", "=")
        + "\nThe public names of each package: what its ``__all__`` exports. Import them\n"
        "from the package (``from bodyvib.comfort import weighted_rms``); the modules behind\n"
        "them are :doc:`internal <internals>`.\n\n"
        f".. toctree::\n   :maxdepth: 1\n\n{toc}\n   internals\n"
    )
    for name, text in pages.items():
        path = os.path.join(dest, name)
        old = open(path, encoding="utf-8").read() if os.path.exists(path) else None
        if old != text:  # unchanged pages keep their time stamp: no needless rebuild
            with open(path, "w", encoding="utf-8") as f:
                f.write(text)
    return packages


# -- names in a re-exported object's docstring ---------------------------------------
# A public name is documented under its package (bodyvib.load_model), but its docstring
# names its neighbours as its own module sees them (load_network, in bodyvib.models).
# Python resolves those names in the defining module, and so does this fallback.


def _defining_module(docname):
    """The module that defines the object an autosummary page documents, or None."""
    if not docname.startswith("api/generated/"):
        return None
    package, _, name = docname.rpartition("/")[2].rpartition(".")
    try:
        obj = getattr(importlib.import_module(package), name)
    except (ImportError, AttributeError):
        return None
    return getattr(obj, "__module__", None)


def resolve_in_defining_module(app, env, node, contnode):
    """Resolve a Python reference left unresolved as the defining module would."""
    if node.get("refdomain") != "py":
        return None
    module = _defining_module(node.get("refdoc", ""))
    if not module or module == node.get("py:module"):
        return None
    retry = node.deepcopy()
    retry["py:module"] = module
    domain = env.get_domain("py")
    return domain.resolve_xref(
        env, node["refdoc"], app.builder, node["reftype"], node["reftarget"], retry, contnode
    )


# -- the changelog's unreleased part, from the fragments in docs/changes/ ---------------


def merge_fragments(paths):
    r"""One Markdown text of changelog fragments, their bullets gathered by section.

    Each fragment is a Markdown bullet list under ``### Added``, ``### Changed`` or
    ``### Fixed`` (or another ``###`` heading); the result has each section once, in the
    order Keep a Changelog gives them, with the bullets of every fragment in file order.

    Parameters
    ----------
    paths : list of str
        The fragment files.

    Returns
    -------
    str
        Markdown; empty when there is no bullet.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     for name, text in [("a.md", "### Fixed\n- one\n"), ("b.md", "### Added\n- two\n")]:
    ...         with open(os.path.join(d, name), "w") as f:
    ...             _ = f.write(text)
    ...     print(merge_fragments(sorted(os.path.join(d, n) for n in os.listdir(d))))
    ### Added
    <BLANKLINE>
    - two
    <BLANKLINE>
    ### Fixed
    <BLANKLINE>
    - one
    <BLANKLINE>
    """
    order = ["Added", "Changed", "Deprecated", "Removed", "Fixed", "Security"]
    sections = {}
    for path in paths:
        current = "Changed"
        with open(path, encoding="utf-8") as f:
            for line in f.read().splitlines():
                if line.startswith("#"):
                    current = line.lstrip("#").strip()
                    continue
                if line.strip():
                    sections.setdefault(current, []).append(line)
    names = [n for n in order if n in sections] + [n for n in sections if n not in order]
    return "".join(f"### {n}\n\n" + "\n".join(sections[n]) + "\n\n" for n in names).rstrip() + (
        "\n" if names else ""
    )


def write_unreleased(dest=UNRELEASED):
    """Write the merged fragments of ``docs/changes/*.md`` for the changelog page."""
    paths = sorted(
        os.path.join(HERE, "changes", n)
        for n in os.listdir(os.path.join(HERE, "changes"))
        if n.endswith(".md")
    )
    text = merge_fragments(paths) or "Nothing yet.\n"
    os.makedirs(os.path.dirname(dest), exist_ok=True)
    old = open(dest, encoding="utf-8").read() if os.path.exists(dest) else None
    if old != text:
        with open(dest, "w", encoding="utf-8") as f:
            f.write(text)
