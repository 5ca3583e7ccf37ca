"""The co-simulation master: a body FMU on the quarter-car FMU, two-way coupled (fmpy).

Any FMU with the body interface of the FMU contract
(:mod:`bodyvib.runtime.contract`: inputs ``seat_displacement``,
``seat_velocity``; outputs ``head_acceleration``, ``head_displacement``,
``torso_displacement``, ``seat_force``) sits on any FMU with the car interface
(inputs ``road_displacement``, ``road_velocity``, ``seat_force`` and
optionally ``seat_force_rate``; outputs ``seat_displacement``,
``seat_velocity``) that also has the outputs the shipped cars declare in their
parameter files' ``fmu_outputs`` (:data:`vehicle.quarter_car.CAR_FMU_OUTPUTS`:
``sprung_acceleration``, ``suspension_deflection``, ``tire_force``). Both run
in fmpy's ``FMU2Slave`` with a fixed communication step ``h``.

One macro-step from ``t_k`` to ``t_{k+1}`` (Gauss-Seidel, car first):

1. car: road ``z_k`` and its slope ``v_k``; seat force ``F_k`` with the rate
   ``(F_k - F_{k-1}) / h`` (linear extrapolation from the last two
   communication points; a car FMU without ``seat_force_rate`` gets the mean
   of that line over the step, ``F_k + (F_k - F_{k-1}) / 2``, held); ``doStep``;
   read the seat motion ``x_{k+1}``, ``v_{k+1}`` (states: exact right after
   the step). The car's outputs are recorded at ``t_k`` after its inputs of
   ``t_k`` are set, since tire force and seat acceleration are feedthrough.
2. body: seat displacement ``x_k`` with the slope ``(x_{k+1} - x_k) / h``, so
   that its in-step seat motion is the chord between the car's two points and
   ends exactly where the car's seat is; ``doStep``.
3. body: set ``x_{k+1}``, ``v_{k+1}`` (the seat force is feedthrough: it is
   computed on read from these) and read ``F_{k+1}`` and the head outputs.

A plain master that holds ``F_k`` over the step (``extrapolate=False``) is
first order in ``h``; the extrapolation makes the coupling second order. On a
class C road at 20 m/s the head-acceleration NRMSE against the monolithic
reference (:mod:`vehicle.reference`) at h = 1 ms is about 0.43 % held and
0.03 % extrapolated (README, "Coupling error").
"""

import contextlib
import os
import shutil
import tempfile
import zipfile
from typing import Dict, Optional

import numpy as np

from bodyvib.runtime import contract
from bodyvib.runtime.discretize import check_step
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.fileio import atomic_write_text

from .quarter_car import CAR_FMU_OUTPUTS

__all__ = [
    "BODY_INPUTS", "BODY_OUTPUTS", "CAR_INPUTS", "CAR_OUTPUTS",
    "Slave", "open_fmu", "model_from_fmu", "cosimulate", "write_csv",
]

#: What the master sets and reads (names from the FMU contract): the body
#: interface whole; of the car's, ``seat_force_rate`` is optional (used if present).
BODY_INPUTS = contract.BODY_INPUTS[:2]  # the master drives seat displacement and velocity
BODY_OUTPUTS = contract.BODY_OUTPUTS[:4]  # and reads these (seat_force_rate is for Jacobi hosts)
CAR_INPUTS = contract.CAR_INPUTS[:3]
_SEAT_FORCE_RATE = contract.CAR_INPUTS[3]
CAR_OUTPUTS = contract.CAR_OUTPUTS + CAR_FMU_OUTPUTS
_INTERFACES = {"body": (BODY_INPUTS, BODY_OUTPUTS), "car": (CAR_INPUTS, CAR_OUTPUTS)}

#: Column units of the result / CSV.
UNITS = {
    "time": "s", "road_displacement": "m", "road_velocity": "m/s",
    "seat_displacement": "m", "seat_velocity": "m/s", "seat_acceleration": "m/s2",
    "suspension_deflection": "m", "tire_force": "N", "seat_force": "N",
    "head_acceleration": "m/s2", "head_displacement": "m", "torso_displacement": "m",
}


class Slave:
    """An FMI 2.0 co-simulation FMU instantiated in fmpy, with its variables by name.

    Use :func:`open_fmu` (a context manager that also cleans up).

    Attributes
    ----------
    fmu : fmpy.fmi2.FMU2Slave
    vr : dict of str to int
        Value reference of each variable.
    path : str
    """

    def __init__(self, fmu, vr, path, unzipdir):
        self.fmu = fmu
        self.vr = vr
        self.path = path
        self._unzipdir = unzipdir

    def close(self):
        """Terminate and free the instance, delete the extracted files."""
        try:
            self.fmu.terminate()
        finally:
            self.fmu.freeInstance()
            shutil.rmtree(self._unzipdir, ignore_errors=True)


def _check_interface(md, path, kind):
    inputs, outputs = _INTERFACES[kind]
    have = {v.name: v.causality for v in md.modelVariables}
    missing = [n for n in inputs if have.get(n) != "input"]
    missing += [n for n in outputs if have.get(n) != "output"]
    if missing:
        raise BodyvibError(
            f"FMU '{path}' lacks the {kind} interface: no {', '.join(missing)}; a {kind} FMU "
            f"needs inputs {', '.join(inputs)} and outputs {', '.join(outputs)} (the FMU contract: README, FMUs)"
        )
    if md.coSimulation is None:
        raise BodyvibError(f"FMU '{path}' is not a co-simulation FMU (FMI 2.0 CS needed)")


@contextlib.contextmanager
def open_fmu(path, kind: str, instance_name: Optional[str] = None):
    """Instantiate and initialize an FMU of the body or car interface.

    Parameters
    ----------
    path : str
        ``.fmu`` file.
    kind : str
        ``"body"`` or ``"car"``: the interface it must have.
    instance_name : str, optional

    Yields
    ------
    Slave

    Raises
    ------
    BodyvibError
        Missing file, not an FMI 2.0 co-simulation FMU, missing interface
        variables, or a failure to instantiate or initialize.
    """
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise BodyvibError(f"FMU file '{path}' does not exist")
    try:
        md = read_model_description(path)
    except Exception as exc:
        raise BodyvibError(f"'{path}' is not a readable FMU: {exc}") from None
    if md.fmiVersion != "2.0":
        raise BodyvibError(f"FMU '{path}' is FMI {md.fmiVersion}; FMI 2.0 is needed")
    _check_interface(md, path, kind)
    unzipdir = extract(path, unzipdir=tempfile.mkdtemp(prefix="bodyvib-fmu-"))
    fmu = None
    try:
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipdir,
                        modelIdentifier=md.coSimulation.modelIdentifier,
                        instanceName=instance_name or kind)
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
    except Exception as exc:
        if fmu is not None:
            with contextlib.suppress(Exception):
                fmu.freeInstance()
        shutil.rmtree(unzipdir, ignore_errors=True)
        raise BodyvibError(f"FMU '{path}' failed to initialize: {exc}") from None
    slave = Slave(fmu, {v.name: v.valueReference for v in md.modelVariables}, path, unzipdir)
    try:
        yield slave
    finally:
        slave.close()


def model_from_fmu(path):
    """The parameter file a bodyvib FMU carries (``resources/bodyvib_model.json``).

    Parameters
    ----------
    path : str
        A ``.fmu`` built by ``build_fmu.py``.

    Returns
    -------
    Network or None
        The model baked into the FMU, or None for an FMU that carries none
        (a foreign FMU: it still co-simulates, but has no monolithic reference).
    """
    from bodyvib.runtime.modelfile import network_from_dict
    import json

    try:
        with zipfile.ZipFile(path) as z:
            data = json.loads(z.read("resources/bodyvib_model.json"))
    except (KeyError, zipfile.BadZipFile, ValueError, OSError):
        return None
    return network_from_dict(data, source=f"{path}:resources/bodyvib_model.json")


def cosimulate(car: Slave, body: Slave, road_displacement, road_velocity, step: float,
               extrapolate: bool = True, progress: bool = False) -> Dict[str, np.ndarray]:
    """Run the two-way coupled co-simulation over a sampled road.

    Parameters
    ----------
    car, body : Slave
        Initialized FMUs (:func:`open_fmu`), at rest.
    road_displacement, road_velocity : (n,) array_like
        Road input at ``t_k = k * step``, m and m/s.
    step : float
        Communication step h, s.
    extrapolate : bool
        Extrapolate the seat force linearly over each step (default); False
        holds it (the plain master, first order).
    progress : bool
        Show a tqdm progress bar on stderr (hidden when stderr is not a terminal).

    Returns
    -------
    dict of str to ndarray
        The signals of :data:`vehicle.reference.SIGNALS` at the ``n``
        communication points (``seat_acceleration`` is the car's
        ``sprung_acceleration`` output: the seat point's acceleration).

    Raises
    ------
    BodyvibError
        Bad step, non-finite road, or an FMU refusing a step.
    """
    z = np.asarray(road_displacement, dtype=float)
    v = np.asarray(road_velocity, dtype=float)
    check_step(step, "communication step")
    if z.shape != v.shape or z.ndim != 1 or z.size < 2:
        raise BodyvibError("road displacement and velocity must be 1-D arrays of equal length >= 2")
    if not (np.all(np.isfinite(z)) and np.all(np.isfinite(v))):
        raise BodyvibError("road input is not finite; check the road profile")
    n = z.size
    h = float(step)
    zl, vl = z.tolist(), v.tolist()
    out = np.zeros((n, 9))  # seat x, v, a, deflection, tire force, head a, head x, torso x, F
    rows = out.tolist()

    cf, bf = car.fmu, body.fmu
    has_rate = _SEAT_FORCE_RATE in car.vr
    car_in = [car.vr[k] for k in CAR_INPUTS] + ([car.vr[_SEAT_FORCE_RATE]] if has_rate else [])
    car_out = [car.vr[k] for k in CAR_OUTPUTS]
    body_in = [body.vr[k] for k in BODY_INPUTS]
    body_out = [body.vr[k] for k in ("seat_force", "head_acceleration", "head_displacement",
                                     "torso_displacement")]
    c_set, c_get, c_step = cf.setReal, cf.getReal, cf.doStep
    b_set, b_get, b_step = bf.setReal, bf.getReal, bf.doStep

    car_motion = car_out[:2]
    # the body at rest at t = 0
    b_set(body_in, [0.0, 0.0])
    F, a1, x1, x2 = b_get(body_out)
    F_prev = F
    bar = _progress(n - 1, progress)
    report = max(1, (n - 1) // 200)
    k = 0
    try:
        for k in range(n - 1):
            t = k * h
            dF = (F - F_prev) if extrapolate else 0.0
            if has_rate:
                c_set(car_in, [zl[k], vl[k], F, dF / h])
            else:
                c_set(car_in, [zl[k], vl[k], F + 0.5 * dF])
            # car outputs at t_k with the inputs of t_k (tire force and seat
            # acceleration are feedthrough of road and seat force)
            xs, vs, a_s, sd, tf = c_get(car_out)
            rows[k] = [xs, vs, a_s, sd, tf, a1, x1, x2, F]
            c_step(t, h)
            xn, vn = c_get(car_motion)  # states only: exact right after the step
            b_set(body_in, [xs, (xn - xs) / h])
            b_step(t, h)
            b_set(body_in, [xn, vn])
            F_prev = F
            F, a1, x1, x2 = b_get(body_out)
            if bar is not None and k % report == 0:
                bar.update(min(report, n - 1 - k))
        k = n - 1
        c_set(car_in, [zl[k], vl[k], F] + ([0.0] if has_rate else []))
        rows[k] = list(c_get(car_out)) + [a1, x1, x2, F]
    except BodyvibError:
        raise
    except Exception as exc:
        raise BodyvibError(f"co-simulation stopped at t = {k * h:g} s: {exc}") from None
    finally:
        if bar is not None:
            bar.close()
    out = np.array(rows)
    return {
        "time": np.arange(n) * h,
        "road_displacement": z,
        "road_velocity": v,
        "seat_displacement": out[:, 0],
        "seat_velocity": out[:, 1],
        "seat_acceleration": out[:, 2],
        "suspension_deflection": out[:, 3],
        "tire_force": out[:, 4],
        "seat_force": out[:, 8],
        "head_acceleration": out[:, 5],
        "head_displacement": out[:, 6],
        "torso_displacement": out[:, 7],
    }


def _progress(total, enabled):
    if not enabled:
        return None
    import sys

    from tqdm import tqdm

    return tqdm(total=total, unit="step", file=sys.stderr, disable=None, leave=False,
                desc="co-simulation", mininterval=0.5)


def write_csv(path, result: Dict[str, np.ndarray]) -> None:
    """Write a run as CSV (header ``name [unit]``), atomically.

    Parameters
    ----------
    path : str
    result : dict of str to ndarray
        Equal-length columns (:func:`cosimulate`, :func:`vehicle.reference.reference_run`).
    """
    names = list(result)
    cols = np.column_stack([np.asarray(result[k], dtype=float) for k in names])
    def unit(name):  # "HumanBody3DOF.head_acceleration" has the unit of head_acceleration
        u = UNITS.get(name.rpartition(".")[2].replace("reference_", ""))
        return f"{name} [{u}]" if u else name

    header = ",".join(unit(k) for k in names)
    lines = [header] + [",".join(f"{x:.10g}" for x in row) for row in cols]
    atomic_write_text(path, "\n".join(lines) + "\n")
