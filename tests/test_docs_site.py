"""The documentation site builds and works in a browser.

The site is built with warnings as errors (or the build CI just made is reused: its stamp
``docs/_build/html/.build-passed``, touched after a build that passed, is newer than every
source), then headless Chromium loads the landing page, an API page and
the search page, and the test reads the DOM after the page's JavaScript ran: the title, a
gallery plot that is in the page and on disk, the API page's entries, search results.
"""

import os
import re
import shutil
import subprocess
import sys

import pytest
from helpers import ROOT

pytestmark = pytest.mark.integration

DOCS = os.path.join(ROOT, "docs")
BUILT = os.path.join(DOCS, "_build", "html")
#: Written by the build itself (not sources): the API pages, the gallery, the changelog's
#: merged fragments, the build's output.
GENERATED = {"_build", "api", "auto_examples", "_generated", "sg_execution_times.rst"}
CHROMIUM = shutil.which("chromium") or (
    "/usr/bin/chromium" if os.path.exists("/usr/bin/chromium") else None
)


def newest_source():
    """The latest modification time among the site's sources (pages, code, changelog, the
    package list)."""
    newest = max(
        os.path.getmtime(os.path.join(ROOT, f))
        for f in ("CHANGELOG.md", "pyproject.toml", "setup.py")
    )
    for top in ("docs", "bodyvib", "vehicle"):
        for folder, dirs, files in os.walk(os.path.join(ROOT, top)):
            if top == "docs" and folder == DOCS:
                dirs[:] = [d for d in dirs if d not in GENERATED]
            dirs[:] = [d for d in dirs if d != "__pycache__"]
            for name in files:
                if name not in GENERATED and name.endswith((".py", ".md", ".rst", ".txt", ".json")):
                    newest = max(newest, os.path.getmtime(os.path.join(folder, name)))
    return newest


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The built site's folder: the existing build when it is up to date, else a new one."""
    stamp = os.path.join(BUILT, ".build-passed")
    if os.path.exists(stamp) and os.path.getmtime(stamp) > newest_source():
        return BUILT
    out = tmp_path_factory.mktemp("site")
    run = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-n", "-q", "-b", "html"]
        + ["-d", str(out / "doctrees"), DOCS, str(out / "html")],
        capture_output=True,
        text=True,
        timeout=1800,
        env={**os.environ, "MPLBACKEND": "Agg"},
    )
    assert run.returncode == 0, run.stderr[-5000:]
    return str(out / "html")


def dom(url, tmp_path, budget_ms=8000):
    """The page's DOM after its scripts ran, as headless Chromium serializes it."""
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (Debian: apt-get install chromium)")
    run = subprocess.run(
        [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic"]
        + ["--no-first-run", "--disable-background-networking", "--disable-component-update"]
        + ["--disable-sync", f"--user-data-dir={tmp_path / 'profile'}"]
        + [f"--virtual-time-budget={budget_ms}", "--dump-dom", url],
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    return run.stdout


def url(site, page):
    return "file://" + os.path.join(site, page)


def test_landing_page_shows_its_title_and_a_gallery_plot(site, tmp_path):
    page = dom(url(site, "index.html"), tmp_path)
    title = re.search(r"<title>(.*?)</title>", page, re.S).group(1)
    assert title.startswith("bodyvib"), title
    images = re.findall(r'<img[^>]*src="([^"]*sphx_glr_plot_transmissibility_001\.png)"', page)
    assert images, "the landing page shows the gallery's transmissibility plot"
    png = os.path.join(site, images[0])
    with open(png, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"  # the plot was rendered, not a placeholder
    assert os.path.getsize(png) > 10_000
    # the theme's sidebar holds the table of contents, by the pages' short titles
    sidebar = re.search(r'<div class="sidebar-tree">(.*?)</div>', page, re.S)
    assert sidebar, "the landing page has the theme's sidebar"
    titles = re.findall(
        r'<li class="toctree-l1[^"]*"><a class="reference internal" href="[^"]+">([^<]+)</a>',
        sidebar.group(1),
    )
    assert {"Getting started", "Seats", "Command line"} <= set(titles), titles
    assert max(len(t) for t in titles) <= 30, titles
    # the navigation leads to pages that exist
    links = set(re.findall(r'<a class="reference internal" href="([^"#]+)', page))
    assert {"getting_started.html", "cli.html", "api/index.html"} <= links, links
    assert all(os.path.exists(os.path.join(site, link)) for link in links), links


def test_an_api_page_lists_the_public_names_of_its_package(site, tmp_path):
    import bodyvib.comfort

    page = dom(url(site, "api/bodyvib.comfort.html"), tmp_path)
    assert "bodyvib.comfort" in re.search(r"<title>(.*?)</title>", page, re.S).group(1)
    listed = set(re.findall(r'href="generated/bodyvib\.comfort\.(\w+)\.html#', page))
    assert listed == set(bodyvib.comfort.__all__), set(bodyvib.comfort.__all__) ^ listed
    entry = os.path.join(site, "api", "generated", "bodyvib.comfort.weighted_rms.html")
    assert "Parameters" in open(entry, encoding="utf-8").read()


def test_search_finds_pages(site, tmp_path):
    page = dom(url(site, "search.html") + "?q=transmissibility", tmp_path)
    block = re.search(r'<ul[^>]*class="search"[^>]*>(.*?)</ul>', page, re.S)
    assert block, "the search script filled in its result list"
    results = re.findall(r'<a href="([^"]+\.html)[^"]*"', block.group(1))
    assert len(results) >= 3, block.group(1)[:3000]
    assert any("getting_started" in r or "models" in r for r in results), results
