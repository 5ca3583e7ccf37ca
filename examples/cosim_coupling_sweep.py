"""Coupling error of the co-simulation master against the communication step.

    python examples/cosim_coupling_sweep.py [DURATION]

Builds the FMUs into a temporary folder, runs HumanBody3DOF.fmu on QuarterCar.fmu
over a class C road at 20 m/s for each step from 1e-4 to 1e-2 s, with the plain
master (seat force held) and with the seat force extrapolated, and prints the
head-acceleration NRMSE against the monolithic reference.
"""

import sys
import tempfile

from bodyvib.vehicle.fmus import build_fmus
from bodyvib.vehicle.road.driven import RunSettings
from bodyvib.vehicle.study import coupling_error_sweep

STEPS = (1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2)


def run(steps=STEPS, duration=30.0, body="HumanBody3DOF", car="quarter-car"):
    """Coupling NRMSE per step for both masters.

    Returns
    -------
    list of dict
        ``{"step", "held", "extrapolated"}`` (NRMSE as fractions).
    """
    with tempfile.TemporaryDirectory() as d:
        fmus = {n: str(p) for n, p in build_fmus(d, car=car, names=(body, "QuarterCar")).items()}
        rows = []
        settings = RunSettings(duration=duration)
        held = coupling_error_sweep(
            steps, fmus[body], fmus["QuarterCar"], settings, extrapolate=False
        )
        extr = coupling_error_sweep(steps, fmus[body], fmus["QuarterCar"], settings)
        for a, b in zip(held, extr):
            rows.append(
                {
                    "step": a["step"],
                    "held": a["coupling_nrmse"],
                    "extrapolated": b["coupling_nrmse"],
                }
            )
    return rows


def main(duration=30.0):
    rows = run(duration=duration)
    print(f"{'step [s]':>9} | {'held [%]':>9} | {'extrapolated [%]':>16}")
    for r in rows:
        print(f"{r['step']:9.0e} | {100 * r['held']:9.4f} | {100 * r['extrapolated']:16.5f}")
    return rows


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 30.0)
