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
    ci = open(os.path.join(ROOT, ".ci", "run"), encoding="utf-8").read()
    test_cmd = quick_start_commands()[1]
    assert test_cmd.replace("pip install -e", "pip install -q -e") in ci
