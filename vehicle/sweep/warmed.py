"""Importing this module warms the process for sweeps (:func:`bodyvib.vehicle.sweep.preload.warm`).

A sweep's LocalCluster starts its workers by forking them from one server process
(multiprocessing's ``forkserver``) that imports this module before the first fork:
the imports, numba's start and the compiled loop are paid once for all the workers
of a cluster (and for later clusters of the same command or Python session), not
once per worker.
"""

from .preload import warm

__all__ = []

warm()
