"""Runs of the native FMUs in C hosts other than fmpy (fmusim, the FMU Compliance Checker)
against fmpy's co-simulation on the same road: the 80 mm bump at 20 m/s as an input CSV, the
co-simulation given the same samples and chord slopes, and the comparison of a first-order
forward Euler with it.

Imported as ``from host_runs import ...`` by the tests of each host.
"""

import os
import shutil

import numpy as np
import pytest
from fmpy import simulate_fmu
from test_regimes import BUMP, SPEED, H


def host_program(env: str, name: str, what: str, how: str):
    """A C host the project does not build: its path (the ``env`` variable's, else ``name``
    on ``PATH``; None: neither) and the marks of its tests (integration, skipped without
    it with the reason ``no <what>: ...``, ``how`` saying where to get it)."""
    path = os.environ.get(env) or shutil.which(name)
    reason = f"no {what}: put {name} on PATH or set {env} ({how})"
    return path, [pytest.mark.integration, pytest.mark.skipif(path is None, reason=reason)]


CAR_OUT = ("seat_displacement", "suspension_deflection", "tire_force", "stop_force")
T_END = 1.0
#: the Euler steps: h and h / 2
EULER_H = 1e-5


def bump(t, h=BUMP[0], length=BUMP[1], at=BUMP[2]):
    """A 1 - cos bump of height h and length ``length`` starting ``at`` metres on, at SPEED."""
    s = SPEED * np.asarray(t) - at
    return np.where((s >= 0) & (s <= length), 0.5 * h * (1 - np.cos(2 * np.pi * s / length)), 0.0)


def road_samples(tracks):
    """The road at the communication points (one column per track) and the chord slopes:
    the co-simulation's in-step road is then the linear interpolation the hosts make."""
    t = np.arange(0.0, T_END + 1.5 * H, H)
    z = np.column_stack([f(t) for f in tracks])
    v = np.vstack([np.diff(z, axis=0) / H, np.zeros((1, z.shape[1]))])
    return t[:-1], z[:-1], v[:-1]


def write_input(path, names, t, z, v, fine):
    """The input CSV the hosts read: time, then each track's displacement and velocity column, the
    seat force and its rate at 0; on a grid ``fine`` times finer than the samples (the
    displacement interpolated, the velocity held over each communication step)."""
    tf = np.arange(0.0, t[-1] + H / (2 * fine), H / fine)
    k = np.minimum(np.floor(tf / H + 1e-9).astype(int), len(t) - 1)
    cols, header = [tf], ["time"]
    for j, (dn, vn) in enumerate(names):
        cols += [np.interp(tf, t, z[:, j]), v[k, j]]
        header += [dn, vn]
    cols += [np.zeros_like(tf)] * 2
    header += ["seat_force", "seat_force_rate"]
    np.savetxt(
        path,
        np.column_stack(cols),
        delimiter=",",
        header=",".join(header),
        comments="",
        fmt="%.17g",
    )


def cosim(fmu, names, t, z, v, outputs, start_values=None):
    """fmpy's co-simulation of ``fmu`` with the road samples and chord slopes as inputs."""
    fields = [("time", float)] + [(n, float) for pair in names for n in pair]
    fields += [("seat_force", float), ("seat_force_rate", float)]
    rows = [(ti, *np.ravel(np.column_stack([zi, vi])), 0.0, 0.0) for ti, zi, vi in zip(t, z, v)]
    return simulate_fmu(
        str(fmu),
        stop_time=T_END,
        step_size=H,
        output_interval=H,
        input=np.array(rows, dtype=fields),
        output=outputs,
        start_values=start_values or {},
    )


def peak_errors(run, ref, outputs):
    """Largest difference of each output on the reference's grid, over its peak."""
    return {
        o: float(
            np.max(np.abs(np.interp(ref["time"], run["time"], run[o]) - ref[o]))
            / np.max(np.abs(ref[o]))
        )
        for o in outputs
    }


def flag_changes(run, flag):
    return run["time"][1:][np.diff(run[flag]) != 0]


def euler_against_cosim(fmu, tmp_path, names, tracks, outputs, euler):
    """A host's forward Euler (``euler(fmu, tmp_path, outputs, h, csv)``) at EULER_H and EULER_H / 2 on the road CSV and fmpy's co-simulation on the same
    road: (errors at h, at h / 2, of the Richardson extrapolation, runs, cs)."""
    t, z, v = road_samples(tracks)
    cs = cosim(fmu, names, t, z, v, outputs)
    csv = tmp_path / "in.csv"
    write_input(csv, names, t, z, v, fine=10)
    runs = [euler(fmu, tmp_path, outputs, h, csv) for h in (EULER_H, EULER_H / 2)]
    coarse, fine = (peak_errors(r, cs, outputs) for r in runs)
    on_grid = [{o: np.interp(cs["time"], r["time"], r[o]) for o in outputs} for r in runs]
    richardson = {
        o: float(np.max(np.abs(2 * on_grid[1][o] - on_grid[0][o] - cs[o])) / np.max(np.abs(cs[o])))
        for o in outputs
    }
    return coarse, fine, richardson, runs, cs


ROAD_NAMES = (("road_displacement", "road_velocity"),)


CORNERS = ("front_left", "front_right", "rear_left", "rear_right")
FULL_OUT = ("bounce", "pitch", "roll", *(f"tire_force_{c}" for c in CORNERS))


def two_track():
    """Per corner: the left track's 80 mm bump at 10 m, the right track's 40 mm one at
    10.5 m; the rear wheels meet them a wheelbase (lf + lr = 2.8 m) later."""
    base = BUMP[2]
    ats = (base, base + 0.5, base + 2.8, base + 3.3)
    heights = (BUMP[0], BUMP[0] / 2, BUMP[0], BUMP[0] / 2)
    return [lambda t, h=h, a=a: bump(t, h=h, at=a) for h, a in zip(heights, ats)]


FULL_NAMES = tuple((f"road_displacement_{c}", f"road_velocity_{c}") for c in CORNERS)


def assert_first_order(coarse, fine, richardson, outputs, extrapolated=None):
    """Forward Euler's error against the co-simulation, as a first-order method has it: at
    most 5e-3 of each output's peak at EULER_H, halving with the step (ratio 1.6 to 2.4) and,
    for the ``extrapolated`` outputs (all by default), at most a fifth of the error at
    EULER_H / 2 after extrapolation."""
    for o in outputs:
        assert coarse[o] <= 5e-3, (o, coarse)
        assert 1.6 <= coarse[o] / fine[o] <= 2.4, (o, coarse, fine)
    for o in outputs if extrapolated is None else extrapolated:
        assert richardson[o] <= fine[o] / 5, (o, fine, richardson)
