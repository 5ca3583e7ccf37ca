"""Every long loop of a command answers SIGINT and SIGTERM within a second or two.

Each command runs as a user's shell starts it, with its own empty temporary folder
(``TMPDIR``) and its outputs in a folder that does not exist yet. Once its work is under
way (the line it prints when its main loop starts, or a moment well inside a run that
lasts a minute or more here) it is sent SIGINT or SIGTERM (what ``timeout`` and ``kill``
send) and must be gone within :data:`BOUND_S`, with that signal's status and line, no
traceback, nothing left in its temporary folder and its output folder never made (the
co-simulation streams its CSV into a ``.tmp-*`` file there, removed with the folder).

The bound, 2 s: one second, the longest a loop may run between two safe points
(:func:`bodyvib.process.interrupts.check`; they come every ~0.1 s or less of wall time on
a loaded two-core machine: a macro-step of the co-simulation, 4096 steps of an exact run,
a piece of a road or of a spectrum, 16384 lines of a CSV file; opening a pythonfmu FMU,
~0.25 s, is not cut short), plus one second for the teardown (temporary files removed,
FMUs freed, the interpreter's exit: 0.05-0.3 s measured). Measured from the signal to the
process's end: 0.05-0.5 s. Before, the signal waited for the end of a whole phase: 48 s
(the rear wheel's road of a half car, summed point by point), 35-49 s (``control``: the
road, each law's run and its Wk weighting in one go each).
"""

import json
import os
import signal
import threading
import time

import numpy as np
import pytest
from helpers import ROOT, start_cli

pytestmark = pytest.mark.integration

#: Seconds from the signal to the process's end.
BOUND_S = 2.0

LINES = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated (SIGTERM)"}

#: The monolithic reference of a long run in one call, as a command runs it: inside
#: ``deferred``, its status the signal's.
REFERENCE = """
import sys
import numpy as np
from bodyvib.models import load_model
from bodyvib.process import interrupts
from bodyvib.vehicle.quarter_car import load_car
from bodyvib.vehicle.reference import reference_run

with interrupts.deferred(exiting=True):
    try:
        n = 2_000_001
        z = 0.01 * np.sin(np.arange(n) * 1e-3)
        print("reference", file=sys.stderr, flush=True)
        reference_run(load_car(), load_model("reduced-paper"), z, np.zeros(n), 1e-3)
    except KeyboardInterrupt:
        print(interrupts.message(), file=sys.stderr)
        sys.exit(interrupts.exit_status())
"""


def _stop(argv, tmp, signum, delay, ready=None, program=None):
    """Run a command, send ``signum`` ``delay`` s after ``ready`` appears on stderr (or after
    its handlers are in place); ``(status, stderr, seconds from the signal to its end)``."""
    tmpdir = tmp / f"tmp-{signal.Signals(signum).name}-{argv[0]}"
    tmpdir.mkdir()
    proc = start_cli(argv, tmp, tmpdir, program)
    err = []
    reader = threading.Thread(target=lambda: err.extend(proc.stderr), daemon=True)
    reader.start()
    t_end = time.monotonic() + 300
    while ready and not any(ready in line for line in err) and time.monotonic() < t_end:
        assert proc.poll() is None, "".join(err)
        time.sleep(0.01)
    time.sleep(delay)
    assert proc.poll() is None, f"{argv[0]} ended before the signal:\n{''.join(err)}"
    t0 = time.monotonic()
    os.kill(proc.pid, signum)
    try:
        proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    elapsed = time.monotonic() - t0
    reader.join(10)
    proc.stdout.close()
    left = os.listdir(tmpdir)
    assert not left, (argv[0], left)
    return proc.returncode, "".join(err), elapsed


def _check(argv, tmp, signum, delay, ready=None, program=None):
    """A run stopped by ``signum`` within the bound, its outputs' folder never made."""
    rc, err, elapsed = _stop(argv, tmp, signum, delay, ready, program)
    what = (
        f"{argv[0]}, {signal.Signals(signum).name} after {delay} s: rc {rc}, {elapsed:.2f} s\n{err}"
    )
    assert rc == 128 + signum, what
    assert err.strip().splitlines()[-1] == LINES[signum], what
    assert "Traceback" not in err, what
    assert elapsed < BOUND_S, what
    assert not (tmp / "out").exists(), (what, list((tmp / "out").iterdir()))
    print(what.splitlines()[0])  # the time measured, shown with pytest -s


@pytest.mark.parametrize(("signum", "delay"), [(signal.SIGINT, 1.0), (signal.SIGTERM, 3.0)])
def test_half_car_cosim_stops_within_bound(tmp_path, signum, delay):
    # the signal at the start of the master loop (the first block's road: the rear wheel
    # on level ground, then on the road) and later in it
    out = [str(tmp_path / "out" / f) for f in ("c.json", "c.csv", "c.png")]
    argv = ["cosim", "--car", "half-car", "--duration", "2000"]
    argv += ["--json", out[0], "--csv", out[1], "--plot", out[2]]
    _check(argv, tmp_path, signum, delay, ready="co-simulating")


@pytest.mark.parametrize(("signum", "delay"), [(signal.SIGINT, 3.0), (signal.SIGTERM, 20.0)])
def test_control_over_3000_s_stops_within_bound(tmp_path, signum, delay):
    # about 90 s here: the road (~10 s), then each law's exact run and its weighting
    out = [str(tmp_path / "out" / f) for f in ("l.json", "l.png")]
    argv = ["control", "--duration", "3000", "--json", out[0], "--plot", out[1]]
    _check(argv, tmp_path, signum, delay)


@pytest.mark.parametrize(
    ("signum", "search", "delay"),
    [
        (signal.SIGINT, {"population": 100, "generations": 100}, 3.0),  # the search
        (signal.SIGTERM, {"population": 8, "generations": 2}, 10.0),  # the verification
    ],
)
def test_design_stops_within_bound(tmp_path, signum, search, delay):
    with open(os.path.join(ROOT, "examples", "design", "quarter-car-class-c.json")) as f:
        spec = json.load(f)
    spec["search"] = dict(spec["search"], **search)
    spec["verify"] = {"duration": 2000, "step": 0.001, "seed": 0}
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec))
    _check(["design", str(path), "--out", str(tmp_path / "out")], tmp_path, signum, delay)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_reference_in_one_call_stops_within_bound(tmp_path, signum):
    program = tmp_path / "reference.py"
    program.write_text(REFERENCE)
    _check(["reference"], tmp_path, signum, 1.0, ready="reference", program=str(program))


def test_respond_to_a_long_record_stops_within_bound(tmp_path):
    # 1e6 samples: reading the file (~4 s here), then the weightings and the bodies' runs
    n = 1_000_001
    a = np.random.default_rng(0).standard_normal(n)
    data = np.column_stack([np.arange(n) * 1e-3, a])
    np.savetxt(tmp_path / "seat.csv", data, delimiter=",", header="time,acceleration", comments="")
    for signum, delay in ((signal.SIGTERM, 1.0), (signal.SIGINT, 8.0)):
        out = [str(tmp_path / "out" / f) for f in ("r.json", "r.csv")]
        argv = ["respond", str(tmp_path / "seat.csv"), "--json", out[0], "--csv", out[1]]
        _check(argv, tmp_path, signum, delay)
