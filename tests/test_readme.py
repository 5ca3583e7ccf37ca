"""The README's quick start stays true: two commands, the second one is what CI runs."""

import os
import re

from helpers import ROOT


def quick_start_commands():
    text = open(os.path.join(ROOT, "README.md"), encoding="utf-8").read()
    section = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```bash\n(.+?)\n```", section)


def test_quick_start_has_two_commands():
    cmds = quick_start_commands()
    assert len(cmds) == 2, cmds
    assert cmds[0].startswith("pip install -e . && bodyvib ")


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
