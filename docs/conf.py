"""Sphinx configuration of the bodyvib documentation site.

Build it with warnings as errors and every cross-reference checked::

    python -m sphinx -W --keep-going -n -b html docs docs/_build/html

The API reference is written at build time from each public package's ``__all__``
(``write_api_pages`` in ``docs/_ext/sitegen.py``), so a name added to a package's ``__all__`` appears in the
reference without editing these pages.
"""

import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "_ext"))

from sitegen import resolve_in_defining_module, write_api_pages, write_unreleased  # noqa: E402

import bodyvib  # noqa: E402

project = "bodyvib"
author = "the bodyvib developers"
copyright = "2025-2026, the bodyvib developers"
release = bodyvib.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinxarg.ext",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
templates_path = ["_templates"]
exclude_patterns = [
    "_build",
    "_generated",
    "changes",
    "gallery/README.txt",
    "auto_examples/*.ipynb",
    "auto_examples/*.py",
    "Thumbs.db",
    ".DS_Store",
]
# Options are written as typed ("--params", not an en dash).
smartquotes = False
# Furo: a maintained theme whose sidebar holds the whole table of contents (short page
# titles keep it readable), with search, light and dark modes and a narrow-screen layout.
html_theme = "furo"
html_title = f"bodyvib {release}"
html_short_title = "bodyvib"
html_theme_options = {"navigation_with_keys": True}

# Every cross-reference must resolve; there is no network (no intersphinx), so names
# of other projects (numpy, scipy, the standard library) are not looked up.
nitpicky = True
nitpick_ignore_regex = [
    (
        r"py:.*",
        r"(numpy|np|scipy|pandas|pd|matplotlib|plt|fmpy|dask|distributed|pyarrow"
        r"|asammdf|control|ct|deap|cma|pymoo|numba|tqdm|threading|typing|collections"
        r"|pathlib|os|io|argparse|subprocess|signal|concurrent|contextlib|json|enum"
        r"|dataclasses|abc|types|tempfile|shutil|sys|time|errno|stat|multiprocessing|math|random"
        r"|functools|itertools|warnings|atexit|ctypes|weakref|hashlib|struct|zipfile|xml"
        r"|tomllib|importlib|inspect|logging|platform|shlex|tarfile|uuid|datetime|re|queue"
        r"|socket|resource|gc|mmap|fcntl|select|selectors|textwrap|string|csv)(\..*)?",
    ),
    (
        r"py:class",
        r"(int|float|str|bytes|bool|dict|list|tuple|object|callable|None"
        r"|Exception|ValueError|RuntimeError|BaseException|OSError|ImportError|type|Ellipsis)",
    ),
]

autosummary_generate = True
autosummary_imported_members = True
autodoc_typehints = "none"
autodoc_default_options = {"member-order": "bysource"}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = True
numpydoc_xref_param_type = False

myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 4

sphinx_gallery_conf = {
    "examples_dirs": ["gallery"],
    "gallery_dirs": ["auto_examples"],
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "within_subsection_order": "FileNameSortKey",
}

os.environ.setdefault("MPLBACKEND", "Agg")


def setup(app):
    app.connect("missing-reference", resolve_in_defining_module)


write_api_pages()
write_unreleased()
