"""Run a body FMU in libcosim (libcosimpy): seat motion in through an override manipulator.

Build the FMU first (``python build_fmu.py``), then::

    python examples/fmu_from_libcosimpy.py dist/HumanBody3DOF.fmu

libcosim counts time in integer nanoseconds and reads outputs right after each
doStep, before it sets new inputs: the FMU's outputs are then those of the
step's end (seat displacement extrapolated at the seat velocity). The libcosimpy
snippet of docs/tutorials/fmu_hosts.md, "FMUs" is this function; tests/test_fmu_integration.py runs it.
"""

import sys

import numpy as np

__all__ = ["run"]


def run(fmu_path="dist/HumanBody3DOF.fmu", seat_displacement=None, seat_velocity=None, step=1e-3):
    """Co-simulate one body FMU in libcosim with a given seat motion.

    Parameters
    ----------
    fmu_path : str
    seat_displacement, seat_velocity : array_like
        Seat motion at ``t[k] = k * step`` (m, m/s); a seat bump by default.
    step : float
        Communication step, s (whole nanoseconds).

    Returns
    -------
    dict of str to ndarray
        ``time`` (s) and each output (``head_acceleration`` m/s2,
        ``head_displacement`` m, ``torso_displacement`` m, ``seat_force`` N)
        at ``t[1:]``, as libcosim reads them after each step.
    """
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    if seat_displacement is None:  # a 2 cm triangular bump at 0.1-0.2 s, then 0.8 s free
        t = np.arange(1001) * step
        seat_displacement = 0.02 * np.clip(1 - np.abs(2 * (t - 0.1) / 0.1 - 1), 0, None)
        seat_velocity = np.append(np.diff(seat_displacement) / step, 0.0)
    log_output_level(CosimLogLevel.ERROR)  # libcosim's default is very verbose
    step_ns = int(round(step * 1e9))
    execution = CosimExecution.from_step_size(step_size=step_ns)
    body = execution.add_local_slave(CosimLocalSlave(fmu_path=str(fmu_path), instance_name="body"))
    vr = {v.name.decode(): v.reference for v in execution.slave_variables(body)}
    outputs = ["head_acceleration", "head_displacement", "torso_displacement", "seat_force"]
    manipulator = CosimManipulator.create_override()
    observer = CosimObserver.create_last_value()
    execution.add_manipulator(manipulator=manipulator)
    execution.add_observer(observer=observer)
    inputs = [vr["seat_displacement"], vr["seat_velocity"]]
    out = {name: [] for name in ["time"] + outputs}
    for k in range(len(seat_displacement) - 1):
        manipulator.slave_real_values(
            body, inputs, [float(seat_displacement[k]), float(seat_velocity[k])]
        )
        if not execution.step():
            raise RuntimeError(f"libcosim step {k} failed")
        values = observer.last_real_values(body, [vr[n] for n in outputs])
        out["time"].append(execution.status().current_time * 1e-9)
        for name, value in zip(outputs, values):
            out[name].append(value)
    return {k: np.array(v) for k, v in out.items()}


if __name__ == "__main__":
    res = run(*sys.argv[1:2])
    print(
        f"peak head acceleration {np.max(np.abs(res['head_acceleration'])):.3f} m/s2, "
        f"peak seat force {np.max(np.abs(res['seat_force'])):.1f} N"
    )
