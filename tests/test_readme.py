"""The README stays short and true: two quick-start commands (the second is what CI runs),
at most 200 lines, and links that lead somewhere."""

import os
import re

import pytest
from helpers import ROOT, run_cli


def readme():
    return open(os.path.join(ROOT, "README.md"), encoding="utf-8").read()


def quick_start_commands():
    section = readme().split("## Quick start", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```bash\n(.+?)\n```", section)


def test_quick_start_has_two_commands():
    cmds = quick_start_commands()
    assert len(cmds) == 2, cmds
    assert cmds[0] == "pip install -e . && bodyvib check --plot check.png --json check.json"
    assert cmds[1] == 'pip install -e ".[test]" && python -m pytest'


def test_ci_runs_the_readme_test_command():
    """CI installs what the README's test command installs (and the dev extra's checkers),
    then runs the same pytest in its two tiers: the fast one first, the integration one last."""
    ci = open(os.path.join(ROOT, ".ci", "run"), encoding="utf-8").read()
    install, run = quick_start_commands()[1].split(" && ")
    assert install == 'pip install -e ".[test]"'
    assert 'pip install -q -e ".[test,dev]"' in ci
    fast, rest = f'{run} -m "not integration"', f"{run} -m integration"
    assert fast in ci and rest in ci and ci.index(fast) < ci.index(rest)
    assert ci.rstrip().endswith(rest)  # its summary closes the log


def test_readme_is_short():
    assert len(readme().splitlines()) <= 200


def test_readme_links_resolve():
    """Every relative link names a file of the tree; the documentation pages it links to
    are the site's sources."""
    links = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", readme())
    local = [link for link in links if "://" not in link]
    assert any(link.startswith("docs/") for link in local), local
    missing = [link for link in local if not os.path.exists(os.path.join(ROOT, link))]
    assert not missing, missing


def test_quick_start_output_is_what_check_prints():
    """The figures the README quotes are those of the getting-started page, which shows
    the output of `bodyvib check` on defaults in full."""
    page = open(os.path.join(ROOT, "docs", "getting_started.md"), encoding="utf-8").read()
    shown = re.search(r"## Quick start.*?```text\n(.*?)```", page, re.S).group(1)
    quoted = re.search(r"## Quick start.*?```\n(head acceleration.*?)```", readme(), re.S).group(1)
    lines = [ln for ln in quoted.splitlines() if ln.strip() and ln.strip() != "..."]
    assert lines and all(ln in shown.splitlines() for ln in lines), lines


def test_measured_road_figures_are_the_road_guides():
    """The figures the README quotes for its measured-road example are those of the road
    guide's worked example, whose figures a test (test_measured_roads.py) reruns."""
    section = readme().split("**Drive a measured road**", 1)[1].split("**Drop the FMU", 1)[0]
    guide = open(os.path.join(ROOT, "docs", "guide", "roads.md"), encoding="utf-8").read()
    example = guide.split("## Worked example", 1)[1]
    quoted = re.findall(r"(\d+\.\d{4}) m/s", section)
    assert quoted, section
    assert all(q in example for q in quoted), (quoted, "not in the guide's worked example")


@pytest.mark.integration
def test_readme_seat_and_control_figures_are_what_the_commands_print():
    """The seat's resonance and SEAT value, and the control table, as `bodyvib frf --seat
    suspension` and `bodyvib control` print them today (the figures are rounded as
    printed, so they match to the printed digit)."""
    text = readme()
    frf = run_cli("frf", "--seat", "suspension")
    assert frf.returncode == 0, frf.stderr
    m = re.search(r"resonates at ([\d.]+) Hz \(\|T\| ([\d.]+) .*?SEAT\nvalue ([\d.]+) %", text)
    assert m, "README: the suspension seat's sentence"
    hz, peak, seat = m.groups()
    assert f"floor to pan: {peak} at {hz} Hz" in frf.stdout
    assert (
        f"suspension in quarter-car with reduced-paper, ISO 8608 road (any class and speed): {seat} %"
        in frf.stdout
    )

    control = run_cli("control")
    assert control.returncode == 0, control.stderr
    printed = {line.split()[0]: line.split() for line in control.stdout.splitlines() if line}
    rows = re.findall(
        r"^\| (passive|skyhook|groundhook) \| ([\d.]+) \| (\d+) \| ([\d.]+) \|$", text, re.M
    )
    assert [r[0] for r in rows] == ["passive", "skyhook", "groundhook"]
    for law, head, tire, travel in rows:
        assert printed[law][3:6] == [head, tire, travel], (law, printed[law])


@pytest.mark.integration
def test_readme_fmpy_snippet_runs_as_written(python_fmus, tmp_path, capfd, monkeypatch):
    """The snippet once used an undefined ``signals`` and left an input out."""
    from test_fmu_integration import check_fmpy_snippet

    section = readme().split("**Drop the FMU into a host**", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    check_fmpy_snippet(code, python_fmus["HumanBody3DOF"], tmp_path, capfd, monkeypatch)


@pytest.mark.integration
def test_readme_car_and_bump_figures_are_what_cosim_prints():
    """The full car's seat axes and the bump's events, forces and VDV, as `bodyvib cosim`
    prints them for the README's two commands (to the printed digit)."""
    section = readme().split("**Cars, bumps and every axis**", 1)[1].split("\n**", 1)[0]
    m = re.search(r"seat a_w y ([\d.]+) beside z ([\d.]+) m/s", section)
    assert m, "README: the full car's seat sentence"
    full = run_cli("cosim", "--car", "full-car", "--duration", "10")
    assert full.returncode == 0, full.stderr
    rows = {ln[:40].strip(): ln.split()[-1] for ln in full.stdout.splitlines() if ln.strip()}
    assert (rows["seat a_w y (Wd) [m/s2]"], rows["seat a_w z (Wk) [m/s2]"]) == m.groups()
    m = re.search(
        r"twice \((\d+) ms in the air\), hits its\nbump stop with (\d+) N and the lumbar spine "
        r"takes ([\d.]+) N; the head's VDV \(([\d.]+)\n",
        section,
    )
    assert m, "README: the bump's sentence"
    air, stop, lumbar, vdv = m.groups()
    bump = run_cli("cosim", "--road", "sine:h=0.08,l=1.0,at=10", "--speed", "20", "--duration", "4")
    assert bump.returncode == 0, bump.stderr
    out = bump.stdout
    assert re.search(rf"lift-offs \(air, longest\)\s+2 \({air} ms, ", out), out
    assert re.search(rf"stop contacts\s+1, largest {stop} N", out), out
    assert re.search(rf"lumbar force peak \[N\]\s+{lumbar} at", out), out
    assert re.search(rf"VDV \[m/s\^1.75\]\s+{vdv}\n", out) and "m/s^1.75 governs" in out, out
