"""What a sweep's Dask worker loads: a task's Parquet part without pandas, the warmed fork server."""

import io
import json
import math
import os
import subprocess
import sys

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from bodyvib.vehicle.sweep.engines import FIGURES
from bodyvib.vehicle.sweep.table import arrow_array, part_bytes, table_schema

FORKSERVER = "forkserver" in __import__("multiprocessing").get_all_start_methods()

#: Values of every kind a sweep column holds: nulls (a failed case's figures, a road
#: without seed), NaN (a parameter a model does not have), signed zero, extremes, text
#: outside ASCII, empty text.
VALUES = {
    pa.int64(): [0, None, 2**62, -(2**63), 7, None],
    pa.float64(): [1.5, None, math.nan, -0.0, 1e-308, math.inf, 2.0**-1074, None],
    pa.string(): ["C", None, "", "a little uncomfortable", "é ✓ 𝛼", None],
}


def _fresh_python(code: str) -> str:
    """What ``code`` prints when run by a new interpreter (nothing imported before it)."""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return out.stdout


@pytest.mark.parametrize("arrow_type", list(VALUES), ids=str)
@pytest.mark.parametrize("nulls", [True, False])
def test_a_column_is_the_array_pyarrow_converts(arrow_type, nulls):
    values = [v for v in VALUES[arrow_type] if nulls or v is not None]
    got, want = arrow_array(values, arrow_type), pa.array(values, arrow_type)
    got.validate(full=True)
    assert got.type == want.type and got.null_count == want.null_count
    # the same bits, NaN and -0.0 included (Array.equals takes NaN for unequal)
    assert [b.to_pybytes() if b else None for b in got.buffers()] == [
        b.to_pybytes() if b else None for b in want.buffers()
    ]


def test_a_tasks_part_is_the_parquet_file_of_the_converted_table():
    schema = table_schema({"m1": "kg", "k1": "N/m"}, {"ms": "kg"}, FIGURES)
    rows = 5
    columns = {}
    for i, field in enumerate(schema):
        values = VALUES[field.type]
        columns[field.name] = [values[(i + r) % len(values)] for r in range(rows)]
    want = io.BytesIO()
    pq.write_table(pa.Table.from_pydict(columns, schema=schema), want)
    assert part_bytes(columns, schema) == want.getvalue()


def test_a_column_of_another_type_or_with_a_number_in_text_is_refused():
    with pytest.raises(TypeError, match="Arrow type bool"):
        arrow_array([True], pa.bool_())
    with pytest.raises(TypeError, match="string column holds int 3"):
        arrow_array(["a", 3], pa.string())


@pytest.mark.integration
def test_the_servers_environment_is_known_before_distributed_is_imported():
    """In a process that has not imported distributed, distributed's defaults come from
    the file distributed reads them from: the same variables as after its import."""
    from bodyvib.vehicle.sweep.cluster import _server_environ

    code = (
        "import json, sys\n"
        "from bodyvib.vehicle.sweep.cluster import _server_environ\n"
        "print(json.dumps([_server_environ({}), 'distributed' in sys.modules]))\n"
    )
    env, imported = json.loads(_fresh_python(code))
    import distributed  # noqa: F401  (its defaults in Dask's configuration)

    assert not imported and env == _server_environ({})
    assert env["OMP_NUM_THREADS"] == os.environ.get("OMP_NUM_THREADS", "1")


@pytest.mark.integration
@pytest.mark.skipif(not FORKSERVER, reason="workers fork from a server only with forkserver")
def test_starting_a_local_cluster_leaves_distributeds_preload_list_unimported():
    """distributed imports the packages of its own preload list (pandas among them) in
    the process that starts a LocalCluster; the sweep's fork server has its own list."""
    code = (
        "import sys\n"
        "from bodyvib.vehicle.sweep.cluster import open_cluster\n"
        "with open_cluster(workers=1) as cl:\n"
        "    assert cl.threads(10) == 1\n"
        "print('pandas' in sys.modules)\n"
    )
    assert _fresh_python(code).strip() == "False"


@pytest.mark.integration
def test_writing_a_part_does_not_import_pandas():
    """pyarrow's conversion of Python values imports pandas; a part is written without it."""
    code = (
        "import sys\n"
        "from bodyvib.vehicle.sweep.table import part_bytes, table_schema\n"
        "s = table_schema({'m1': 'kg'}, {}, ['head_weighted_rms'])\n"
        "part_bytes({f.name: [None] for f in s}, s)\n"
        "print('pandas' in sys.modules)\n"
    )
    assert _fresh_python(code).strip() == "False"


@pytest.mark.integration
@pytest.mark.skipif(not FORKSERVER, reason="workers fork from a server only with forkserver")
def test_a_local_workers_first_sweep_loads_nothing_and_it_has_dasks_environment():
    """The fork server imports all a task needs (a task's first run imports no module),
    and it starts early with the environment Dask gives its workers: the hash seed
    (the hash of a string, as a Python started with PYTHONHASHSEED=6640 computes it)
    and glibc's malloc settings, which glibc reads when the process starts."""
    import psutil

    from bodyvib.vehicle.sweep.cluster import open_cluster
    from bodyvib.vehicle.sweep.run import run_sweep

    def modules():
        return sorted(sys.modules)

    def text_hash():
        return hash("bodyvib")

    def running_servers():
        return [
            p
            for p in psutil.Process().children(recursive=True)
            if "forkserver" in " ".join(p.cmdline())
        ]

    seen = []  # the servers running when this process's own preparation is called

    def meanwhile():
        seen.append(len(running_servers()))

    spec = {"road": "C", "speed": [10, 20], "seed": [0, 1], "duration": 1, "body": "reduced-paper"}
    with open_cluster(workers=1, meanwhile=meanwhile) as cl:
        before = next(iter(cl.client.run(modules).values()))
        run_sweep(spec, scheduler=cl.client.scheduler.address)
        after = next(iter(cl.client.run(modules).values()))
        worker_hash = next(iter(cl.client.run(text_hash).values()))
        servers = [p.environ() for p in running_servers()]
    assert sorted(set(after) - set(before)) == []
    assert len(seen) == 1 and seen[0] >= 1
    seeded = subprocess.run(
        [sys.executable, "-c", "print(hash('bodyvib'))"],
        env={"PYTHONHASHSEED": "6640"},
        capture_output=True,
        text=True,
        check=True,
    )
    assert worker_hash == int(seeded.stdout)
    assert servers and all(e.get("MALLOC_TRIM_THRESHOLD_") == str(128 << 20) for e in servers)


def test_the_fork_server_gets_the_environment_dask_gives_a_worker(monkeypatch):
    """The server starts before this process imports distributed, with the variables
    distributed.Nanny would set before starting a worker (its own computation here)."""
    import dask
    from distributed.nanny import _get_env_variables

    from bodyvib.vehicle.sweep.cluster import _server_environ

    key = "distributed.nanny.pre-spawn-environ"
    config = {f"{key}.MALLOC_TRIM_THRESHOLD_": 1 << 27, f"{key}.BODYVIB_TEST_ONLY": "x"}
    monkeypatch.setenv("OMP_NUM_THREADS", "3")  # this process's value wins
    for seed in (None, "0", "12"):
        if seed is None:
            monkeypatch.delenv("PYTHONHASHSEED", raising=False)
        else:
            monkeypatch.setenv("PYTHONHASHSEED", seed)
        with dask.config.set({**config, f"{key}.PYTHONHASHSEED": seed}):
            want = _get_env_variables(key)
        if want.get("PYTHONHASHSEED") in (None, "0"):
            want["PYTHONHASHSEED"] = "6640"  # distributed.Nanny's fixed seed
        got = _server_environ({**config, f"{key}.PYTHONHASHSEED": seed})
        assert got == want
        assert got["OMP_NUM_THREADS"] == "3" and got["MALLOC_TRIM_THRESHOLD_"] == str(1 << 27)


@pytest.mark.integration
@pytest.mark.skipif(not FORKSERVER, reason="workers fork from a server only with forkserver")
def test_a_sweep_starts_its_workers_server_before_it_samples_the_bodies():
    """The server a LocalCluster's workers fork from is started as soon as the sweep's
    cases are counted: its warm-up (0.8 s of CPU) runs while this process samples the
    bodies (scipy.stats for a Latin hypercube) and checks the outputs. A serial sweep,
    and one small enough to run in this process, start none."""
    code = (
        "import json, sys\n"
        "import psutil\n"
        "import bodyvib.vehicle.sweep.spec as sp\n"
        "from bodyvib.vehicle.sweep.run import run_sweep\n"
        "seen = []\n"
        "sample = sp._samples\n"
        "def samples(*a):\n"
        "    kids = psutil.Process().children(recursive=True)\n"
        "    seen.append(any('forkserver' in ' '.join(p.cmdline()) for p in kids))\n"
        "    return sample(*a)\n"
        "sp._samples = samples\n"
        "body = [{'model': 'reduced-paper', 'samples': 5, 'vary': {'m1': [0.9, 1.1]}}]\n"
        "spec = {'road': ['C', 'D'], 'speed': [10, 20], 'duration': 1, 'body': body}\n"
        "small = dict(spec, road='C', speed=10)\n"
        "if __name__ == '__main__':\n"
        "    run_sweep(spec, scheduler='serial')\n"
        "    run_sweep(small)\n"
        "    df = run_sweep(spec, workers=1)\n"
        "    print(json.dumps([seen, len(df)]))\n"
    )
    seen, rows = json.loads(_fresh_python(code).strip().splitlines()[-1])
    assert seen == [False, False, True] and rows == 20
