"""SIGTERM, SIGHUP and a terminal's Ctrl-C at random moments of real commands.

Each command runs as a user's shell starts it (its own process group), with its own
empty temporary folder (``TMPDIR``). It is sent, after a random delay counted from the
moment its signal handlers are in place (SIGTERM caught, read from ``/proc/PID/status``;
the first ~0.1 s of Python's own start-up is not covered), once or, in a quarter of the
runs, twice 20 ms apart:

- SIGTERM to the process alone, as ``kill PID``, ``timeout`` and job schedulers send it
  (20 runs; the compiler of ``build --native`` gets nothing, so it must be killed by the
  command itself);
- SIGINT to the whole process group, as a terminal's Ctrl-C (20 runs);
- SIGHUP to the group, as a closing terminal (4 runs).

Each run must end with its status (143, 130, 129; or 0 when the signal came after the
work) and that signal's single line last on stderr, within the time limit (no hang),
without a traceback, with its outputs all new or all old, no ``.tmp-*`` file beside
them, an empty temporary folder (no ``bodyvib-fmu*``, ``bodyvib_native_*``, extracted
FMU or staged file left), and no process left that names that folder on its command
line (an orphan compiler or pythonfmu build).
"""

import json
import os
import random
import shutil
import signal
import subprocess
import time

import pytest
from helpers import check_stopped_run, start_cli, write_old_outputs

pytestmark = pytest.mark.integration

LINES = {
    signal.SIGTERM: "terminated (SIGTERM)",
    signal.SIGINT: "interrupted",
    signal.SIGHUP: "hung up (SIGHUP)",
}


def _commands(tmp):
    """(name, argv, outputs, a rough run time in s) of each command tried."""
    cfg = tmp / "cfg.json"
    cfg.write_text(
        json.dumps({"ga": {"population": 30, "generations": 40}, "restarts": {"model": 1}})
    )
    c = [tmp / n for n in ("c.json", "c.csv", "c.png")]
    n = [
        tmp / "dist" / "native" / "HumanBody3DOF.fmu",
        tmp / "dist" / "native" / "fmi3" / "HumanBody3DOF.fmu",
    ]
    return [
        (
            "cosim",
            [
                "cosim",
                "--duration",
                "2",
                "--quiet",
                "--json",
                str(c[0]),
                "--csv",
                str(c[1]),
                "--plot",
                str(c[2]),
            ],
            c,
            6.0,
        ),
        (
            "fit",
            ["fit", "--quiet", "--config", str(cfg), "--out", str(tmp / "p.json")],
            [tmp / "p.json"],
            3.0,
        ),
        (
            "build --native",
            ["build", "--native", "--fmus", "HumanBody3DOF", "--dest", str(tmp / "dist")],
            n,
            8.0,
        ),
    ]


def _naming(text):
    """Pids of live processes whose command line contains ``text``."""
    out = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                if text.encode() in f.read():
                    out.append(int(pid))
        except OSError:
            pass
    return out


def _duration(argv, cwd, tmpdir):
    """Seconds a command runs on this machine now, from its handlers in place to its end."""
    proc = start_cli(argv, cwd, tmpdir)
    t0 = time.monotonic()
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    return time.monotonic() - t0


def _run(argv, signum, to_group, delay, twice, cwd, tmpdir):
    proc = start_cli(argv, cwd, tmpdir)
    time.sleep(delay)
    for _ in range(2 if twice else 1):
        try:
            (os.killpg if to_group else os.kill)(proc.pid, signum)
        except ProcessLookupError:  # already finished
            break
        time.sleep(0.02)
    try:
        out, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"{argv} hung after {signal.Signals(signum).name}:\n{err}")
    return proc.returncode, out, err


def test_signals_at_random_moments_leave_nothing_behind(tmp_path):
    rng = random.Random(20261201)
    (tmp_path / "dist").mkdir()
    commands = _commands(tmp_path)
    plan = (
        [(signal.SIGTERM, False)] * 20 + [(signal.SIGINT, True)] * 20 + [(signal.SIGHUP, True)] * 4
    )
    trials = [
        (commands[i % len(commands)], signum, group) for i, (signum, group) in enumerate(plan)
    ]
    rng.shuffle(trials)
    # the signals fall within each command's run as this machine runs it now: measured once,
    # undisturbed (so most runs are stopped by their signal, on a fast machine or a loaded one)
    longest = {}
    for name, argv, _outputs, _ in commands:
        tmpdir = tmp_path / f"tmp-{name.split()[0]}"
        tmpdir.mkdir()
        longest[name] = 0.8 * _duration(argv, tmp_path, tmpdir)
        shutil.rmtree(tmpdir)
    stopped = {s: 0 for s in LINES}
    for k, ((name, argv, outputs, _), signum, group) in enumerate(trials):
        write_old_outputs(outputs)
        tmpdir = tmp_path / f"tmp{k}"
        tmpdir.mkdir()
        delay, twice = rng.uniform(0.0, longest[name]), rng.random() < 0.25
        rc, out, err = _run(argv, signum, group, delay, twice, tmp_path, tmpdir)
        what = (
            f"{name}: {signal.Signals(signum).name} to the "
            f"{'group' if group else 'process'} after {delay:.2f} s"
            f"{' twice' if twice else ''}: rc {rc}\n{err}"
        )
        stopped[signum] += check_stopped_run(rc, err, outputs, 128 + signum, LINES[signum], what)
        t_end = time.monotonic() + 5  # a killed compiler's children are reaped by init
        while _naming(str(tmpdir)) and time.monotonic() < t_end:
            time.sleep(0.05)
        assert not _naming(str(tmpdir)), (what, "orphan processes", _naming(str(tmpdir)))
        left = os.listdir(tmpdir)
        assert not left, (what, left)
        tmpdir.rmdir()
    # most runs are stopped by their signal (not finished before it)
    assert stopped[signal.SIGTERM] >= 10 and stopped[signal.SIGINT] >= 10, stopped
