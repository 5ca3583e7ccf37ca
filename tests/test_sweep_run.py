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
from bodyvib.cli.main import main
from bodyvib.models import load_model
from bodyvib.vehicle.quarter_car import load_car
from bodyvib.vehicle.sweep.run import (
    BASE_COLUMNS,
    SweepSettings,
    parts_dir,
    plan_tasks,
    read_results,
    run_sweep,
    task_size,
)
from bodyvib.vehicle.sweep.spec import expand, spec_hash

# Dask clusters, killed and resumed runs and the command line: processes and seconds each
pytestmark = pytest.mark.integration

SMALL = {
    "road": ["C", "E"],
    "speed": [10, 25],
    "seed": [0, 1],
    "duration": 2,
    "body": [
        "reduced-paper",
        "iso7962",
        {"model": "reduced-paper", "vary": {"k1": [0.8, 1.2]}, "samples": 2, "name": "varied"},
    ],
    "car": ["quarter-car", "quarter-car-cushion"],
}


def _figures(df):
    return df.drop(columns=["run_id"]).reset_index(drop=True)


def test_table_columns_provenance_and_files(tmp_path):
    out, csv = tmp_path / "r.parquet", tmp_path / "r.csv"
    df = run_sweep(SMALL, out=str(out), csv=str(csv), scheduler="serial")
    cases = expand(SMALL)
    assert len(df) == len(cases) == 64
    reduced, iso = load_model("reduced-paper"), load_model("iso7962")
    body_params = list(dict.fromkeys([*reduced.parameters, *iso.parameters]))
    car = load_car("quarter-car-cushion")
    cols = list(BASE_COLUMNS)
    at = cols.index("car") + 1
    cols[at:at] = [f"body_{p}" for p in body_params] + [
        # the cars as the cases run them: the quarter car with its stops
        f"car_{p}"
        for p in dict.fromkeys([*load_car("quarter-car").parameters, *car.parameters])
    ]
    assert list(df.columns) == cols
    assert list(df["case_id"]) == list(range(64))
    assert set(df["engine"]) == {"batched"} and set(df["bodyvib_version"]) == {__version__}
    assert set(df["spec_hash"]) == {spec_hash(SMALL)} and df["run_id"].nunique() == 1
    assert df["error"].isna().all()
    assert (df["head_weighted_rms"] > 0).all() and (df["seat_weighted_rms"] > 0).all()
    np.testing.assert_allclose(
        df["head_crest_factor"], df["head_peak"] / df["head_weighted_rms"], rtol=1e-12
    )
    # every parameter of every model, per case: the model's value unless the case varies it
    for c, (_, row) in zip(cases, df.iterrows()):
        net = c.body_network()
        for p in body_params:
            want = net.parameters.get(p, float("nan"))
            assert row[f"body_{p}"] == want or (np.isnan(want) and np.isnan(row[f"body_{p}"]))
        for p, v in c.car_network().parameters.items():
            assert row[f"car_{p}"] == v
    varied = df[df["body"] == "varied"]
    assert (varied["body_k1"] != reduced.parameters["k1"]).all()
    assert (df[df["body"] == "reduced-paper"]["body_k1"] == reduced.parameters["k1"]).all()
    assert df[df["body"] == "reduced-paper"]["body_k2s"].isna().all()
    assert (df[df["car"] == "quarter-car-cushion"]["car_ms"] == car.parameters["ms"]).all()
    back = pd.read_parquet(out)
    pd.testing.assert_frame_equal(back, df, check_exact=True)
    # units and provenance in the file
    import pyarrow.parquet as pq

    schema = pq.read_schema(out)
    assert schema.field("head_vdv").metadata[b"unit"] == b"m/s^1.75"
    assert schema.field("speed").metadata[b"unit"] == b"m/s"
    assert schema.field("body_k1").metadata[b"unit"] == b"N/m"
    assert schema.field("car_ms").metadata[b"unit"] == b"kg"
    meta = schema.metadata
    file_units = json.loads(meta[b"bodyvib.units"])
    assert file_units["head_weighted_rms"] == "m/s2" and file_units["car_kt"] == "N/m"
    assert set(file_units) == set(schema.names)
    assert json.loads(meta[b"bodyvib.spec"]) == json.loads(json.dumps(SMALL))
    versions = json.loads(meta[b"bodyvib.versions"])
    assert versions["numpy"] == np.__version__ and versions["dask"] and versions["scipy"]
    assert meta[b"bodyvib.version"].decode() == __version__
    assert meta[b"bodyvib.created"].decode().endswith("Z")
    commit = meta[b"bodyvib.commit"].decode()
    assert commit == "" or len(commit.split("-")[0]) == 40
    assert json.loads(df["engine_settings"][0])["method"].startswith("exact")
    # the CSV: the same values, units in the header
    from_csv = pd.read_csv(csv)
    assert "head_vdv [m/s^1.75]" in from_csv.columns and "case_id" in from_csv.columns
    assert "body_k1 [N/m]" in from_csv.columns and "speed [m/s]" in from_csv.columns
    np.testing.assert_array_equal(from_csv["head_vdv [m/s^1.75]"], df["head_vdv"])
    assert not os.path.exists(parts_dir(str(out)))
    # one table with the class ordering physics expects: rougher road, more vibration
    piv = df.groupby(["road"])["head_weighted_rms"].median()
    assert piv["E"] > 3 * piv["C"]


def test_tasks_are_consecutive_cases_of_any_size():
    cases = expand(SMALL)
    tasks = list(plan_tasks(iter(cases), 5))
    assert [c.case_id for t in tasks for c in t] == list(range(64))
    assert [len(t) for t in tasks] == [5] * 12 + [4]
    assert task_size("batched", 10000, 2) == 512 and task_size("batched", 10000, 100) == 25
    assert task_size("spectral", 10**6, 2) == 20000 and task_size("cosim", 3, 2, block=7) == 7


#: How far a case's figures may move with the cases sharing its task: the compiled step
#: advances each case alone (same bits), and the Wk filter's block product (BLAS) is the
#: one place where cases meet. Measured: 0 in every grouping since the compiled step;
#: before it, up to 2.2e-16 m/s2 (2.8e-16 relative) with identical histories.
GROUPING_RTOL = 1e-15


def test_figures_do_not_depend_on_how_cases_are_grouped_into_tasks():
    figures = [
        "head_weighted_rms",
        "head_vdv",
        "head_peak",
        "head_crest_factor",
        "seat_weighted_rms",
    ]
    whole = run_sweep(SMALL, scheduler="serial", block=64)
    for block in (1, 5, 13):
        other = run_sweep(SMALL, scheduler="serial", block=block)
        for f in figures:
            np.testing.assert_allclose(other[f], whole[f], rtol=GROUPING_RTOL, atol=0)


def test_settings_object_and_keywords_run_the_same_sweep(tmp_path):
    """One SweepSettings, keywords, or the object with keywords replacing some fields: the
    same table (run_id aside) and the same files; a keyword that is no setting and a
    contradiction between settings are refused by name."""
    import pytest

    from bodyvib.runtime.errors import BodyvibError

    spec = {**SMALL, "body": "reduced-paper", "car": "quarter-car"}
    by_keywords = run_sweep(spec, scheduler="serial", block=3, out=str(tmp_path / "a.parquet"))
    settings = SweepSettings(scheduler="serial", block=3, out=str(tmp_path / "b.parquet"))
    by_object = run_sweep(spec, settings)
    replaced = run_sweep(
        spec, settings, out=str(tmp_path / "c.parquet"), csv=str(tmp_path / "c.csv")
    )
    for df in (by_object, replaced):
        pd.testing.assert_frame_equal(_figures(df), _figures(by_keywords))
    assert (tmp_path / "c.parquet").is_file() and (tmp_path / "c.csv").is_file()
    assert settings.out == str(tmp_path / "b.parquet")  # frozen: a call replaces a copy
    with pytest.raises(BodyvibError, match="worker_count"):
        run_sweep(spec, settings, worker_count=2)
    with pytest.raises(BodyvibError, match="retry_failed=True needs resume=True"):
        run_sweep(spec, settings, retry_failed=True)


def test_local_cluster_equals_serial_exactly():
    serial = run_sweep(SMALL, scheduler="serial", block=7, workers=2)
    dask = run_sweep(SMALL, workers=2, block=7)  # a real two-worker LocalCluster
    pd.testing.assert_frame_equal(_figures(dask), _figures(serial), check_exact=True)
    spectral = run_sweep({**SMALL, "duration": 30}, engine="spectral", workers=2, block=16)
    spectral_serial = run_sweep(
        {**SMALL, "duration": 30}, engine="spectral", scheduler="serial", block=16
    )
    pd.testing.assert_frame_equal(_figures(spectral), _figures(spectral_serial), check_exact=True)


#: Four cases, two of which fail: a neck stiffness of 1e290 N/m gives a state matrix whose
#: exponential is not finite.
FAILING_SPEC = {
    "road": "C",
    "speed": [10, 20],
    "duration": 1,
    "body": [
        "reduced-paper",
        {"model": "reduced-paper", "vary": {"k1": [1e290, 1e290]}, "name": "absurd"},
    ],
}


def test_a_failing_case_is_recorded_and_the_sweep_goes_on(tmp_path):
    spec = FAILING_SPEC
    df = run_sweep(spec, out=str(tmp_path / "r.parquet"), scheduler="serial")
    bad = df[df["body"] == "absurd"]
    assert len(df) == 4 and len(bad) == 2
    assert bad["error"].str.contains("not finite").all() and bad["head_weighted_rms"].isna().all()
    assert df[df["body"] != "absurd"]["error"].isna().all()


def _cli(*args, **kw):
    return subprocess.Popen(
        [sys.executable, "-m", "bodyvib.cli", "sweep", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kw,
    )


def _wait_for_parts(out, proc, count, timeout=120):
    t0 = time.time()
    while time.time() - t0 < timeout:
        folder = parts_dir(out)
        if (
            os.path.isdir(folder)
            and len(
                [f for f in os.listdir(folder) if f.endswith(".parquet") and not f.startswith(".")]
            )
            >= count
        ):
            return
        if proc.poll() is not None:
            raise AssertionError(
                f"sweep ended before {count} tasks were written: {proc.communicate()}"
            )
        time.sleep(0.02)
    raise AssertionError("no parts written in time")


KILL_SPEC = {
    "road": ["C", "D", "E"],
    "speed": [10, 15, 20, 25, 30],
    "seed": [0, 1],
    "duration": 8,
    "body": "reduced-paper",
}


def test_killed_sweep_resumes_without_running_a_case_twice(tmp_path):
    spec_file = tmp_path / "spec.json"
    spec_file.write_text(json.dumps(KILL_SPEC))
    out = str(tmp_path / "r.parquet")
    # SIGKILL leaves the command's private temporary folder behind (nothing can remove it):
    # the killed process gets a temporary folder of the test's own
    own_tmp = tmp_path / "tmp"
    own_tmp.mkdir()
    proc = _cli(
        str(spec_file),
        "--out",
        out,
        "--scheduler",
        "serial",
        "--block",
        "1",
        "--quiet",
        env=dict(os.environ, TMPDIR=str(own_tmp)),
    )
    _wait_for_parts(out, proc, 3)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    first = read_results(out)
    assert 3 <= len(first) < 30, "the sweep was not killed midway"
    assert not os.path.exists(out)  # the table itself is only written at the end
    said = []
    df = run_sweep(
        str(spec_file), out=out, resume=True, scheduler="serial", block=1, progress=said.append
    )
    assert f"{len(first)} already done, {30 - len(first)} to run" in said[0]
    assert len(df) == 30 and df["case_key"].is_unique and list(df["case_id"]) == list(range(30))
    runs = df["run_id"].value_counts()
    assert runs[first["run_id"].iloc[0]] == len(first) and runs.sum() == 30 and len(runs) == 2
    # what the first run wrote is kept as it was
    kept = df.set_index("case_key").loc[first["case_key"]]
    np.testing.assert_array_equal(kept["head_weighted_rms"], first["head_weighted_rms"])
    # the sweep run in one piece gives the same figures (to the grouping tolerance)
    fresh = run_sweep(KILL_SPEC, scheduler="serial")
    for f in ("head_weighted_rms", "head_vdv", "head_peak", "seat_weighted_rms"):
        np.testing.assert_allclose(df[f], fresh[f], rtol=GROUPING_RTOL, atol=0)
    # resuming a finished sweep runs nothing
    said.clear()
    again = run_sweep(
        str(spec_file), out=out, resume=True, scheduler="serial", progress=said.append
    )
    assert "30 already done, 0 to run" in said[0] and len(again) == 30


def _one_line_error(capsys, *argv):
    assert main(["sweep", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bodyvib sweep: error:"), err
    return err[0]


def test_cli_errors_are_one_line_exit_2(tmp_path, capsys):
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"road": "C", "speed": 10, "body": "reduced-paper", "wheels": 4}))
    assert "unknown key(s) wheels" in _one_line_error(
        capsys, str(spec), "--out", str(tmp_path / "r.parquet")
    )
    assert "No such file" in _one_line_error(
        capsys, str(tmp_path / "none.json"), "--out", "r.parquet"
    )
    assert "not both" in _one_line_error(
        capsys, str(spec), "--grid", "road=C", "--out", "r.parquet"
    )
    assert "SPEC file or --grid" in _one_line_error(capsys, "--out", "r.parquet")
    assert "key=v1,v2" in _one_line_error(capsys, "--grid", "road", "--out", "r.parquet")
    assert "--out" in _one_line_error(capsys, "--grid", "road=C", "speed=10", "body=reduced-paper")
    assert ".png" in _one_line_error(
        capsys,
        "--grid",
        "road=C",
        "speed=10",
        "body=reduced-paper",
        "--out",
        str(tmp_path / "r.parquet"),
        "--plot",
        "x.gif",
    )
    assert "spectral engine needs" in _one_line_error(
        capsys,
        "--grid",
        "road=bump",
        "speed=10",
        "body=reduced-paper",
        "--engine",
        "spectral",
        "--out",
        str(tmp_path / "r.parquet"),
    )
    out = tmp_path / "done.parquet"
    grid = ["--grid", "road=C", "speed=10", "body=reduced-paper", "--duration", "1"]
    assert main(["sweep", *grid, "--out", str(out), "--scheduler", "serial", "--quiet"]) == 0
    capsys.readouterr()
    assert "exists; pass --resume" in _one_line_error(capsys, *grid, "--out", str(out))
    assert "another spec" in _one_line_error(
        capsys,
        "--grid",
        "road=D",
        "speed=10",
        "body=reduced-paper",
        "--duration",
        "1",
        "--out",
        str(out),
        "--resume",
    )
    assert "cannot connect" in _one_line_error(
        capsys,
        *grid,
        "--out",
        str(tmp_path / "x.parquet"),
        "--scheduler",
        "tcp://127.0.0.1:9",
        "--quiet",
    )


def test_cli_grid_run_and_plot(tmp_path, capsys):
    out, png = tmp_path / "r.parquet", tmp_path / "map.png"
    assert (
        main(
            [
                "sweep",
                "--grid",
                "road=C,D",
                "speed=10,20",
                "seed=0,1",
                "body=reduced-paper,iso7962",
                "--duration",
                "2",
                "--out",
                str(out),
                "--plot",
                str(png),
                "--scheduler",
                "serial",
                "--quiet",
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert f"wrote {out}" in text and f"wrote {png}" in text
    table = pd.read_parquet(out)
    assert len(table) == 16
    # the summary closes the output: its figures and cases are the table's
    summary = text.split(f"wrote {png}\n", 1)[1].splitlines()
    assert summary[0] == "sweep: 16 cases, 16 computed, 0 failed (engine batched)"
    rms = table["head_weighted_rms"]
    assert summary[1] == (
        f"head Wk r.m.s. [m/s2]: min {rms.min():.4g}, median {rms.median():.4g}, max {rms.max():.4g}"
    )
    for line, row in zip(summary[2:4], (table.loc[rms.idxmin()], table.loc[rms.idxmax()])):
        assert line.endswith(
            f"road {row.road}, {row.speed:g} m/s, body {row.body}, "
            f"car {row.car} (case {row.case_id})"
        )
    bands = table["head_comfort"].value_counts()
    assert sorted(summary[4].split(": ", 1)[1].split(", ")) == sorted(
        f"{n} {b}" for b, n in bands.items()
    )
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    png2 = tmp_path / "again.png"  # a finished table plots without running
    assert main(["sweep", "--out", str(out), "--plot", str(png2)]) == 0
    assert png2.stat().st_size > 10000


@pytest.mark.integration
@pytest.mark.skipif(
    "forkserver" not in __import__("multiprocessing").get_all_start_methods(),
    reason="workers fork from a warmed server only where multiprocessing has forkserver",
)
def test_a_sweeps_local_workers_start_with_the_engines_loaded():
    """A sweep's LocalCluster forks its workers from a server that has imported the
    engines and loaded the compiled loop: before any task, a worker has them."""
    from bodyvib.vehicle.sweep.cluster import open_cluster

    def loaded():
        import sys

        return [m in sys.modules for m in ("bodyvib.vehicle.sweep.warmed", "numba")]

    with open_cluster(workers=2) as cl:
        found = cl.client.run(loaded)
    assert len(found) == 2 and all(all(v) for v in found.values())
