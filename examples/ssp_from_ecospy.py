"""Run the shipped SSP (road, quarter car, occupant) in Ecos (ecospy), unchanged.

Build it first (``python build_fmu.py``), then::

    python examples/ssp_from_ecospy.py [dist/QuarterCarWithOccupant.ssp] [DURATION]

Ecos reads the system from the SSP; the step is given here
(``EcosSimulation(step_size=...)``) and the parameter set by its name at
``init`` (``"QuarterCarWithOccupant"``, the name of every ``.ssv`` in the SSP:
without it Ecos applies none, and the FMUs run on their built-in values);
variables are named ``"<component>::<variable>"``. ecospy needs Intel TBB at run time (Debian:
``apt-get install libtbb12``). tests/test_ssp.py runs this function.
"""

import numpy as np
from _ssp_host import DEFAULT_SSP, SIGNALS, main, record

__all__ = ["PARAMETER_SET", "SIGNALS", "run"]

#: Name of the SSP's parameter set (its ``.ssv`` files).
PARAMETER_SET = "QuarterCarWithOccupant"


def run(
    ssp_path=DEFAULT_SSP, duration=30.0, step=1e-3, signals=SIGNALS, parameter_set=PARAMETER_SET
):
    """Simulate the SSP in Ecos.

    Parameters
    ----------
    ssp_path : str
        The ``.ssp`` file (Ecos extracts it into ``TMPDIR``).
    duration : float
        Simulated time, s: ``round(duration / step)`` steps.
    step : float
        Communication step, s: Ecos takes it from here, not from the SSP.
    signals : sequence of (str, str)
        Component and variable names to record.
    parameter_set : str
        Name of the SSP's parameter set (``"HalfCarWithOccupant"`` for the half car's).

    Returns
    -------
    dict of str to ndarray
        ``time`` [s] and ``"<component>.<variable>"`` at ``0, h, 2h, ...``.
    """
    from ecospy import EcosSimulation

    names = [f"{c}::{v}" for c, v in signals]
    sim = EcosSimulation(step_size=step, ssp_path=str(ssp_path))
    try:
        if not sim.init(parameter_set=parameter_set):
            raise RuntimeError("Ecos could not initialize the SSP")
        n = int(round(duration / step))
        rows = np.empty((n + 1, len(names)))
        times = np.empty(n + 1)
        for k in range(n + 1):
            if k:
                sim.step()
            times[k] = sim.get_time()
            rows[k] = [sim.get_real(name) for name in names]
        sim.terminate()
    finally:
        sim.free()
    return record(times, rows, signals)


if __name__ == "__main__":
    main(run)
