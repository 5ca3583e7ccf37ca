"""Warm a process for sweeps: import the engines and load the compiled time loop once.

A sweep's first task on a fresh Dask worker pays for importing the engines (numpy
aside: the models, the road synthesis, the Wk filter), for numba and for loading
the compiled time loop from numba's cache. A cluster kept between sweeps pays
that once, at the worker's start, when the worker preloads this module:

.. code-block:: console

    $ dask scheduler --scheduler-file sched.json &
    $ dask worker --scheduler-file sched.json --nworkers 2 --nthreads 1 \\
          --preload bodyvib.vehicle.sweep.preload &
    $ bodyvib sweep --scheduler-file sched.json --grid ... --out a.parquet
    $ bodyvib sweep --scheduler-file sched.json --grid ... --out b.parquet

Dask calls :func:`dask_setup` in each worker as it starts; :func:`warm` does the
same in any process.
"""

import time

__all__ = ["warm", "dask_setup"]


def warm() -> float:
    """Import the sweep engines and run the batched engine once on one short case (1 s).

    Returns
    -------
    float
        Seconds it took (wall clock).

    Examples
    --------
    >>> warm() >= 0.0
    True
    """
    t0 = time.perf_counter()
    from . import engines, run  # noqa: F401  (the modules a task unpickles into)
    from .spec import expand
    from .table import part_bytes, table_schema

    # one second on a random road, as a task runs it: the model files, the road
    # synthesis's transform, the exact discretization, the compiled loop (numba's
    # cache) and the BLAS thread limits; then its figures as a Parquet part
    case = expand({"road": "C", "speed": 10, "duration": 1, "body": "reduced-paper"})
    figures = engines.run_engine("batched", case)
    schema = table_schema({}, {}, engines.FIGURES)
    part_bytes({f.name: [figures[0].get(f.name)] for f in schema}, schema)
    return time.perf_counter() - t0


def dask_setup(worker=None) -> None:
    """Dask's preload hook (``dask worker --preload bodyvib.vehicle.sweep.preload``)."""
    warm()
