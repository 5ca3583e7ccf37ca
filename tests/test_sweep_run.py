"""Running sweeps: Dask against serial, kill and resume, outputs, the command line."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from bodyvib import __version__
from bodyvib_cli.main import main
from vehicle.sweep.run import BASE_COLUMNS, parts_dir, plan_tasks, read_results, run_sweep
from vehicle.sweep.spec import expand, spec_hash

SMALL = {"road": ["C", "E"], "speed": [10, 25], "seed": [0, 1], "duration": 2,
         "body": ["reduced-paper", "iso7962",
                  {"model": "reduced-paper", "vary": {"k1": [0.8, 1.2]}, "samples": 2,
                   "name": "varied"}],
         "car": ["quarter-car", "quarter-car-cushion"]}


def _figures(df):
    return df.drop(columns=["run_id"]).reset_index(drop=True)


def test_table_columns_provenance_and_files(tmp_path):
    out, csv = tmp_path / "r.parquet", tmp_path / "r.csv"
    df = run_sweep(SMALL, out=str(out), csv=str(csv), scheduler="serial")
    cases = expand(SMALL)
    assert len(df) == len(cases) == 64
    cols = list(BASE_COLUMNS)
    cols.insert(cols.index("car") + 1, "body_k1")
    assert list(df.columns) == cols
    assert list(df["case_id"]) == list(range(64))
    assert set(df["engine"]) == {"batched"} and set(df["bodyvib_version"]) == {__version__}
    assert set(df["spec_hash"]) == {spec_hash(SMALL)} and df["run_id"].nunique() == 1
    assert df["error"].isna().all()
    assert (df["head_weighted_rms"] > 0).all() and (df["seat_weighted_rms"] > 0).all()
    np.testing.assert_allclose(df["head_crest_factor"], df["head_peak"] / df["head_weighted_rms"],
                               rtol=1e-12)
    varied = df[df["body"] == "varied"]
    assert varied["body_k1"].notna().all() and df[df["body"] != "varied"]["body_k1"].isna().all()
    back = pd.read_parquet(out)
    pd.testing.assert_frame_equal(back, df, check_exact=True)
    from_csv = pd.read_csv(csv)
    np.testing.assert_allclose(from_csv["head_vdv"], df["head_vdv"], rtol=1e-12)
    assert not os.path.exists(parts_dir(str(out)))
    # one table with the class ordering physics expects: rougher road, more vibration
    piv = df.groupby(["road"])["head_weighted_rms"].median()
    assert piv["E"] > 3 * piv["C"]


def test_tasks_group_cases_of_one_model_length_and_car():
    cases = expand(SMALL)
    tasks = plan_tasks(cases, "batched", workers=2, block=5)
    assert sorted(c.case_id for t in tasks for c in t) == list(range(64))
    for t in tasks:
        assert len(t) <= 5
        assert len({(c.body_model, c.car, c.duration, c.step) for c in t}) == 1


def test_local_cluster_equals_serial_exactly():
    serial = run_sweep(SMALL, scheduler="serial", block=7, workers=2)
    dask = run_sweep(SMALL, workers=2, block=7)  # a real two-worker LocalCluster
    pd.testing.assert_frame_equal(_figures(dask), _figures(serial), check_exact=True)
    spectral = run_sweep({**SMALL, "duration": 30}, engine="spectral", workers=2, block=16)
    spectral_serial = run_sweep({**SMALL, "duration": 30}, engine="spectral", scheduler="serial",
                                block=16)
    pd.testing.assert_frame_equal(_figures(spectral), _figures(spectral_serial), check_exact=True)


def test_a_failing_case_is_recorded_and_the_sweep_goes_on(tmp_path):
    spec = {"road": "C", "speed": [10, 20], "duration": 1,
            "body": ["reduced-paper", {"model": "reduced-paper", "vary": {"k1": [1e290, 1e290]},
                                       "name": "absurd"}]}
    df = run_sweep(spec, out=str(tmp_path / "r.parquet"), scheduler="serial")
    bad = df[df["body"] == "absurd"]
    assert len(df) == 4 and len(bad) == 2
    assert bad["error"].str.contains("not finite").all() and bad["head_weighted_rms"].isna().all()
    assert df[df["body"] != "absurd"]["error"].isna().all()


def _cli(*args, **kw):
    return subprocess.Popen([sys.executable, "-m", "bodyvib_cli", "sweep", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def _wait_for_parts(out, proc, count, timeout=120):
    t0 = time.time()
    while time.time() - t0 < timeout:
        folder = parts_dir(out)
        if os.path.isdir(folder) and len([f for f in os.listdir(folder)
                                          if f.endswith(".parquet") and not f.startswith(".")]) >= count:
            return
        if proc.poll() is not None:
            raise AssertionError(f"sweep ended before {count} tasks were written: {proc.communicate()}")
        time.sleep(0.02)
    raise AssertionError("no parts written in time")


KILL_SPEC = {"road": ["C", "D", "E"], "speed": [10, 15, 20, 25, 30], "seed": [0, 1], "duration": 8,
             "body": "reduced-paper"}


def test_killed_sweep_resumes_without_running_a_case_twice(tmp_path):
    spec_file = tmp_path / "spec.json"
    spec_file.write_text(json.dumps(KILL_SPEC))
    out = str(tmp_path / "r.parquet")
    proc = _cli(str(spec_file), "--out", out, "--scheduler", "serial", "--block", "1", "--quiet")
    _wait_for_parts(out, proc, 3)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    first = read_results(out)
    assert 3 <= len(first) < 30, "the sweep was not killed midway"
    assert not os.path.exists(out)  # the table itself is only written at the end
    said = []
    df = run_sweep(str(spec_file), out=out, resume=True, scheduler="serial", block=1,
                   echo=said.append)
    assert f"{len(first)} already done, {30 - len(first)} to run" in said[0]
    assert len(df) == 30 and df["case_key"].is_unique and list(df["case_id"]) == list(range(30))
    runs = df["run_id"].value_counts()
    assert runs[first["run_id"].iloc[0]] == len(first) and runs.sum() == 30 and len(runs) == 2
    # what the first run wrote is kept as it was
    kept = df.set_index("case_key").loc[first["case_key"]]
    np.testing.assert_array_equal(kept["head_weighted_rms"], first["head_weighted_rms"])
    # the same tasks give the same bits (other groupings differ by rounding, 1e-15)
    fresh = run_sweep(KILL_SPEC, scheduler="serial", block=1)
    pd.testing.assert_frame_equal(_figures(df), _figures(fresh), check_exact=True)
    other = run_sweep(KILL_SPEC, scheduler="serial")
    np.testing.assert_allclose(other["head_weighted_rms"], df["head_weighted_rms"], rtol=1e-13)
    # resuming a finished sweep runs nothing
    said.clear()
    again = run_sweep(str(spec_file), out=out, resume=True, scheduler="serial", echo=said.append)
    assert "30 already done, 0 to run" in said[0] and len(again) == 30


@pytest.mark.integration
def test_ctrl_c_on_a_local_cluster_ends_cleanly_and_resumes(tmp_path):
    spec_file = tmp_path / "spec.json"
    spec_file.write_text(json.dumps(KILL_SPEC))
    out = str(tmp_path / "r.parquet")
    proc = _cli(str(spec_file), "--out", out, "--block", "1", "--workers", "2")
    _wait_for_parts(out, proc, 2)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert stderr.strip().splitlines()[-1] == "interrupted"
    partial = pd.read_parquet(out)  # what was done is gathered into the table
    assert 2 <= len(partial) < 30
    proc = _cli(str(spec_file), "--out", out, "--resume", "--scheduler", "serial", "--quiet")
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 0, stderr
    df = pd.read_parquet(out)
    assert len(df) == 30 and df["case_key"].is_unique


def _one_line_error(capsys, *argv):
    assert main(["sweep", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bodyvib sweep: error:"), err
    return err[0]


def test_cli_errors_are_one_line_exit_2(tmp_path, capsys):
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"road": "C", "speed": 10, "body": "reduced-paper", "wheels": 4}))
    assert "unknown key(s) wheels" in _one_line_error(capsys, str(spec), "--out", str(tmp_path / "r.parquet"))
    assert "No such file" in _one_line_error(capsys, str(tmp_path / "none.json"), "--out", "r.parquet")
    assert "not both" in _one_line_error(capsys, str(spec), "--grid", "road=C", "--out", "r.parquet")
    assert "SPEC file or --grid" in _one_line_error(capsys, "--out", "r.parquet")
    assert "key=v1,v2" in _one_line_error(capsys, "--grid", "road", "--out", "r.parquet")
    assert "--out" in _one_line_error(capsys, "--grid", "road=C", "speed=10", "body=reduced-paper")
    assert ".png" in _one_line_error(capsys, "--grid", "road=C", "speed=10", "body=reduced-paper",
                                     "--out", str(tmp_path / "r.parquet"), "--plot", "x.gif")
    assert "spectral engine needs" in _one_line_error(
        capsys, "--grid", "road=bump", "speed=10", "body=reduced-paper", "--engine", "spectral",
        "--out", str(tmp_path / "r.parquet"))
    out = tmp_path / "done.parquet"
    grid = ["--grid", "road=C", "speed=10", "body=reduced-paper", "--duration", "1"]
    assert main(["sweep", *grid, "--out", str(out), "--scheduler", "serial", "--quiet"]) == 0
    capsys.readouterr()
    assert "exists; pass --resume" in _one_line_error(capsys, *grid, "--out", str(out))
    assert "another spec" in _one_line_error(capsys, "--grid", "road=D", "speed=10",
                                             "body=reduced-paper", "--duration", "1",
                                             "--out", str(out), "--resume")
    assert "cannot connect" in _one_line_error(capsys, *grid, "--out", str(tmp_path / "x.parquet"),
                                               "--scheduler", "tcp://127.0.0.1:9", "--quiet")


def test_cli_grid_run_and_plot(tmp_path, capsys):
    out, png = tmp_path / "r.parquet", tmp_path / "map.png"
    assert main(["sweep", "--grid", "road=C,D", "speed=10,20", "seed=0,1",
                 "body=reduced-paper,iso7962", "--duration", "2", "--out", str(out),
                 "--plot", str(png), "--scheduler", "serial", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert f"wrote {out}" in text and f"wrote {png}" in text
    assert len(pd.read_parquet(out)) == 16
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    png2 = tmp_path / "again.png"  # a finished table plots without running
    assert main(["sweep", "--out", str(out), "--plot", str(png2)]) == 0
    assert png2.stat().st_size > 10000
