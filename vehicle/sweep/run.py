"""Running a sweep: cases grouped into tasks, executed on Dask, written as they arrive.

:func:`run_sweep` expands a spec (:mod:`vehicle.sweep.spec`), skips the cases
already in the output when resuming, groups the rest into tasks (blocks of
cases with the same body model, car, duration and step, so that the batched
engine advances a whole block with one matrix product per step), runs them on
a Dask scheduler -- a :class:`distributed.LocalCluster` with one
single-threaded worker process per core by default, any scheduler address, or
``"serial"`` in-process -- and collects the results with
:func:`distributed.as_completed`.

Output: each finished task is written at once, atomically, as one Parquet file
in ``OUT.parts/``; at the end (and on Ctrl-C) all rows are gathered into
``OUT`` (atomically, sorted by ``case_id``) and the parts are deleted. A sweep
killed at any point keeps every finished task; ``resume=True`` reads ``OUT``
and ``OUT.parts/``, refuses an output written by another spec, and runs only
the cases whose ``case_key`` is missing.

The table, one row per case (:data:`BASE_COLUMNS`, then one ``body_<name>``
column per varied body parameter in SI units):

================== ===========================================================
case_id, case_key  position in the spec; hash identifying the case
road, seed         ISO 8608 class, ``bump`` or ``sweep``; random-road seed
speed_m_s          vehicle speed, m/s
duration_s, step_s run length and time step, s
body, body_model   body entry name; shipped model name or parameter file
body_sample        parameter-set number of a ``vary`` entry (-1: none)
car                car model name or file
head_weighted_rms  head ISO 2631-1 Wk-weighted r.m.s., m/s2
head_vdv           head vibration dose value, m/s^1.75 (NaN for ``spectral``)
head_peak          head peak weighted acceleration, m/s2 (NaN for ``spectral``)
head_crest_factor  peak / r.m.s. (NaN for ``spectral``)
head_comfort       ISO 2631-1 Annex C words for the head's weighted r.m.s.
seat_weighted_rms  seat (the car's seat point) Wk-weighted r.m.s., m/s2
engine             ``batched``, ``spectral`` or ``cosim``
error              why the case failed (empty when it did not)
bodyvib_version    version that computed the row
spec_hash          hash of the spec and the files it names
run_id             the invocation that computed the row
================== ===========================================================
"""

import io
import math
import os
import shutil
import sys
import uuid
from typing import Callable, Dict, List, Optional, Sequence, Union

from bodyvib import __version__
from bodyvib.process import interrupts
from bodyvib.runtime.errors import BodyvibError
from bodyvib.process.outputs import atomic_write_bytes, atomic_write_text

from .engines import FIGURES, check_engine, run_engine
from .spec import Case, expand, load_spec, spec_hash, varied_parameters

__all__ = ["BASE_COLUMNS", "run_sweep", "plan_tasks", "read_results", "parts_dir"]

#: Columns of every sweep table, in order (``body_<parameter>`` columns follow ``car``).
BASE_COLUMNS = ("case_id", "case_key", "road", "seed", "speed_m_s", "duration_s", "step_s",
                "body", "body_model", "body_sample", "car") + FIGURES + (
                "engine", "error", "bodyvib_version", "spec_hash", "run_id")


def parts_dir(out: str) -> str:
    """Folder holding the per-task files of a running sweep (``OUT.parts``).

    Parameters
    ----------
    out : str
        The sweep's output file.

    Returns
    -------
    str

    Examples
    --------
    >>> parts_dir("results.parquet")
    'results.parquet.parts'
    """
    return os.fspath(out) + ".parts"


def _schema(params: Sequence[str]):
    import pyarrow as pa

    types = {"case_id": pa.int64(), "seed": pa.int64(), "body_sample": pa.int64(),
             "speed_m_s": pa.float64(), "duration_s": pa.float64(), "step_s": pa.float64()}
    for f in FIGURES:
        if f != "head_comfort":
            types[f] = pa.float64()
    names = list(BASE_COLUMNS)
    at = names.index("car") + 1
    names[at:at] = [f"body_{p}" for p in params]
    for p in params:
        types[f"body_{p}"] = pa.float64()
    return pa.schema([(n, types.get(n, pa.string())) for n in names])


def _row(case: Case, figures: dict, engine: str, sh: str, run_id: str, params) -> dict:
    values = dict(case.body_values)
    row = {"case_id": case.case_id, "case_key": case.case_key, "road": case.road,
           "seed": case.seed, "speed_m_s": case.speed, "duration_s": case.duration,
           "step_s": case.step, "body": case.body, "body_model": case.body_model,
           "body_sample": case.body_sample, "car": case.car}
    for p in params:
        row[f"body_{p}"] = values.get(p, float("nan"))
    row.update({k: figures.get(k) for k in FIGURES})
    row.update(engine=engine, error=figures.get("error"), bodyvib_version=__version__,
               spec_hash=sh, run_id=run_id)
    return row


def _parquet_bytes(rows: List[dict], schema) -> bytes:
    import pyarrow as pa
    import pyarrow.parquet as pq

    buf = io.BytesIO()
    pq.write_table(pa.Table.from_pylist(rows, schema=schema), buf)
    return buf.getvalue()


def read_results(out: str):
    """Rows of a sweep output so far: ``OUT`` and ``OUT.parts/`` (duplicates dropped).

    Parameters
    ----------
    out : str
        The sweep's ``--out`` file.

    Returns
    -------
    pandas.DataFrame or None
        None if there is nothing yet.

    Raises
    ------
    BodyvibError
        A file that is not a sweep table.
    """
    import pandas as pd
    import pyarrow.parquet as pq

    frames = []
    files = [out] if os.path.isfile(out) else []
    pd_dir = parts_dir(out)
    if os.path.isdir(pd_dir):
        files += [os.path.join(pd_dir, f) for f in sorted(os.listdir(pd_dir))
                  if f.endswith(".parquet") and not f.startswith(".")]
    for f in files:
        try:
            frames.append(pq.read_table(f).to_pandas())
        except Exception as exc:
            raise BodyvibError(f"'{f}' is not a readable sweep table: {exc}") from None
    if not frames:
        return None
    df = pd.concat(frames, ignore_index=True)
    if "case_key" not in df.columns:
        raise BodyvibError(f"'{out}' is not a sweep table (no case_key column)")
    return df.drop_duplicates("case_key", keep="first")


def plan_tasks(cases: Sequence[Case], engine: str, workers: int = 1,
               block: Optional[int] = None) -> List[List[Case]]:
    """Group cases into tasks.

    Cases with the same body model, car, duration and step go together (the
    batched engine advances a task's cases in one array), ordered by body
    parameters so that cases sharing a model are adjacent; each group is cut
    into blocks of ``block`` cases.

    Parameters
    ----------
    cases : sequence of Case
    engine : str
    workers : int
        Workers the tasks are for: by default blocks are sized to give each
        worker at least four tasks.
    block : int, optional
        Cases per task. Default: batched 16-512, spectral 20,000, cosim 1-16
        (its FMUs are built once per task).

    Returns
    -------
    list of list of Case

    Examples
    --------
    >>> from vehicle.sweep.spec import expand
    >>> cases = expand({"road": ["C", "D"], "speed": [10, 20], "body": ["reduced-paper", "iso7962"]})
    >>> [len(t) for t in plan_tasks(cases, "batched", block=3)]
    [3, 1, 3, 1]
    """
    if block is None:
        share = math.ceil(len(cases) / max(1, 4 * workers)) if cases else 1
        block = {"batched": min(512, max(16, share)), "spectral": 20000,
                 "cosim": min(16, max(1, share))}[engine]
    block = max(1, int(block))
    groups: Dict[tuple, List[Case]] = {}
    for c in cases:
        groups.setdefault((c.body_model, c.car, c.duration, c.step), []).append(c)
    tasks = []
    for group in groups.values():
        group = sorted(group, key=lambda c: (c.body_values, c.case_id))
        tasks += [group[i:i + block] for i in range(0, len(group), block)]
    return tasks


def _check_output(path, what):
    if path is None:
        return
    folder = os.path.dirname(os.path.abspath(path))
    probe = folder
    while not os.path.isdir(probe):
        parent = os.path.dirname(probe)
        if parent == probe:
            break
        probe = parent
    if os.path.isdir(path):
        raise BodyvibError(f"{what} '{path}' is a folder")
    if not os.access(probe, os.W_OK):
        raise BodyvibError(f"cannot write {what} '{path}': folder '{probe}' is not writable")


def _client(scheduler, workers):
    """(client, cluster, scratch folder or None) for a scheduler setting."""
    import logging
    import tempfile

    from dask.distributed import Client, LocalCluster

    if scheduler in (None, "local"):
        import dask

        # Dask's workers return freed memory to the system at once (glibc
        # MALLOC_TRIM_THRESHOLD_ = 64 kB), which made the batched engine's
        # block buffers fault in again and again: 1.36x the in-process time
        # against 1.12x with the default threshold (measured).
        # the workers' scratch space goes into a folder of this run, deleted after it
        scratch = tempfile.mkdtemp(prefix="bodyvib-sweep-dask-")
        try:
            with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_":
                                  128 * 1024 * 1024, "temporary-directory": scratch}):
                cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=logging.ERROR,
                                       local_directory=scratch)
            return Client(cluster), cluster, scratch
        except BaseException:
            shutil.rmtree(scratch, ignore_errors=True)
            raise
    try:
        return Client(scheduler, timeout="5s"), None, None
    except Exception as exc:
        raise BodyvibError(f"cannot connect to the Dask scheduler '{scheduler}': {exc}") from None


def run_sweep(spec: Union[dict, str], out: Optional[str] = None, engine: str = "batched",
              scheduler: Optional[str] = None, resume: bool = False, overwrite: bool = False,
              csv: Optional[str] = None, progress: bool = False, block: Optional[int] = None,
              workers: Optional[int] = None, echo: Optional[Callable[[str], None]] = None):
    """Run a sweep and return its table.

    Parameters
    ----------
    spec : dict or str
        A spec (:mod:`vehicle.sweep.spec`) or the path of a JSON spec.
    out : str, optional
        Parquet file for the table (also the key of ``--resume``); None keeps
        the table in memory only.
    engine : str
        ``"batched"`` (default), ``"spectral"`` or ``"cosim"``.
    scheduler : str, optional
        None or ``"local"``: a LocalCluster of ``workers`` single-threaded
        processes (None: in this process when all cases make one task);
        ``"serial"``: in this process, no Dask; otherwise the
        address of a running Dask scheduler (``tcp://host:8786``), whose
        workers must have bodyvib installed.
    resume : bool
        Keep the rows already in ``out`` (and its parts) and run the rest.
    overwrite : bool
        Replace an existing ``out`` instead of refusing.
    csv : str, optional
        Also write the table as CSV.
    progress : bool
        Progress bar on stderr.
    block : int, optional
        Cases per task (see :func:`plan_tasks`).
    workers : int, optional
        LocalCluster size (default: the number of cores).
    echo : callable, optional
        Called with one-line status messages.

    Returns
    -------
    pandas.DataFrame
        One row per case, sorted by ``case_id`` (columns in the module docstring).

    Raises
    ------
    BodyvibError
        A bad spec or engine, an output that exists (without ``resume`` or
        ``overwrite``) or cannot be written, an output of another spec on
        resume, an unreachable scheduler.
    KeyboardInterrupt
        After writing what was done (resumable).

    Examples
    --------
    >>> df = run_sweep({"road": "C", "speed": [10, 20], "duration": 2,
    ...                 "body": "reduced-paper"}, scheduler="serial")
    >>> list(df["speed_m_s"]), bool(df["head_weighted_rms"].gt(0).all())
    ([10.0, 20.0], True)
    """
    say = echo or (lambda msg: None)
    if isinstance(spec, (str, os.PathLike)):
        spec = load_spec(os.fspath(spec))
    cases = expand(spec)
    check_engine(engine, cases)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 1):
        raise BodyvibError(f"workers must be a positive integer, got {workers!r}")
    workers = workers or os.cpu_count() or 1
    sh = spec_hash(spec)
    params = varied_parameters(cases)
    schema = _schema(params)
    if resume and out is None:
        raise BodyvibError("resume needs an output file")
    _check_output(out, "output")
    _check_output(csv, "CSV output")
    done = None
    if out is not None:
        if resume:
            done = read_results(out)
            if done is not None:
                other = sorted(set(done["spec_hash"]) - {sh})
                if other:
                    raise BodyvibError(f"'{out}' holds rows of another spec (hash {other[0]}, "
                                       f"this spec {sh}); use another output file")
                done = done[done["case_key"].isin({c.case_key for c in cases})]
        elif (os.path.exists(out) or os.path.isdir(parts_dir(out))) and not overwrite:
            raise BodyvibError(f"output '{out}' exists; pass --resume to continue that sweep or "
                               "--overwrite to replace it")
        elif overwrite:
            shutil.rmtree(parts_dir(out), ignore_errors=True)
    done_keys = set(done["case_key"]) if done is not None else set()
    todo = [c for c in cases if c.case_key not in done_keys]
    run_id = uuid.uuid4().hex[:12]
    tasks = plan_tasks(todo, engine, workers=workers, block=block)  # same tasks on any scheduler
    say(f"sweep: {len(cases)} cases, {len(done_keys)} already done, {len(todo)} to run in "
        f"{len(tasks)} tasks, engine {engine}, "
        + ("in this process" if scheduler == "serial" or (scheduler is None and len(tasks) == 1) else
           f"LocalCluster of {workers} workers" if scheduler in (None, "local") else
           f"scheduler {scheduler}"))
    new_rows: List[dict] = []
    part_folder = parts_dir(out) if out is not None else None

    def arrived(task_no, task, figures):
        rows = [_row(c, f, engine, sh, run_id, params) for c, f in zip(task, figures)]
        new_rows.extend(rows)
        if part_folder is not None:
            atomic_write_bytes(os.path.join(part_folder, f"part-{run_id}-{task_no:06d}.parquet"),
                               _parquet_bytes(rows, schema))
        if bar is not None:
            bar.update(len(rows))

    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(cases), initial=len(done_keys), unit="case", file=sys.stderr,
                   desc="sweep", mininterval=0.5, disable=None)
    # one task and no scheduler asked for: starting a cluster would cost more than the task
    serial = scheduler == "serial" or (scheduler is None and len(tasks) == 1)
    try:
        if tasks and serial:
            for i, task in enumerate(tasks):
                arrived(i, task, run_engine(engine, task))
                interrupts.check()  # Ctrl-C: stop between tasks, keep what arrived
        elif tasks:
            from dask.distributed import as_completed

            client, cluster, scratch = _client(scheduler, workers)
            try:
                futures = {client.submit(run_engine, engine, task, pure=False): i
                           for i, task in enumerate(tasks)}
                for fut in as_completed(futures):
                    i = futures[fut]
                    try:
                        figures = fut.result()
                    except Exception as exc:  # a lost worker: the task's cases are failed
                        figures = [{"error": f"task failed: {type(exc).__name__}: {exc}"}
                                   for _ in tasks[i]]
                    arrived(i, tasks[i], figures)
                    fut.release()
                    interrupts.check()  # Ctrl-C: stop between arrivals, keep what arrived
            finally:
                client.close()
                if cluster is not None:
                    cluster.close()
                if scratch is not None:
                    shutil.rmtree(scratch, ignore_errors=True)
    except KeyboardInterrupt:
        if out is not None:
            _gather(out, done, new_rows, schema, None)
        raise
    finally:
        if bar is not None:
            bar.close()
    df = _table(done, new_rows, schema)
    if out is not None:
        _gather(out, done, new_rows, schema, csv, df)
    elif csv is not None:
        atomic_write_text(csv, df.to_csv(index=False))
    failed = int(df["error"].notna().sum()) if len(df) else 0
    say(f"sweep: {len(df)} cases" + (f", {failed} failed (see the error column)" if failed else "")
        + (f"; wrote {out}" if out else ""))
    return df


def _table(done, new_rows, schema):
    import pandas as pd
    import pyarrow as pa

    new = pa.Table.from_pylist(new_rows, schema=schema).to_pandas()
    frames = [f for f in (done, new) if f is not None and len(f)]
    if not frames:
        return new
    df = pd.concat([f[new.columns] for f in frames], ignore_index=True)
    return df.sort_values("case_id", kind="stable").reset_index(drop=True)


def _gather(out, done, new_rows, schema, csv, df=None):
    """Write all rows so far into ``out`` (and ``csv``), then drop the parts."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    if df is None:
        df = _table(done, new_rows, schema)
    table = pa.Table.from_pandas(df, schema=schema, preserve_index=False)
    buf = io.BytesIO()
    pq.write_table(table, buf)
    atomic_write_bytes(out, buf.getvalue())
    if csv is not None:
        atomic_write_text(csv, df.to_csv(index=False))
    shutil.rmtree(parts_dir(out), ignore_errors=True)
