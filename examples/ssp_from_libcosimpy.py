"""Run the shipped SSP (road, quarter car, occupant) in libcosim (libcosimpy), unchanged.

Build it first (``python build_fmu.py`` writes ``dist/QuarterCarWithOccupant.ssp``), then::

    python examples/ssp_from_libcosimpy.py [dist/QuarterCarWithOccupant.ssp] [DURATION]

libcosim reads the system, the parameter set and the 1 ms step from the SSP; this
script only records signals (time in integer nanoseconds; its default log is very
verbose, so it is lowered). tests/test_ssp.py runs this function.
"""

from _ssp_host import DEFAULT_SSP, SIGNALS, main, record

__all__ = ["SIGNALS", "run"]


def run(ssp_path=DEFAULT_SSP, duration=30.0, step=None, signals=SIGNALS, log_level="ERROR"):
    """Simulate the SSP in libcosim.

    Parameters
    ----------
    ssp_path : str
        The ``.ssp`` file.
    duration : float
        Simulated time, s.
    step : float, optional
        Communication step, s (whole nanoseconds); None takes the SSP's (1 ms).
    signals : sequence of (str, str)
        Component and variable names to record.
    log_level : str
        libcosim's log level (``"WARNING"`` shows the FMUs' warnings).

    Returns
    -------
    dict of str to ndarray
        ``time`` [s] and ``"<component>.<variable>"`` at ``0, h, 2h, ...``
        (the first row: the values after initialization).
    """
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(getattr(CosimLogLevel, log_level))
    execution = (
        CosimExecution.from_ssp_file(str(ssp_path))
        if step is None
        else CosimExecution.from_ssp_file(str(ssp_path), step_size=int(round(step * 1e9)))
    )
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer=observer)
    where = []
    for comp, var in signals:
        index = execution.slave_index_from_instance_name(comp)
        vr = {v.name.decode(): v.reference for v in execution.slave_variables(index)}[var]
        where.append((index, vr))
    rows, times = [], []
    while True:
        if rows:  # the first row: after initialization (libcosim exchanges values then)
            if not execution.step():
                raise RuntimeError(f"libcosim step failed at t = {times[-1]:g} s")
        times.append(execution.status().current_time * 1e-9)
        rows.append([observer.last_real_values(i, [vr])[0] for i, vr in where])
        if times[-1] >= duration - 1e-12:
            break
    return record(times, rows, signals)


if __name__ == "__main__":
    main(run)
