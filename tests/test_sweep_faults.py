"""Sweeps when things go wrong: a real Dask cluster failing, Ctrl-C from a terminal, outputs.

The cluster faults run against real ``dask scheduler`` and ``dask worker``
processes started here on 127.0.0.1 (ports chosen by the scheduler); Ctrl-C is
sent as a terminal sends it, to the whole process group of the command.
"""

import functools
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest
from test_sweep_run import FAILING_SPEC, GROUPING_RTOL

from bodyvib.vehicle.sweep.run import parts_dir, read_results, run_sweep

pytestmark = pytest.mark.integration

SPEC = {
    "road": ["C", "D"],
    "speed": [10, 15, 20, 25, 30],
    "seed": [0, 1, 2, 3],
    "duration": 4,
    "body": "reduced-paper",
}  # 40 cases
ENV = {
    **os.environ,
    "PYTHONPATH": os.pathsep.join(
        [os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
        + ([os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else [])
    ),
}


def _start(args, env=ENV, **kw):
    return subprocess.Popen(args, env=env, start_new_session=True, **kw)


def _kill(proc):
    if proc.poll() is None:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    proc.wait()


class Cluster:
    """A real ``dask scheduler`` (and ``dask worker`` processes), each in its own session."""

    def __init__(self, folder, workers):
        self.folder = folder
        self.procs = []
        sf = os.path.join(folder, f"scheduler-{time.time_ns()}.json")
        env = {**ENV, "DASK_TEMPORARY_DIRECTORY": folder}  # their scratch space: not in /tmp
        self.scheduler = _start(
            [sys.executable, "-m", *"dask scheduler --host 127.0.0.1 --port 0".split()]
            + ["--no-dashboard", "--scheduler-file", sf],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        self.procs.append(self.scheduler)
        t0 = time.time()
        while not os.path.exists(sf):
            assert time.time() - t0 < 60, "the scheduler did not start"
            time.sleep(0.1)
        time.sleep(0.2)
        self.file = sf
        self.address = json.load(open(sf))["address"]
        for _i in range(workers):
            self.procs.append(
                _start(
                    [sys.executable, "-m", "dask", "worker", self.address, "--nthreads", "1"]
                    + ["--no-dashboard", "--local-directory"]
                    + [os.path.join(folder, f"w{len(self.procs)}")],
                    env=env,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                )
            )

    def close(self):
        for p in self.procs:
            _kill(p)


@pytest.fixture
def clusters(tmp_path):
    made = []

    def make(workers=1):
        c = Cluster(str(tmp_path), workers)
        made.append(c)
        return c

    yield make
    for c in made:
        c.close()


def _cli(*args):
    return _start(
        [sys.executable, "-m", "bodyvib.cli", "sweep", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _parts(out):
    folder = parts_dir(out)
    return (
        [f for f in os.listdir(folder) if f.endswith(".parquet") and not f.startswith(".")]
        if os.path.isdir(folder)
        else []
    )


def _wait_parts(out, proc, count, timeout=180):
    t0 = time.time()
    while len(_parts(out)) < count:
        assert proc.poll() is None, f"the sweep ended first: {proc.communicate()}"
        assert time.time() - t0 < timeout, "no parts in time"
        time.sleep(0.05)


def _clean(stderr):
    for bad in ("Traceback", "Nanny", "KeyboardInterrupt", "distributed.", "Exception"):
        assert bad not in stderr, stderr


def test_killed_scheduler_leaves_the_lost_cases_to_resume(tmp_path, clusters):
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps(SPEC))
    out = str(tmp_path / "r.parquet")
    c = clusters(1)
    proc = _cli(str(spec), "--out", out, "--scheduler", c.address, "--block", "1", "--quiet")
    _wait_parts(out, proc, 3)
    os.killpg(c.scheduler.pid, signal.SIGKILL)  # kill -9 of the scheduler, midway
    t_kill = time.time()
    _, err = proc.communicate(timeout=60)
    waited = time.time() - t_kill
    c.close()
    assert proc.returncode == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "lost" in lines[0] and "--resume" in lines[0], err
    _clean(err)
    assert waited < 30
    kept = read_results(out)
    assert 3 <= len(kept) < 40, "the scheduler was not killed midway"
    assert kept["error"].isna().all()  # no lost case is written as failed
    assert not os.path.exists(out)
    # a new cluster: --resume runs exactly the cases not kept
    c2 = clusters(1)
    proc = _cli(str(spec), "--out", out, "--resume", "--scheduler-file", c2.file, "--block", "1")
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert f"{len(kept)} already done, {40 - len(kept)} to run" in err
    df = pd.read_parquet(out)
    assert list(df["case_id"]) == list(range(40)) and df["error"].isna().all()
    assert df["run_id"].nunique() == 2
    # the same figures as the whole sweep run in one task in this process
    serial = run_sweep(SPEC, scheduler="serial")
    for f in ("head_weighted_rms", "head_vdv", "head_peak", "seat_weighted_rms"):
        np.testing.assert_allclose(df[f], serial[f], rtol=GROUPING_RTOL, atol=0)


def test_no_worker_is_a_message_in_the_stated_time_and_ctrl_c_works(tmp_path, clusters):
    out = str(tmp_path / "r.parquet")
    c = clusters(0)
    grid = ["--grid", "road=C", "speed=10,20", "body=reduced-paper", "--duration", "2"]
    t0 = time.time()
    proc = _cli(*grid, "--out", out, "--scheduler", c.address, "--worker-timeout", "3")
    _, err = proc.communicate(timeout=60)
    took = time.time() - t0
    assert proc.returncode == 2 and "no worker after 3 s" in err, err
    assert err.strip().splitlines()[-1].startswith("bodyvib sweep: error:")
    _clean(err)
    assert 3 <= took < 20
    assert not os.path.exists(out) and not os.path.exists(parts_dir(out))
    # Ctrl-C while it waits: taken the first time
    proc = _cli(*grid, "--out", out, "--scheduler", c.address, "--worker-timeout", "600")
    time.sleep(6)
    os.killpg(proc.pid, signal.SIGINT)
    t_int = time.time()
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and err.strip().splitlines()[-1] == "interrupted", err
    assert time.time() - t_int < 3
    _clean(err)
    assert not os.path.exists(out) and not os.path.exists(parts_dir(out))


def test_bad_or_unreachable_scheduler_is_one_line(tmp_path):
    grid = [
        "--grid",
        "road=C",
        "speed=10",
        "body=reduced-paper",
        "--duration",
        "1",
        "--out",
        str(tmp_path / "r.parquet"),
    ]
    proc = _cli(*grid, "--scheduler", "127.0.0.1:8786")
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2 and "write it as tcp://127.0.0.1:8786" in err, err
    assert len(err.strip().splitlines()) == 1
    t0 = time.time()
    proc = _cli(*grid, "--scheduler", "tcp://127.0.0.1:9", "--connect-timeout", "2", "--quiet")
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2 and "within 2 s (--connect-timeout)" in err, err
    assert len(err.strip().splitlines()) == 1 and time.time() - t0 < 15
    assert not os.listdir(tmp_path)


def test_ctrl_c_from_a_terminal_on_a_local_cluster(tmp_path):
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps(SPEC))
    out = str(tmp_path / "r.parquet")
    # a previous table at --out: an interrupted --overwrite leaves it as it was
    before = run_sweep({**SPEC, "speed": 10}, out=out, scheduler="serial", table=False)
    old = open(out, "rb").read()
    proc = _cli(str(spec), "--out", out, "--overwrite", "--block", "1", "--workers", "2")
    _wait_parts(out, proc, 2)
    os.killpg(proc.pid, signal.SIGINT)  # as a terminal: the whole process group
    time.sleep(0.3)
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)  # and a second Ctrl-C
    t_int = time.time()
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1] == "interrupted"
    _clean(err)
    assert time.time() - t_int < 10
    assert open(out, "rb").read() == old  # never a 0-row (or partial) table over it
    assert before is None
    kept = _parts(out)
    assert len(kept) >= 2
    assert not [f for f in os.listdir(tmp_path) if f.startswith(".tmp-")]


def test_outputs_are_checked_before_the_work(tmp_path, capsys):
    from bodyvib.cli.main import main

    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({**SPEC, "speed": 10}))
    text = spec.read_text()
    for args in (
        ["--out", str(spec), "--overwrite"],
        ["--csv", str(spec)],
        ["--out", str(tmp_path / "x.parquet"), "--csv", str(tmp_path / "x.parquet")],
    ):
        assert main(["sweep", str(spec), "--scheduler", "serial", "--quiet", *args]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and ("input" in err[0] or "same file" in err[0]), err
        assert spec.read_text() == text
        assert not os.path.exists(tmp_path / "x.parquet")
    # a device is refused before the sweep runs (no OUT.parts left); --out must end in
    # .parquet, so the device is reached through a link that does
    os.symlink("/dev/full", tmp_path / "full.parquet")
    t0 = time.time()
    serial = ["sweep", str(spec), "--scheduler", "serial", "--quiet", "--out"]
    assert main([*serial, str(tmp_path / "full.parquet"), "--overwrite"]) == 2
    assert "character device" in capsys.readouterr().err and time.time() - t0 < 10
    assert not os.path.exists("/dev/full.parts")
    # --csv on a device: refused before the work, the previous --out untouched
    out = tmp_path / "a.parquet"
    assert main([*serial, str(out)]) == 0
    old = out.read_bytes()
    capsys.readouterr()
    assert main([*serial, str(out), "--overwrite", "--csv", "/dev/full"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--csv '/dev/full' is a character device" in err[0], err
    assert out.read_bytes() == old and not os.path.exists(parts_dir(str(out)))


def test_all_outputs_or_none_on_a_full_disk(tmp_path):
    full = tmp_path / "full"
    full.mkdir()
    if subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=32k", "tmpfs", str(full)], capture_output=True
    ).returncode:
        pytest.skip("cannot mount a small tmpfs here")
    try:
        out = str(tmp_path / "a.parquet")
        spec = {
            "road": ["C", "D"],
            "speed": list(range(5, 35)),
            "seed": [0, 1, 2, 3, 4],
            "body": "reduced-paper",
        }  # 300 cases: a CSV of about 100 kB
        sweep = functools.partial(run_sweep, out=out, engine="spectral", scheduler="serial")
        sweep({**spec, "speed": 10})
        old = open(out, "rb").read()
        from bodyvib.runtime.errors import BodyvibError

        with pytest.raises(BodyvibError, match="No space left") as e:
            sweep(spec, csv=str(full / "a.csv"), overwrite=True)
        assert "resume=True" in str(e.value)
        assert open(out, "rb").read() == old and not os.listdir(full)
        # the finished cases are kept: --resume writes both once there is room
        df = sweep(spec, csv=str(tmp_path / "a.csv"), resume=True)
        assert len(df) == 300 and len(pd.read_csv(tmp_path / "a.csv")) == 300
    finally:
        subprocess.run(["umount", str(full)], check=True)


def test_failed_cases_are_recorded_and_retried_on_request(tmp_path):
    spec = FAILING_SPEC
    out = str(tmp_path / "r.parquet")
    first = run_sweep(spec, out=out, scheduler="serial")
    assert first["error"].notna().sum() == 2
    said = []
    again = run_sweep(spec, out=out, scheduler="serial", resume=True, progress=said.append)
    assert "4 already done, 0 to run" in said[0]
    pd.testing.assert_frame_equal(again, first)
    said.clear()
    retried = run_sweep(
        spec, out=out, scheduler="serial", resume=True, retry_failed=True, progress=said.append
    )
    assert "2 already done, 2 to run" in said[0]
    bad = retried["error"].notna()
    assert bad.sum() == 2 and (retried.loc[bad, "run_id"] != first.loc[bad, "run_id"]).all()
    pd.testing.assert_frame_equal(retried[~bad], first[~bad])
