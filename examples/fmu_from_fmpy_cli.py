"""Run HumanBody3DOF.fmu from fmpy's command line: a seat bump from a CSV file in, a CSV out.

Build the FMU first (``python build_fmu.py``), then::

    python examples/fmu_from_fmpy_cli.py dist/HumanBody3DOF.fmu

which writes ``seat_bump.csv`` into the current folder and runs there exactly (so the
command runs again as written, result in ``result.csv``)::

    fmpy simulate dist/HumanBody3DOF.fmu --input-file seat_bump.csv --output-interval 0.001 \\
        --output-variables head_acceleration seat_force --output-file result.csv

``--output-interval`` is the communication step for a co-simulation FMU and a user
must give it: without it fmpy takes the FMU's 1 ms and doubles it until the run has
at most 1000 points (16 ms over the default 10 s), and the seat bump's peak head
acceleration comes out 29 % high (docs/tutorials/fmu_hosts.md, "FMUs"). fmpy interpolates the input file
linearly at each communication point and sets ``seat_velocity`` from its column.

The SSP's command line (``python -m fmpy.ssp.simulate``) is no alternative for the
coupled system: it takes only ``--stop-time``, steps at 1 % of it and writes no
results; use ``fmpy.ssp.simulation.simulate_ssp`` (``examples/ssp_from_fmpy.py``).
tests/test_ssp.py runs this function.
"""

import os
import subprocess
import sys
import tempfile

import numpy as np

__all__ = ["seat_bump_csv", "run"]


def seat_bump_csv(path, duration=10.0, step=1e-3, height=0.02, start=0.1, width=0.1):
    """Write a triangular seat bump as fmpy's input CSV (``time``, ``seat_displacement``,
    ``seat_velocity`` and ``seat_acceleration``, 0: every input given, none warned about).

    Returns
    -------
    (t, x, v) : ndarrays
    """
    t = np.arange(round(duration / step) + 1) * step
    x = height * np.clip(1 - np.abs(2 * (t - start) / width - 1), 0, None)
    v = np.append(np.diff(x) / np.diff(t), 0.0)
    np.savetxt(
        path,
        np.c_[t, x, v, np.zeros_like(t)],
        delimiter=",",
        header="time,seat_displacement,seat_velocity,seat_acceleration",
        comments="",
    )
    return t, x, v


def run(fmu_path="dist/HumanBody3DOF.fmu", output_interval=1e-3, dest=None):
    """fmpy's ``simulate`` command on the seat bump.

    Parameters
    ----------
    fmu_path : str
    output_interval : float or None
        ``--output-interval``; None leaves it out (fmpy's own choice).
    dest : str, optional
        Where ``seat_bump.csv`` and ``result.csv`` go and stay (by default a temporary
        folder, deleted on return).

    Returns
    -------
    numpy structured array
        ``time``, ``head_acceleration`` [m/s2], ``seat_force`` [N].
    """
    from fmpy.util import read_csv

    with tempfile.TemporaryDirectory() as tmp:
        dest = dest or tmp
        seat_bump_csv(os.path.join(dest, "seat_bump.csv"))
        cmd = [
            sys.executable,
            "-m",
            "fmpy",
            "simulate",
            os.path.abspath(fmu_path),
            "--input-file",
            "seat_bump.csv",
            "--output-variables",
            "head_acceleration",
            "seat_force",
            "--output-file",
            "result.csv",
        ]
        if output_interval is not None:
            cmd += ["--output-interval", repr(float(output_interval))]
        subprocess.run(cmd, cwd=dest, check=True, capture_output=True, text=True)
        return read_csv(os.path.join(dest, "result.csv"))


if __name__ == "__main__":
    res = run(*sys.argv[1:2], dest=os.getcwd())  # the files stay for the next command
    k = int(np.argmax(np.abs(res["head_acceleration"])))
    print(
        f"peak head acceleration {res['head_acceleration'][k]:.3f} m/s2 at {res['time'][k]:.3f} s"
    )
