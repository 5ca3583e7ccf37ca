"""Ctrl-C at random moments of real runs of real FMUs.

Every command is started as a user's shell starts it (its own process group) and sent
SIGINT to the whole group, as a terminal's Ctrl-C does (pythonfmu's build process gets it
too), after a random delay. Each run must end with status 130 and the last line of stderr
``interrupted`` (or, if the signal came after the work was done, status 0), never with a
signal (segfault, abort), a traceback or a fatal FMU status, and its outputs must be all
new or all untouched.
"""

import json
import os
import random
import signal
import subprocess
import sys
import time

import pytest
from helpers import check_stopped_run, write_old_outputs

pytestmark = pytest.mark.integration


def _fit_config(folder):
    cfg = {"ga": {"population": 40, "generations": 60}, "restarts": {"model": 2}}
    p = folder / "cfg.json"
    p.write_text(json.dumps(cfg))
    return p


def _commands(fmus, tmp):
    """(name, argv, outputs, typical duration in s) of each command tried."""
    out = {n: tmp / n for n in ("c.json", "c.png", "c.csv", "f.json", "f.png", "p.json", "k.json")}
    body, iso, car = (
        str(fmus / f) for f in ("HumanBody3DOF.fmu", "HumanBodyISO7962.fmu", "QuarterCar.fmu")
    )
    common = [
        "--quiet",
        "--json",
        str(out["c.json"]),
        "--plot",
        str(out["c.png"]),
        "--csv",
        str(out["c.csv"]),
    ]
    return [
        (
            "cosim",
            ["cosim", "--duration", "40", "--body", body, "--car-fmu", car] + common,
            [out["c.json"], out["c.png"], out["c.csv"]],
            3.0,
        ),
        (
            "check",
            ["check", "--duration", "20", "--body", body, "--iso-body", iso, "--car-fmu", car]
            + common,
            [out["c.json"], out["c.png"], out["c.csv"]],
            3.0,
        ),
        (
            "cosim+build",
            ["cosim", "--duration", "10"] + common,
            [out["c.json"], out["c.png"], out["c.csv"]],
            4.0,
        ),
        (
            "frf",
            [
                "frf",
                "--points",
                "300000",
                "--json",
                str(out["f.json"]),
                "--plot",
                str(out["f.png"]),
            ],
            [out["f.json"], out["f.png"]],
            6.0,
        ),
        (
            "fit",
            [
                "fit",
                "--quiet",
                "--config",
                str(_fit_config(tmp)),
                "--out",
                str(out["p.json"]),
                "--report",
                str(tmp / "report"),
            ],
            [out["p.json"], tmp / "report" / "comparison.json"],
            5.0,
        ),
        (
            "build",
            ["build", "--dest", str(tmp / "dist")],
            [
                tmp / "dist" / f"{n}.fmu"
                for n in ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar")
            ],
            4.0,
        ),
    ]


def _interrupt(argv, delay, cwd, twice=False):
    proc = subprocess.Popen(
        [sys.executable, "-m", "bodyvib.cli", *argv],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    time.sleep(delay)
    for _i in range(2 if twice else 1):
        try:
            os.killpg(proc.pid, signal.SIGINT)
        except ProcessLookupError:  # already finished
            break
        time.sleep(0.01)
    out, err = proc.communicate(timeout=120)
    return proc.returncode, out, err


def test_ctrl_c_at_random_points_never_crashes_and_keeps_outputs_all_or_none(
    python_fmu_dir, tmp_path
):
    rng = random.Random(20261201)
    tmp_path.joinpath("report").mkdir()
    tmp_path.joinpath("dist").mkdir()
    commands = _commands(python_fmu_dir, tmp_path)
    tried, interrupted, t_end = 0, 0, time.monotonic() + 420  # bounded time
    trials = [c for c in commands for _ in range(4)]
    rng.shuffle(trials)
    for name, argv, outputs, typical in trials:
        if time.monotonic() > t_end:
            break
        write_old_outputs(outputs)
        delay = rng.uniform(0.3, typical)
        twice = rng.random() < 0.25
        rc, out, err = _interrupt(argv, delay, tmp_path, twice)
        tried += 1
        what = f"{name} interrupted after {delay:.2f} s{' twice' if twice else ''}: rc {rc}\n{err}"
        interrupted += check_stopped_run(rc, err, outputs, 130, "interrupted", what)
    assert tried >= 20 and interrupted >= tried // 2, (tried, interrupted)
