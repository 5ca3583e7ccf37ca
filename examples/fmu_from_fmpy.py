"""Run HumanBody3DOF.fmu from fmpy: a seat bump in, head acceleration and seat force out.

Build the FMU first (``python build_fmu.py``), then::

    python examples/fmu_from_fmpy.py dist/HumanBody3DOF.fmu

The fmpy snippet of docs/tutorials/fmu_hosts.md, "FMUs" is this function; tests/test_fmu_integration.py runs it.
"""

import sys

import numpy as np

__all__ = ["seat_bump", "run"]


def seat_bump(t, height=0.02, start=0.1, width=0.1):
    """A triangular seat bump: displacement (m) and velocity (m/s) on a time grid.

    The velocity at ``t[k]`` is the slope over ``[t[k], t[k+1]]``, so with the kinks
    on grid points the FMU's in-step extrapolation follows the bump exactly.
    """
    t = np.asarray(t, float)
    x = height * np.clip(1 - np.abs(2 * (t - start) / width - 1), 0, None)
    v = np.append(np.diff(x) / np.diff(t), 0.0)
    return x, v


def run(fmu_path="dist/HumanBody3DOF.fmu", duration=1.0, step=1e-3):
    """Simulate the body FMU with fmpy on a seat bump.

    Parameters
    ----------
    fmu_path : str
        HumanBody3DOF.fmu or HumanBodyISO7962.fmu.
    duration : float
        Simulated time from 0, s.
    step : float
        Communication step, s (fmpy's ``output_interval`` for co-simulation FMUs).

    Returns
    -------
    numpy structured array
        Fields ``time`` [s], ``head_acceleration`` [m/s2], ``head_displacement``
        [m], ``torso_displacement`` [m], ``seat_force`` [N].
    """
    from fmpy import simulate_fmu

    t = np.arange(round(duration / step) + 1) * step
    x, v = seat_bump(t)
    # every input of the FMU (fmpy warns about one left out): seat_acceleration 0, the
    # seat moving linearly over each step, as the bump does
    signals = np.array(
        list(zip(t, x, v, np.zeros_like(t))),
        dtype=[
            ("time", float),
            ("seat_displacement", float),
            ("seat_velocity", float),
            ("seat_acceleration", float),
        ],
    )
    return simulate_fmu(
        fmu_path,
        start_time=0.0,
        stop_time=duration,
        output_interval=step,
        input=signals,
        output=["head_acceleration", "head_displacement", "torso_displacement", "seat_force"],
    )


if __name__ == "__main__":
    res = run(*sys.argv[1:2])
    k = int(np.argmax(np.abs(res["head_acceleration"])))
    print(
        f"peak head acceleration {res['head_acceleration'][k]:.3f} m/s2 at {res['time'][k]:.3f} s; "
        f"peak seat force {np.max(np.abs(res['seat_force'])):.1f} N"
    )
