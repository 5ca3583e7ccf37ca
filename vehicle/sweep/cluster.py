"""Running sweep tasks on Dask: connecting with time limits, a bounded window, lost tasks.

:func:`open_cluster` starts a :class:`distributed.LocalCluster` (its worker
processes start with SIGINT blocked, so a terminal's Ctrl-C, sent to the whole
process group, reaches only the command, which shuts them down) or connects to
a running scheduler (an address ``tcp://host:port`` or a scheduler file, as
written by ``dask scheduler --scheduler-file`` and dask-jobqueue), waiting at
most ``connect_timeout`` seconds for the scheduler and ``worker_timeout``
seconds for a first worker. :func:`run_tasks` keeps a bounded number of tasks
in flight (:class:`distributed.as_completed`, refilled as tasks finish) and
reports each task's fate: finished, or *lost* -- cancelled because the
scheduler went away, or given up after its workers died
(:class:`distributed.KilledWorker`), or stalled for ``worker_timeout`` seconds
with no worker. A lost task is not a failed case: its cases are run again by
``--resume``. Every blocking call of the client runs in a helper thread while
the main thread waits for it in short slices, so that Ctrl-C is taken at once.
distributed's own loggers are silenced while a sweep runs: the command reports
in one line.
"""

import contextlib
import logging
import multiprocessing
import os
import shutil
import tempfile
import threading
import time
import warnings
from dataclasses import dataclass
from typing import Callable, Iterator, Optional

from bodyvib.process import interrupts
from bodyvib.runtime.errors import BodyvibError

__all__ = ["ClusterLost", "Cluster", "open_cluster", "run_tasks", "check_address", "start_server"]

_QUIET = ("distributed", "tornado", "asyncio", "bokeh")


class ClusterLost(BodyvibError):
    """The cluster could not run (all of) the tasks; the cases not done are kept for ``--resume``."""


def check_address(address: str) -> str:
    """Refuse a scheduler address without a protocol (``host:8786`` for ``tcp://host:8786``).

    Parameters
    ----------
    address : str
        ``--scheduler`` as given: a Dask scheduler address with its protocol, e.g.
        ``tcp://10.0.0.5:8786``.

    Returns
    -------
    str
        ``address``, unchanged.

    Raises
    ------
    BodyvibError
        No ``://`` in it; the message names the ``tcp://`` form to write.

    Examples
    --------
    >>> check_address("tcp://127.0.0.1:8786")
    'tcp://127.0.0.1:8786'
    """
    if "://" not in address:
        raise BodyvibError(
            f"scheduler='{address}' has no protocol: write it as "
            f"tcp://{address} (or 'serial', or leave it out for a LocalCluster)",
            parameters=("scheduler",),
        )
    return address


class _Silence(logging.Filter):
    """Drops every record of distributed (and the libraries under it) while a sweep runs."""

    def filter(self, record):
        return record.name.split(".")[0] not in _QUIET


@contextlib.contextmanager
def _quiet_logs():
    # distributed configures a level and a handler per named logger; a filter on
    # every handler of those loggers (and of the root) drops their records wherever
    # they propagate, including loggers created while the sweep runs
    silence = _Silence()
    filtered = []

    def cover():
        names = [n for n in logging.root.manager.loggerDict if n.split(".")[0] in _QUIET]
        for lg in [logging.getLogger(n) for n in names] + [logging.getLogger()]:
            for h in lg.handlers:
                if silence not in h.filters:
                    h.addFilter(silence)
                    filtered.append(h)

    cover()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield cover
    finally:
        cover()
        for h in filtered:
            h.removeFilter(silence)


def _call(fn: Callable, timeout: float, what: str, interruptible: bool = True):
    """``fn()`` in a helper thread; the main thread takes Ctrl-C while it waits.

    Raises the call's exception, ``KeyboardInterrupt``, or ``TimeoutError`` after
    ``timeout`` seconds (the thread is then left to end by itself).
    """
    box = {}

    def target():
        try:
            box["value"] = fn()
        except BaseException as exc:  # handed to the caller
            box["error"] = exc

    t = threading.Thread(target=target, name=f"bodyvib-sweep-{what}", daemon=True)
    t.start()
    t_end = time.monotonic() + timeout
    while t.is_alive():
        if interruptible:
            interrupts.check()
        left = t_end - time.monotonic()
        if left <= 0:
            raise TimeoutError(f"{what}: no answer in {timeout:g} s")
        t.join(min(0.05, left))
    if interruptible:
        interrupts.check()
    if "error" in box:
        raise box["error"]
    return box.get("value")


@contextlib.contextmanager
def _workers_ignore_sigint(folder: str):
    """Worker processes spawned in the block start with SIGINT ignored.

    A terminal's Ctrl-C goes to the whole process group: workers that took it
    died with tracebacks or "Nanny failed to start". multiprocessing spawns them
    through a two-line shell script that ignores SIGINT and executes Python (an
    ignored signal stays ignored across exec, and Python then installs no
    KeyboardInterrupt handler); the command alone takes the Ctrl-C and shuts
    the cluster down.
    """
    import multiprocessing.spawn as mp_spawn
    import shlex

    exe = mp_spawn.get_executable()
    wrapper = os.path.join(folder, "python-ignoring-sigint")
    with open(wrapper, "w") as f:
        f.write(f"#!/bin/sh\ntrap '' INT\nexec {shlex.quote(os.fsdecode(exe))} \"$@\"\n")
    os.chmod(wrapper, 0o700)
    mp_spawn.set_executable(wrapper)
    try:
        yield
    finally:
        mp_spawn.set_executable(exe)


@dataclass
class Cluster:
    """A connected client and what to close with it.

    Attributes
    ----------
    client : distributed.Client
    where : str
        For messages (``"LocalCluster of 2 workers"``, the scheduler's address).
    """

    client: object
    where: str
    local: object = None
    scratch: Optional[str] = None
    spawn: Optional[contextlib.ExitStack] = None

    def threads(self, timeout: float) -> int:
        """Total worker threads now (0: no worker)."""
        return sum(_call(self.client.nthreads, timeout, "ask the scheduler").values())

    def close(self) -> None:
        """Close the client (and the LocalCluster), bounded in time, whatever state they are in."""
        with interrupts.critical():
            with contextlib.suppress(BaseException):
                _call(lambda: self.client.close(timeout=5), 10, "close the client", False)
            if self.local is not None:
                with contextlib.suppress(BaseException):
                    _call(lambda: self.local.close(timeout=10), 15, "close the LocalCluster", False)
            if self.spawn is not None:
                self.spawn.close()
            if self.scratch is not None:
                shutil.rmtree(self.scratch, ignore_errors=True)


@contextlib.contextmanager
def open_cluster(
    scheduler: Optional[str] = None,
    scheduler_file: Optional[str] = None,
    workers: int = 1,
    connect_timeout: float = 10.0,
    worker_timeout: float = 60.0,
    meanwhile: Optional[Callable[[], None]] = None,
) -> Iterator[Cluster]:
    """A Dask client for a sweep, with at least one worker; closed when the block ends.

    Parameters
    ----------
    scheduler : str, optional
        None or ``"local"``: a LocalCluster of ``workers`` single-threaded
        processes; otherwise a scheduler address ``tcp://host:port``.
    scheduler_file : str, optional
        A scheduler file (``dask scheduler --scheduler-file``, dask-jobqueue).
    workers : int
        LocalCluster size.
    connect_timeout : float
        Seconds to wait for the scheduler.
    worker_timeout : float
        Seconds to wait for a first worker.
    meanwhile : callable, optional
        This process's own preparation (imports for the results), called once: for a
        LocalCluster while its workers' fork server warms up on another core, else
        before connecting.

    Yields
    ------
    Cluster

    Raises
    ------
    BodyvibError
        An address without protocol, an unreachable scheduler, no worker in time.
    KeyboardInterrupt
        Ctrl-C while waiting.
    """
    with _quiet_logs() as cover:
        cluster = _start(scheduler, scheduler_file, workers, connect_timeout, meanwhile)
        cover()  # the loggers the client made
        try:
            t_end = time.monotonic() + worker_timeout
            while True:
                try:
                    if cluster.threads(connect_timeout) > 0:
                        break
                except (KeyboardInterrupt, BodyvibError):
                    raise
                except Exception as exc:
                    raise ClusterLost(
                        f"the Dask scheduler {cluster.where} stopped answering "
                        f"({type(exc).__name__})"
                    ) from None
                if time.monotonic() > t_end:
                    raise BodyvibError(
                        f"the Dask scheduler {cluster.where} has no worker after "
                        f"{worker_timeout:g} s (worker_timeout); start "
                        f"workers with 'dask worker {cluster.where}'",
                        parameters=("worker_timeout",),
                    )
                for _ in range(5):
                    interrupts.check()
                    time.sleep(0.05)
            yield cluster
        finally:
            cluster.close()


def _start(scheduler, scheduler_file, workers, connect_timeout, meanwhile=None) -> Cluster:
    if scheduler_file is None and scheduler in (None, "local"):
        return _local(workers, connect_timeout, meanwhile)  # distributed after its fork server
    if meanwhile is not None:
        meanwhile()
    if scheduler_file is not None:
        if not os.path.isfile(scheduler_file):
            raise BodyvibError(
                f"scheduler_file='{scheduler_file}' does not exist (start the Dask "
                "scheduler first: it writes that file)",
                parameters=("scheduler_file",),
            )
        where = f"of '{scheduler_file}'"
        kw = {"scheduler_file": scheduler_file}
    else:
        where = check_address(scheduler)
        kw = {"address": scheduler}
    from dask.distributed import Client

    try:
        client = _call(
            lambda: Client(timeout=f"{connect_timeout}s", **kw), connect_timeout + 5, "connect"
        )
    except (KeyboardInterrupt, BodyvibError):
        raise
    except Exception as exc:
        raise BodyvibError(
            f"cannot connect to the Dask scheduler {where} within "
            f"{connect_timeout:g} s (connect_timeout): "
            f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}",
            parameters=("connect_timeout",),
        ) from None
    return Cluster(client, where)


def _start_method() -> str:
    """How a LocalCluster starts its workers: ``forkserver`` where the system has it."""
    return "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"


def _tempdir_environ() -> dict:
    """The temporary-folder variables of this process (``TMPDIR``, ``TMP``, ``TEMP``)."""
    return {k: os.environ[k] for k in ("TMPDIR", "TMP", "TEMP") if k in os.environ}


#: What a sweep's fork server imports before it forks a worker.
_SERVER_PRELOAD = ("distributed", "bodyvib.vehicle.sweep.warmed")
#: The variables distributed.Nanny sets before it starts a worker process: its
#: ``distributed.nanny.pre-spawn-environ`` settings.
_PRE_SPAWN = "distributed.nanny.pre-spawn-environ"


def _preload_forkserver() -> None:
    """Keep the fork server's list: the warmed engines, not distributed's own list.

    distributed sets its list (distributed and the packages it reports, pandas among
    them) the first time it asks for the forkserver context, importing each of them in
    this process to see that it is there: 0.3-0.5 s of CPU at the cluster's start,
    for a list that the server started by :func:`_start_server` does not use. Marked
    as set, distributed leaves the list alone. Without effect with ``spawn``.
    """
    import dask
    import distributed.utils

    if dask.config.get("distributed.worker.multiprocessing-method") == "forkserver":
        if hasattr(distributed.utils, "_forkserver_preload_set"):
            distributed.utils._forkserver_preload_set = True
        multiprocessing.get_context("forkserver").set_forkserver_preload(list(_SERVER_PRELOAD))


def _start_server(config: dict) -> None:
    """Start the fork server at once, before this process imports distributed.

    The server otherwise starts with the first worker, after this process has
    imported distributed and started the scheduler: now its imports and warm-up run
    alongside those. It gets the environment the first worker would give it
    (:func:`_server_environ`). Returns at once; the first fork waits for the server.

    Parameters
    ----------
    config : dict
        The Dask settings the LocalCluster is made with (dotted keys).
    """
    import multiprocessing.forkserver

    multiprocessing.get_context("forkserver").set_forkserver_preload(list(_SERVER_PRELOAD))
    _server_folder()
    env = _server_environ(config)
    saved = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    try:
        multiprocessing.forkserver.ensure_running()
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _server_environ(config: dict) -> dict:
    """The variables distributed.Nanny sets in this process before it starts a worker.

    Its ``distributed.nanny.pre-spawn-environ`` settings: distributed's defaults (read
    from the file distributed loads them from, without importing distributed), then
    Dask's configuration and ``config``; a variable this process already has keeps its
    value, and the hash seed is fixed (``PYTHONHASHSEED=6640``) unless set, so that
    every worker hashes alike. A process reads these as it starts (glibc's malloc
    settings, the BLAS threads, the hash seed): the fork server must have them.

    Parameters
    ----------
    config : dict
        Dask settings with dotted keys (``distributed.nanny.pre-spawn-environ.X``).

    Returns
    -------
    dict
        Variable -> value (text).
    """
    import importlib.util

    import dask
    import yaml

    settings = {}
    spec = importlib.util.find_spec("distributed")
    for folder in (spec.submodule_search_locations if spec else None) or ():
        path = os.path.join(folder, "distributed.yaml")
        if os.path.isfile(path):
            with open(path) as f:  # libyaml's parser where there is one: 20 ms less
                defaults = yaml.load(f, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
            settings.update(defaults["distributed"]["nanny"]["pre-spawn-environ"] or {})
    settings.update(dask.config.get(_PRE_SPAWN, default=None) or {})
    prefix = _PRE_SPAWN + "."
    settings.update({k[len(prefix) :]: v for k, v in config.items() if k.startswith(prefix)})
    env = {k: os.environ.get(k, str(v)) for k, v in settings.items() if v is not None}
    if env.get("PYTHONHASHSEED") in (None, "0"):
        env["PYTHONHASHSEED"] = "6640"
    return env


def _server_folder() -> None:
    """Make multiprocessing's folder (the fork server's socket) in the system's folder.

    The fork server lives as long as this process: beyond a command's private temporary
    folder (:func:`bodyvib.process.scratch.private_tempdir`), which is removed when the
    command ends, while multiprocessing removes its own folder when the process exits.
    """
    import multiprocessing.util

    for folder in ("/tmp", "/var/tmp"):
        if os.path.isdir(folder) and os.access(folder, os.W_OK | os.X_OK):
            break
    else:
        return
    saved = tempfile.tempdir
    tempfile.tempdir = folder
    try:
        multiprocessing.util.get_temp_dir()  # made once, kept for the process
    finally:
        tempfile.tempdir = saved


def _local_config(scratch: Optional[str] = None) -> dict:
    """The Dask settings of a sweep's LocalCluster (dotted keys); ``scratch``: its folder.

    Dask's workers return freed memory to the system at once (glibc
    MALLOC_TRIM_THRESHOLD_ = 64 kB), and setting the trim threshold also fixes
    glibc's mmap threshold at 128 kB (it is dynamic, up to 32 MB, only while
    neither is set): every large buffer of a task (road samples, packed
    matrices) would be mapped and faulted in afresh, task after task. Both set
    high; the fork server starts with these variables (:func:`_server_environ`).
    Each worker's statistical profiler samples the running task's stack every
    10 ms for a dashboard that a sweep's LocalCluster does not have: off.
    The workers fork from one server process that has imported and warmed the
    engines (:mod:`bodyvib.vehicle.sweep.warmed`) instead of each starting Python
    afresh.
    """
    config = {
        "distributed.worker.multiprocessing-method": _start_method(),
        "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": 128 * 1024 * 1024,
        "distributed.nanny.pre-spawn-environ.MALLOC_MMAP_THRESHOLD_": 32 * 1024 * 1024,
        "distributed.worker.profile.enabled": False,
        # a forked worker has the fork server's environment: set this command's
        # temporary folder in each worker as it starts
        **{f"distributed.nanny.environ.{k}": v for k, v in _tempdir_environ().items()},
    }
    if scratch is not None:
        config["temporary-directory"] = scratch
    return config


def start_server() -> None:
    """Start the fork server of a sweep's LocalCluster workers now, ahead of the cluster.

    The server imports and warms the engines before its first fork (about 0.8 s of
    CPU). Started while this process still prepares a sweep (samples the bodies,
    checks the outputs), that runs beside the preparation on another core; the
    cluster then finds it running. Idempotent, and without effect where the workers
    are spawned instead of forked or outside the main thread. The server starts with
    SIGINT ignored (the workers it forks inherit that), so that a terminal's Ctrl-C,
    sent to the whole process group, reaches only the command, which shuts the
    cluster down.

    Examples
    --------
    >>> start_server()  # doctest: +SKIP
    """
    import signal

    config = _local_config()
    if config["distributed.worker.multiprocessing-method"] != "forkserver":
        return
    if threading.current_thread() is not threading.main_thread():
        return  # only the main thread sets handlers: the cluster starts the server
    # SIGINT ignored while the server is spawned: a process starts with the handling it
    # inherits (an ignored signal stays ignored across exec, and Python then installs no
    # KeyboardInterrupt handler); a blocked signal would not do, the server's start
    # unblocks it. A Ctrl-C in these few milliseconds is lost; the next one is taken.
    handler = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        _start_server(config)
    finally:
        signal.signal(signal.SIGINT, handler)


def _local(workers, connect_timeout, meanwhile=None) -> Cluster:
    scratch = tempfile.mkdtemp(prefix="bodyvib-sweep-dask-")
    try:
        # the server starts first (unless start_server has), its warm-up alongside this
        # process's import of distributed and the scheduler's start
        config = _local_config(scratch)
        spawn = contextlib.ExitStack()  # until the cluster is closed (a worker may restart)
        spawn.enter_context(_workers_ignore_sigint(scratch))
        if config["distributed.worker.multiprocessing-method"] == "forkserver":
            _start_server(config)
        if meanwhile is not None:
            meanwhile()
        import dask
        from dask.distributed import Client, LocalCluster

        # a second Ctrl-C waits too: a cluster half started would leave its workers behind
        with dask.config.set(config), interrupts.critical():
            _preload_forkserver()
            local = LocalCluster(
                n_workers=workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.CRITICAL + 1,
                local_directory=scratch,
            )
            try:
                client = Client(local, timeout=f"{max(connect_timeout, 10)}s")
            except BaseException:
                local.close()
                raise
    except BaseException as exc:
        if "spawn" in locals():
            spawn.close()
        shutil.rmtree(scratch, ignore_errors=True)
        if isinstance(exc, (KeyboardInterrupt, BodyvibError)):
            raise
        raise BodyvibError(
            f"cannot start a LocalCluster of {workers} workers: {type(exc).__name__}: {exc}"
        ) from None
    return Cluster(client, f"LocalCluster of {workers} workers", local, scratch, spawn)


def _lost_reason(fut) -> Optional[str]:
    """Why a finished future's task was lost to the cluster (None: it ran)."""
    from distributed import KilledWorker

    if fut.status == "cancelled":
        return "cancelled by the cluster (scheduler connection lost?)"
    if fut.status == "error":
        exc = fut.exception()
        if isinstance(exc, KilledWorker):
            return "its workers died (KilledWorker)"
        if type(exc).__module__.split(".")[0] in ("distributed", "tornado") or isinstance(
            exc, (OSError, TimeoutError)
        ):
            return f"{type(exc).__name__}"
    return None


def run_tasks(
    cluster: Cluster,
    fn,
    tasks: Iterator,
    window: int,
    on_result: Callable,
    worker_timeout: float = 60.0,
    connect_timeout: float = 10.0,
    shared=None,
) -> int:
    """Run ``fn(shared, task)`` for every task with at most ``window`` in flight.

    ``on_result(task_no, task, value)`` gets each task that ran (``value`` the
    exception for a task that raised by itself). Submission stops at the first
    lost task; the ones in flight are drained.

    Parameters
    ----------
    cluster : Cluster
    fn : callable
        Submitted as ``fn(shared, task)`` (``pure=False``).
    tasks : iterator
        The tasks, made lazily.
    window : int
        Tasks in flight at most.
    on_result : callable
    worker_timeout : float
        A run with no worker for this many seconds stops (its tasks lost).
    connect_timeout : float
        Seconds a scheduler may take to answer.
    shared : object
        Sent to every worker once (``Client.scatter``), the first argument of ``fn``.

    Returns
    -------
    int
        0 (all tasks ran).

    Raises
    ------
    ClusterLost
        Tasks were lost (their cases are not reported).
    """
    from distributed import as_completed

    client = cluster.client
    ac = as_completed()
    meta = {}
    state = {"task_no": 0, "exhausted": False}
    try:
        ref = _call(
            lambda: client.scatter(shared, broadcast=True, hash=False),
            connect_timeout + 60,
            "send the spec to the workers",
        )
    except (KeyboardInterrupt, BodyvibError):
        raise
    except Exception as exc:
        raise ClusterLost(
            f"the spec could not be sent to the workers ({type(exc).__name__})"
        ) from None

    def submit():
        while not state["exhausted"] and ac.count() < window:
            try:
                task = next(tasks)
            except StopIteration:
                state["exhausted"] = True
                return
            fut = client.submit(fn, ref, task, pure=False)
            meta[fut.key] = (state["task_no"], task)
            ac.add(fut)
            state["task_no"] += 1

    try:
        return _run(
            client, cluster, ac, meta, submit, on_result, worker_timeout, connect_timeout, state
        )
    except _ResultError as exc:  # writing a result failed: that error, as it is
        raise exc.__cause__ from None
    except (KeyboardInterrupt, BodyvibError):
        raise
    except Exception as exc:  # the client library failed: the tasks in flight are lost
        _cancel(client, ac)
        raise ClusterLost(
            f"{ac.count() or 'some'} task(s) lost: the Dask client failed "
            f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})"
        ) from None


def _cancel(client, ac):
    futures = list(ac.futures)
    with contextlib.suppress(BaseException):
        _call(lambda: client.cancel(futures, force=True), 5, "cancel", False)


class _ResultError(Exception):
    """An exception of ``on_result`` (not the cluster's), carried out of the client code."""


def _run(client, cluster, ac, meta, submit, on_result, worker_timeout, connect_timeout, state):
    lost = 0
    reason = None
    submit()
    last_worker = time.monotonic()
    last_look = 0.0
    while not ac.is_empty():
        interrupts.check()
        if ac.has_ready():
            for fut in ac.next_batch(block=False):
                no, task = meta.pop(fut.key)
                why = _lost_reason(fut)
                if why is not None:
                    lost += 1
                    reason = reason or why
                    state["exhausted"] = True  # the cluster is failing: submit nothing more
                    continue
                value = fut.exception() if fut.status == "error" else fut.result()
                fut.release()
                try:
                    on_result(no, task, value)
                except Exception as exc:
                    raise _ResultError() from exc
            if reason is None:
                submit()
            continue
        if client.status != "running":  # the scheduler went away
            reason = reason or "the connection to the scheduler was lost"
            lost += ac.count()
            break
        now = time.monotonic()
        if now - last_look > 1.0:
            last_look = now
            try:
                threads = cluster.threads(connect_timeout)
            except (KeyboardInterrupt, BodyvibError):
                raise
            except Exception:
                threads = -1
            if threads > 0:
                last_worker = now
            elif threads < 0 or now - last_worker > worker_timeout:
                reason = (
                    "the scheduler stopped answering"
                    if threads < 0
                    else f"no Dask worker for {worker_timeout:g} s (worker_timeout)"
                )
                lost += ac.count()
                break
        time.sleep(0.02)
    if lost:
        _cancel(client, ac)
        raise ClusterLost(f"{lost} task(s) lost: {reason}", parameters=("worker_timeout",))
    return 0
