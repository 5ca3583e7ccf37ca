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
    """Import the sweep engines and run the compiled time loop once on one tiny case.

    Returns
    -------
    float
        Seconds it took (wall clock).

    Examples
    --------
    >>> warm() >= 0.0
    True
    """
    import numpy as np

    t0 = time.perf_counter()
    from ..road.synthetic import _czt_class
    from . import engines, run  # noqa: F401  (the modules a task unpickles into)
    from .kernel import advance

    _czt_class()  # the road synthesis's transform

    M = np.zeros((1, 3, 1))
    g = np.zeros((1, 3))
    advance(
        M,
        g,
        g,
        np.zeros((1, 2)),
        np.zeros((1, 2)),
        np.zeros(1, np.int64),
        np.zeros((1, 1)),
        0,
        np.empty((2, 1, 2)),
    )
    return time.perf_counter() - t0


def dask_setup(worker=None) -> None:
    """Dask's preload hook (``dask worker --preload bodyvib.vehicle.sweep.preload``)."""
    warm()
