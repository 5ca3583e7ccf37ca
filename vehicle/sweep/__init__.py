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

_MODULES = {
    "spec": ("Case", "count_cases", "expand", "grid_spec", "iter_cases", "load_spec"),
    "cluster": ("ClusterLost",),
    "engines": ("ENGINES", "run_engine"),
    "run": ("SweepSettings", "read_results", "run_sweep"),
    "summary": ("format_summary",),
    "plot": ("plot_comfort_maps",),
}

__all__, __getattr__, __dir__ = lazy_exports(__name__, _MODULES)
