"""Sweeps: a study's cases (roads x seeds x speeds x bodies x cars) run on Dask.

:mod:`~bodyvib.vehicle.sweep.spec` expands a specification into cases,
:mod:`~bodyvib.vehicle.sweep.engines` computes a block of cases (batched exact steps
compiled in :mod:`~bodyvib.vehicle.sweep.kernel`, the spectral expectation, or real
co-simulations), :mod:`~bodyvib.vehicle.sweep.run` cuts the cases into tasks and runs
them (on Dask through :mod:`~bodyvib.vehicle.sweep.cluster`), :mod:`~bodyvib.vehicle.sweep.table`
writes the parts and the final table with units and provenance, :mod:`~bodyvib.vehicle.sweep.plot`
draws comfort maps. Names are imported from their module on first use (Dask is
loaded only by a sweep).

Import from the package (``from bodyvib.vehicle.sweep import run_sweep``): the names in ``__all__``
are its public interface, and the modules that hold them are internal and may move.
"""

from bodyvib._lazy import lazy_exports

_HOME = {
    "Case": "spec",
    "load_spec": "spec",
    "grid_spec": "spec",
    "expand": "spec",
    "iter_cases": "spec",
    "count_cases": "spec",
    "ClusterLost": "cluster",
    "ENGINES": "engines",
    "run_engine": "engines",
    "run_sweep": "run",
    "SweepSettings": "run",
    "read_results": "run",
    "format_summary": "summary",
    "plot_comfort_maps": "plot",
}

__all__, __getattr__, __dir__ = lazy_exports(__name__, _HOME)
