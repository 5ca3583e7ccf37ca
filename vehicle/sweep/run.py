"""Running a sweep: cases cut into tasks, executed here or on Dask, written as they arrive.

:func:`run_sweep` validates a spec (:mod:`bodyvib.vehicle.sweep.spec`) and checks the
outputs before any work, skips the cases already stored when resuming, cuts
the pending case numbers into tasks of consecutive cases (:func:`plan_tasks`,
sized by :func:`task_size` from the cluster's threads) and runs them in this
process or on Dask (:mod:`bodyvib.vehicle.sweep.cluster`: a LocalCluster of
single-threaded worker processes by default, any scheduler address or
scheduler file). A task is an array of case numbers; it returns its rows as
Parquet bytes.

Output: each finished task is written at once, atomically, as one Parquet part
in ``OUT.parts/``; at the end the parts are streamed into ``OUT`` (and the
CSV) by ``case_id``, all outputs or none (:mod:`bodyvib.vehicle.sweep.table`), and
deleted. A sweep that is interrupted, killed or loses its cluster keeps every
finished task; ``resume=True`` refuses an output written by another spec and
runs only the cases not stored (``retry_failed=True``: also those stored
with an error).

The table, one row per case (:data:`BASE_COLUMNS`, with one ``body_<name>``
and ``car_<name>`` column per parameter of every model after ``car``; units
in the schema, see :mod:`bodyvib.vehicle.sweep.table`):

========================= ===========================================================
case_id, case_key         position in the spec; hash identifying the case
road, seed                ISO 8608 class, ``bump``, ``sweep``, a bump shape with its
                          dimensions or a road file; random-road seed
speed                     vehicle speed, m/s
duration, step            run length and time step, s
body, body_model          body entry name; shipped model name or parameter file
body_sample               parameter-set number of a ``vary`` entry (-1: none)
car                       car model name or file
head_weighted_rms         head ISO 2631-1 Wk-weighted r.m.s., m/s2
head_vdv                  head vibration dose value, m/s^1.75 (NaN for ``spectral``)
head_peak                 head peak weighted acceleration, m/s2 (NaN for ``spectral``)
head_crest_factor         peak / r.m.s. (NaN for ``spectral``)
head_comfort              ISO 2631-1 Annex C words for the head's weighted r.m.s.
head_comfort_method       which ISO 2631-1 method governs (clause 6.3): ``basic``,
                          ``vdv`` or ``mtvv`` (:func:`bodyvib.comfort.governing_method`);
                          where it is not ``basic``, ``head_comfort`` names the r.m.s. only
seat_weighted_rms         seat (the car's seat point) Wk-weighted r.m.s., m/s2
head_mtvv                 head maximum transient vibration value (largest 1 s running
                          r.m.s.), m/s2 (NaN for ``spectral``)
neck_force_peak           largest magnitude of the body's neck force, N (NaN for
                          ``spectral`` and for a body that names no neck force)
lumbar_force_peak         the same for the lumbar force, N
seat_aw_x, _y, _z         the seat surface's ISO 2631-1 weighted r.m.s. fore-aft,
                          sideways (Wd) and vertical (Wk), m/s2 (NaN: a car whose seat
                          has no height above the body's centre, a quarter car)
seat_av                   their point vibration total value for comfort, m/s2
seat_aw_rx, _ry           the seat's roll (a full car) and pitch accelerations, We, rad/s2
seat_rotation_av          their point vibration total value for comfort, m/s2
lift_offs                 a car with tire contacts: lift-offs, summed over the wheels (NaN:
                          a linear run)
time_in_air               time in the air, s, summed over the wheels
stop_contacts             contacts with the bump and rebound stops, summed over the stops
largest_stop_force        the largest stop force, N
smallest_tire_load_ratio  the smallest total over static tire force of any wheel (0: in
                          the air)
stepping                  ``linear``, ``batched`` (nothing switched) or ``events`` (run
                          again with exact steps and located events)
engine                    ``batched``, ``spectral`` or ``cosim``
engine_settings           the engine's settings (JSON)
error                     why the case failed (empty when it did not)
bodyvib_version           version that computed the row
spec_hash                 hash of the spec and the files it names
run_id                    the invocation that computed the row
========================= ===========================================================
"""

import json
import math
import os
import shutil
import tempfile
import time
import uuid
from dataclasses import dataclass, replace
from itertools import islice
from typing import Callable, Dict, Iterator, List, Optional, Sequence, Union

import numpy as np
from numpy.linalg import LinAlgError

from bodyvib import __version__
from bodyvib.process import extras, interrupts
from bodyvib.process.outputs import atomic_write_bytes, check_outputs, open_staged, staged_writes
from bodyvib.process.progress import Progress, progress_bar, progress_lines
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.renames import renamed_parameters

from .cluster import ClusterLost, open_cluster, run_tasks, start_server
from .engines import ENGINE_SETTINGS, FIGURES, check_engine, run_engine
from .spec import Case, _Prepared, load_spec, spec_hash
from .table import (
    CASE_COLUMNS,
    REPLACES_OUT,
    TRAILING_COLUMNS,
    assemble,
    current_columns,
    part_bytes,
    part_name,
    parts_dir,
    provenance,
    scan,
    table_schema,
    units,
    write_part,
)

__all__ = [
    "BASE_COLUMNS",
    "PARQUET_EXTENSIONS",
    "SweepSettings",
    "run_sweep",
    "plan_tasks",
    "read_results",
    "parts_dir",
    "task_size",
]

#: Columns of every sweep table, in order (``body_<parameter>`` and ``car_<parameter>``
#: columns, every parameter of every model of the sweep, follow ``car``).
BASE_COLUMNS = tuple(n for n, _ in CASE_COLUMNS) + FIGURES + TRAILING_COLUMNS

#: The extension of a sweep table (``out``): the file is Parquet.
PARQUET_EXTENSIONS = (".parquet",)

#: Cases per task: (smallest, largest) by engine; between them, four tasks per worker thread.
TASK_SIZES = {"batched": (16, 512), "spectral": (200, 20000), "cosim": (1, 16)}


def task_size(engine: str, cases: int, threads: int, block: Optional[int] = None) -> int:
    """Cases per task: ``block`` if given, else four tasks per worker thread within the engine's bounds.

    Parameters
    ----------
    engine : str
    cases : int
        Cases to run.
    threads : int
        Worker threads of the cluster (1 in this process).
    block : int, optional

    Returns
    -------
    int

    Examples
    --------
    >>> task_size("batched", 10000, 2), task_size("batched", 10000, 100)
    (512, 25)
    """
    if block is not None:
        return max(1, int(block))
    lo, hi = TASK_SIZES[engine]
    return min(hi, max(lo, math.ceil(cases / max(1, 4 * threads))))


def plan_tasks(cases, block: int) -> Iterator[List[Case]]:
    """Cut a stream of cases into tasks of ``block`` consecutive cases (made lazily).

    Consecutive cases share their road, seed and speed (the spec's outer keys),
    so a task generates few roads; the batched engine groups a task's cases by
    state size itself. The figures of a case do not depend on the task it is in.

    Parameters
    ----------
    cases : iterable of Case
    block : int

    Yields
    ------
    list of Case

    Examples
    --------
    >>> from bodyvib.vehicle.sweep.spec import expand
    >>> cases = expand({"road": ["C", "D"], "speed": [10, 20], "body": ["reduced-paper", "iso7962"]})
    >>> [len(t) for t in plan_tasks(cases, 3)]
    [3, 3, 2]
    """
    it = iter(cases)
    while True:
        task = list(islice(it, block))
        if not task:
            return
        yield task


def read_results(out: str):
    """Rows of a sweep output so far: ``OUT`` and ``OUT.parts/``, one per case, by ``case_id``.

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
    bodyvib.process.extras.MissingExtraError
        The sweep extra is not installed.
    """
    import io

    extras.require("reading a sweep table", "sweep")
    import pyarrow.parquet as pq

    found = scan(out)
    if not found.rows:
        return None
    schema = current_columns(pq.read_schema(found.sources[-1]), found.sources[-1])
    buf = io.BytesIO()
    assemble(found, schema, out_file=buf)
    buf.seek(0)
    return pq.read_table(buf).to_pandas()


class _Rows:
    """Turns a task's figures into table columns: the case, every model parameter, provenance."""

    def __init__(self, prep: _Prepared, engine: str, sh: str, run_id: str):
        from bodyvib.models import load_model
        from bodyvib.vehicle.quarter_car import load_car

        self.prep, self.engine, self.sh, self.run_id = prep, engine, sh, run_id
        self.base = {m: load_model(m) for m in dict.fromkeys(b[1] for b in prep.bodies)}
        self.cars = {c: load_car(c, linear=prep.linear) for c in prep.cars}  # as the cases run
        body_units: Dict[str, str] = {}
        for net in self.base.values():
            for p in net.parameters:
                body_units.setdefault(p, net.units.get(p, ""))
        car_units: Dict[str, str] = {}
        for net in self.cars.values():
            for p in net.parameters:
                car_units.setdefault(p, net.units.get(p, ""))
        self.body_params, self.car_params = list(body_units), list(car_units)
        self.schema = table_schema(body_units, car_units, FIGURES)
        self.settings = ENGINE_SETTINGS[engine]
        self._body_values: Dict[tuple, dict] = {}

    def _body(self, case: Case) -> dict:
        key = (case.body_model, case.body_values)
        v = self._body_values.get(key)
        if v is None:
            if len(self._body_values) > 4096:
                self._body_values.clear()
            v = {**self.base[case.body_model].parameters, **dict(case.body_values)}
            v = self._body_values[key] = {p: float(v.get(p, math.nan)) for p in self.body_params}
        return v

    def columns(self, cases: Sequence[Case], figures: Sequence[dict]) -> Dict[str, list]:
        if len(cases) != len(figures):
            raise BodyvibError(f"an engine returned {len(figures)} rows for {len(cases)} cases")
        cols: Dict[str, list] = {n: [] for n in self.schema.names}
        for c, f in zip(cases, figures):
            for name, value in (
                ("case_id", c.case_id),
                ("case_key", c.case_key),
                ("road", c.road),
                ("seed", c.seed),
                ("speed", c.speed),
                ("duration", c.duration),
                ("step", c.step),
                ("body", c.body),
                ("body_model", c.body_model),
                ("body_sample", c.body_sample),
                ("car", c.car),
            ):
                cols[name].append(value)
            for p, x in self._body(c).items():
                cols[f"body_{p}"].append(x)
            car = self.cars[c.car].parameters
            for p in self.car_params:
                cols[f"car_{p}"].append(float(car.get(p, math.nan)))
            for k in FIGURES:
                cols[k].append(f.get(k))
            cols["engine"].append(self.engine)
            cols["engine_settings"].append(self.settings)
            cols["error"].append(f.get("error"))
            cols["bodyvib_version"].append(__version__)
            cols["spec_hash"].append(self.sh)
            cols["run_id"].append(self.run_id)
        return cols


class _Work:
    """What a task computes: the rows of some cases (by ``case_id``) as Parquet bytes.

    Sent to each worker once; a task is only an array of case numbers, so the
    client holds little per case in flight, and the rows are made where the
    figures are.
    """

    def __init__(self, rows: "_Rows", engine: str):
        self.rows, self.engine = rows, engine

    def cases(self, ids) -> List[Case]:
        return [self.rows.prep.case_at(i) for i in ids]

    def failed(self, ids, exc) -> bytes:
        cases = self.cases(ids)
        return part_bytes(self.rows.columns(cases, _failed_rows(cases, exc)), self.rows.schema)

    def __call__(self, ids) -> bytes:
        cases = self.cases(ids)
        try:
            figures = run_engine(self.engine, cases)
        except (BodyvibError, ArithmeticError, ValueError, MemoryError, LinAlgError) as exc:
            figures = _failed_rows(cases, exc)  # the task's own failure: its cases failed
        return part_bytes(self.rows.columns(cases, figures), self.rows.schema)


def _run_work(work: _Work, ids) -> bytes:
    """A sweep task on a worker."""
    return work(ids)


def _failed_rows(task, exc):
    msg = f"task failed: {type(exc).__name__}: {exc}"
    return [{"error": msg} for _ in task]


def _spec_inputs(spec: dict, spec_path: Optional[str]):
    """(option, path) of the files a sweep reads: its spec and the model files it names."""
    inputs = [("SPEC", spec_path)] if spec_path else []
    for key in ("body", "car"):
        entries = spec.get(key, [])
        for e in entries if isinstance(entries, list) else [entries]:
            src = e.get("model") if isinstance(e, dict) else e
            if isinstance(src, str) and os.path.isfile(src):
                inputs.append((f"spec {key}", src))
    return inputs


@dataclass(frozen=True)
class SweepSettings:
    """How a sweep runs and where it writes: every option of :func:`run_sweep` but the spec.

    Parameters
    ----------
    out : str, optional
        Parquet file for the table (also the key of ``resume``); None keeps
        the table in memory (and in ``csv``) only.
    engine : str
        ``"batched"`` (default), ``"spectral"`` or ``"cosim"``.
    scheduler : str, optional
        None or ``"local"``: a LocalCluster of ``workers`` single-threaded
        processes (None: in this process when all cases make one task);
        ``"serial"``: in this process, no Dask; otherwise the address of a
        running Dask scheduler (``tcp://host:8786``), whose workers must have
        bodyvib installed.
    scheduler_file : str, optional
        Connect to the scheduler of this file instead (``dask scheduler
        --scheduler-file``, dask-jobqueue).
    workers : int, optional
        LocalCluster size (default: the number of cores).
    block : int, optional
        Cases per task (default: :func:`task_size`).
    resume : bool
        Keep the cases already in ``out`` (and its parts) and run the rest.
    retry_failed : bool
        With ``resume``: run again the cases stored with an error.
    overwrite : bool
        Replace an existing ``out`` instead of refusing.
    csv : str, optional
        Also write the table as CSV (header ``name [unit]``).
    progress : bool or callable
        A progress bar and the status lines on stderr (True), or the bar on stderr and
        each status line to a callable (:mod:`bodyvib.process.progress`).
    connect_timeout : float
        Seconds to wait for a scheduler to answer.
    worker_timeout : float
        Seconds to wait for a first worker, and the longest a running sweep
        goes on without any worker.
    table : bool
        Return the table (False: return None; the table is only on disk,
        which a million-case sweep needs).

    Examples
    --------
    >>> SweepSettings(engine="spectral", workers=2).check()
    >>> SweepSettings(retry_failed=True).check()
    Traceback (most recent call last):
    ...
    bodyvib.runtime.errors.BodyvibError: retry_failed=True needs resume=True
    """

    out: Optional[str] = None
    engine: str = "batched"
    scheduler: Optional[str] = None
    scheduler_file: Optional[str] = None
    workers: Optional[int] = None
    block: Optional[int] = None
    resume: bool = False
    retry_failed: bool = False
    overwrite: bool = False
    csv: Optional[str] = None
    progress: Progress = False
    connect_timeout: float = 10.0
    worker_timeout: float = 60.0
    table: bool = True

    def check(self) -> None:
        """Refuse settings that contradict each other or are out of range.

        Raises
        ------
        BodyvibError
            Naming the setting and what it takes.
        """
        if self.resume and self.overwrite:
            raise BodyvibError(
                "resume=True keeps the cases in 'out' and overwrite=True replaces it: give one "
                "of them",
                parameters=("resume", "out", "overwrite"),
            )
        w = self.workers
        if w is not None and (isinstance(w, bool) or not isinstance(w, int) or w < 1):
            raise BodyvibError(
                f"'workers' must be a positive integer, got {w!r}", parameters=("workers",)
            )
        for name in ("connect_timeout", "worker_timeout"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0 < value < math.inf):
                raise BodyvibError(
                    f"{name} must be a positive number of seconds, got {value!r}",
                    parameters=(name,),
                )
        if self.retry_failed and not self.resume:
            raise BodyvibError(
                "retry_failed=True needs resume=True", parameters=("retry_failed", "resume")
            )
        if self.resume and self.out is None:
            raise BodyvibError(
                "resume=True needs an output file ('out')", parameters=("resume", "out")
            )
        if self.out is None and self.csv is None and not self.table:
            raise BodyvibError(
                "give an output file ('out' and/or 'csv')", parameters=("out", "csv")
            )

    @property
    def threads(self) -> int:
        """LocalCluster size: ``workers``, else the number of cores."""
        return self.workers or os.cpu_count() or 1


@renamed_parameters(echo="progress")
def run_sweep(
    spec: Union[dict, str],
    settings: Optional[SweepSettings] = None,
    **options,
):
    """Run a sweep and return its table.

    Parameters
    ----------
    spec : dict or str
        A spec (:mod:`bodyvib.vehicle.sweep.spec`) or the path of a JSON spec.
    settings : SweepSettings, optional
        How to run it and where to write (defaults: batched engine, in memory,
        on a LocalCluster when the cases make more than one task).
    **options
        Fields of :class:`SweepSettings` that replace those of ``settings``
        (``out="r.parquet", scheduler="serial"``, ``progress=print``). The old keyword
        ``echo`` (a callable for the status lines) still works for one release as
        ``progress``, with a ``DeprecationWarning``.

    Returns
    -------
    pandas.DataFrame or None
        One row per case, sorted by ``case_id`` (columns in the module
        docstring); None with ``table=False``.

    Raises
    ------
    BodyvibError
        A bad spec, engine or setting (``resume`` with ``overwrite`` among them); an
        ``out`` not ending in ``.parquet``; an output that exists (without ``resume`` or
        ``overwrite``), cannot be written, or is one of the sweep's inputs; an output of
        another spec on resume; an unreachable scheduler or no worker in time.
    bodyvib.process.extras.MissingExtraError
        The sweep extra is not installed.
    bodyvib.vehicle.sweep.cluster.ClusterLost
        The cluster lost tasks (scheduler gone, workers dead, no worker): the
        finished cases are kept in ``OUT.parts/``, the lost ones are not
        written, and ``resume`` runs them.
    KeyboardInterrupt
        Ctrl-C: the finished tasks are kept in ``OUT.parts/`` (``resume``
        continues), ``out`` and ``csv`` are left as they were.

    Examples
    --------
    >>> df = run_sweep({"road": "C", "speed": [10, 20], "duration": 2,
    ...                 "body": "reduced-paper"}, scheduler="serial")
    >>> list(df["speed"]), bool(df["head_weighted_rms"].gt(0).all())
    ([10.0, 20.0], True)
    """
    extras.require("a sweep", "sweep")
    try:
        cfg = replace(settings or SweepSettings(), **options)
    except TypeError as exc:
        raise BodyvibError(f"run_sweep: {exc} (the options are SweepSettings' fields)") from None
    say = progress_lines(cfg.progress)
    spec, spec_path = _load(spec)
    prep = _Prepared(spec, counted=lambda count: _start_workers_early(cfg, count))
    check_engine(cfg.engine, [_RoadOnly(r) for r in prep.roads])
    cfg.check()
    check_outputs(
        [("out", cfg.out, PARQUET_EXTENSIONS), ("csv", cfg.csv, None)],
        _spec_inputs(spec, spec_path),
    )
    sh = spec_hash(spec)
    done = _done_cases(cfg, prep.count, sh)
    run_id = uuid.uuid4().hex[:12]
    rows = _Rows(prep, cfg.engine, sh, run_id)
    schema = rows.schema.with_metadata(
        {**provenance(spec, cfg.engine), "bodyvib.units": json.dumps(units(rows.schema))}
    )
    replaces = cfg.out is not None and cfg.overwrite and not cfg.resume
    if replaces:
        shutil.rmtree(parts_dir(cfg.out), ignore_errors=True)
    folder = (
        parts_dir(cfg.out)
        if cfg.out is not None
        else tempfile.mkdtemp(prefix="bodyvib-sweep-parts-")
    )
    parts = _Parts(folder, replaces, _Work(rows, cfg.engine), run_id)
    try:
        _compute(cfg, prep, done, parts, say)
        return _finish(cfg, folder, schema, say)
    finally:
        parts.close()
        if cfg.out is None:
            shutil.rmtree(folder, ignore_errors=True)


def _load(spec) -> tuple:
    """(spec dict, its file or None)."""
    if isinstance(spec, (str, os.PathLike)):
        path = os.fspath(spec)
        return load_spec(path), path
    return spec, None


def _done_cases(cfg: SweepSettings, count: int, sh: str) -> np.ndarray:
    """Per case, True if kept from an earlier run (``resume``); refuse an output in the way."""
    done = np.zeros(count, dtype=bool)
    out = cfg.out
    if out is None:
        return done
    if cfg.resume:
        found = scan(out)
        if found.rows:
            other = sorted(found.spec_hashes - {sh})
            if other:
                raise BodyvibError(
                    f"'{out}' holds rows of another spec (hash {other[0]}, "
                    f"this spec {sh}); use another output file"
                )
            done = found.done(count, cfg.retry_failed)
    elif (os.path.exists(out) or os.path.isdir(parts_dir(out))) and not cfg.overwrite:
        raise BodyvibError(
            f"output '{out}' exists; pass resume=True to continue that sweep or "
            "overwrite=True to replace it",
            parameters=("resume", "overwrite"),
        )
    return done


class _Parts:
    """Where finished tasks go: one Parquet part each in ``folder``, a progress bar."""

    def __init__(self, folder: str, replaces: bool, work: _Work, run_id: str):
        self.folder, self.replaces, self.work, self.run_id = folder, replaces, work, run_id
        self.start_ns = time.time_ns()
        self.bar = None

    def open_bar(self, total: int, todo: int) -> None:
        # off a terminal (a log), a line every 10 s: a sweep may run for hours
        self.bar = progress_bar(total, True, "sweep", "case", total - todo, 10.0, leave=True)

    def arrived(self, task_no: int, ids, data) -> None:
        """Write a task's rows (or, for a task that raised, failed rows for its cases)."""
        marker = os.path.join(self.folder, REPLACES_OUT)
        if self.replaces and not os.path.exists(marker):
            # until the table is written, the parts are the sweep and OUT is not
            atomic_write_bytes(marker, b"")
        if isinstance(data, BaseException):  # the task raised by itself
            data = self.work.failed(ids, data)
        write_part(self.folder, part_name(self.start_ns, self.run_id, task_no), data)
        if self.bar is not None:
            self.bar.update(len(ids))

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def _pending(prep: _Prepared, done: np.ndarray, engine: str) -> Iterator[int]:
    """Case numbers to run, lazily: consecutive cases of one road (batched) or of one model
    (spectral and cosim: one frequency response, one FMU build per task)."""
    return (k for k in prep.order(body_major=engine != "batched") if not done[k])


def _tasks(prep: _Prepared, done: np.ndarray, engine: str, size: int) -> Iterator[np.ndarray]:
    return (np.array(ids, dtype=np.int64) for ids in plan_tasks(_pending(prep, done, engine), size))


def _in_process(cfg: SweepSettings, todo: int) -> bool:
    """Run here without Dask: asked for, or (default scheduler) all cases make one task."""
    if cfg.scheduler == "serial":
        return True
    return (
        cfg.scheduler is None
        and cfg.scheduler_file is None
        and todo <= task_size(cfg.engine, todo, cfg.threads, cfg.block)
    )


def _start_workers_early(cfg: SweepSettings, count: int) -> None:
    """Start the server a LocalCluster's workers fork from, when the sweep will run on one.

    Called once the spec's cases are counted, before its bodies are sampled (a Latin
    hypercube imports scipy.stats, 0.3-0.5 s) and its outputs checked: the server's
    imports and warm-up (about 0.8 s of CPU) run beside them on another core.
    """
    if _local_cluster(cfg) and not _in_process(cfg, count):
        start_server()


def _local_cluster(cfg: SweepSettings) -> bool:
    """Whether a sweep that runs on Dask runs on its own LocalCluster (no scheduler named)."""
    return cfg.scheduler in (None, "local") and cfg.scheduler_file is None


def _compute(
    cfg: SweepSettings, prep: _Prepared, done: np.ndarray, parts: _Parts, say: Callable[[str], None]
) -> None:
    """Run the pending cases, here or on Dask, each task written as it arrives."""
    total = prep.count
    todo = total - int(done.sum())
    if not todo:
        say(f"sweep: {total} cases, {total} already done, 0 to run")
        return
    if cfg.progress:
        parts.open_bar(total, todo)
    if _in_process(cfg, todo):
        size = task_size(cfg.engine, todo, 1, cfg.block)
        say(
            f"sweep: {total} cases, {total - todo} already done, {todo} to run in "
            f"{math.ceil(todo / size)} tasks, engine {cfg.engine}, in this process"
        )
        for i, ids in enumerate(_tasks(prep, done, cfg.engine, size)):
            parts.arrived(i, ids, parts.work(ids))
            interrupts.check()  # Ctrl-C: stop between tasks, keep what arrived
    else:
        _on_cluster(cfg, prep, done, parts, say, total, todo)
    parts.close()


def _on_cluster(
    cfg: SweepSettings,
    prep: _Prepared,
    done: np.ndarray,
    parts: _Parts,
    say: Callable[[str], None],
    total: int,
    todo: int,
) -> None:
    """Run the pending cases on Dask (a LocalCluster or a running scheduler)."""
    with open_cluster(
        None if _local_cluster(cfg) else cfg.scheduler,
        cfg.scheduler_file,
        cfg.threads,
        cfg.connect_timeout,
        cfg.worker_timeout,
        meanwhile=_table_imports,
    ) as cluster:
        threads = cluster.threads(cfg.connect_timeout)
        size = task_size(cfg.engine, todo, threads, cfg.block)
        window = max(2, 2 * threads)  # one running and one waiting per thread
        say(
            f"sweep: {total} cases, {total - todo} already done, {todo} to run in "
            f"{math.ceil(todo / size)} tasks, engine {cfg.engine}, {cluster.where} "
            f"({threads} threads)"
        )
        try:
            run_tasks(
                cluster,
                _run_work,
                _tasks(prep, done, cfg.engine, size),
                window,
                parts.arrived,
                cfg.worker_timeout,
                cfg.connect_timeout,
                shared=parts.work,
            )
        except ClusterLost as exc:
            where = (
                f"kept in {parts.folder}/: run again with resume=True"
                if cfg.out is not None
                else "lost (no 'out')"
            )
            raise ClusterLost(
                f"{exc}; the sweep is incomplete, the cases finished are {where}",
                parameters=exc.parameters + ("resume", "out"),
            ) from None


def _table_imports() -> None:
    """Import what this process makes the table with (run while a cluster's workers start)."""
    import pandas  # noqa: F401
    import pyarrow.parquet  # noqa: F401


def _finish(cfg: SweepSettings, folder: str, schema, say: Callable[[str], None]):
    """Stream the parts into ``out`` and ``csv`` (all or none), drop them, return the table."""
    out = cfg.out
    found = scan(out, folder)
    try:
        with staged_writes(guard=interrupts.critical), _open(out) as fout, _open(cfg.csv) as fcsv:
            n = assemble(found, schema, fout, fcsv, interrupts.check)
    except OSError as exc:
        kept = f"; the finished cases are kept in {folder}/ (resume=True)" if out else ""
        raise BodyvibError(
            f"cannot write '{exc.filename}': {exc.strerror or exc}{kept}", parameters=("resume",)
        ) from None
    if out is not None:
        shutil.rmtree(folder, ignore_errors=True)
    failed = found.failed()
    say(
        f"sweep: {n} cases"
        + (
            f", {failed} failed (see the error column; resume=True with retry_failed=True "
            "runs them again)"
            if failed
            else ""
        )
        + (f"; wrote {out}" if out else "")
    )
    if not cfg.table:
        return None
    import pandas as pd

    return pd.read_parquet(out) if out is not None else _read_folder(found, schema)


class _RoadOnly:
    """What :func:`check_engine` looks at: a case's road."""

    def __init__(self, road):
        self.road = road


def _open(path):
    import contextlib

    return open_staged(path, "wb") if path is not None else contextlib.nullcontext()


def _read_folder(found, schema):
    import io

    import pyarrow.parquet as pq

    buf = io.BytesIO()
    assemble(found, schema, out_file=buf)
    buf.seek(0)
    return pq.read_table(buf).to_pandas()
