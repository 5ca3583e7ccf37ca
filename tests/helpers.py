"""Helpers the tests share: the repository's root, the command line, what a command stopped
by a signal must leave, a C host built for win64, independent references.

Imported as ``from helpers import ...`` (``tests/`` is on ``sys.path`` under pytest's default
import mode, as ``conftest.py`` is). Fixtures live in ``conftest.py``.
"""

import contextlib
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np
import pytest

__all__ = [
    "ROOT",
    "run_cli",
    "run_text",
    "run_ok",
    "OLD_CONTENT",
    "write_old_outputs",
    "check_stopped_run",
    "handles_signal",
    "start_cli",
    "win64_host",
    "fmi2_model_exchange",
    "fmpy_headers",
    "compile_c_host",
    "fmpy_compile_sources",
    "VARIABLE_ATTRIBUTES",
    "dynamic_stiffness_response",
    "sine_road",
    "write_sine_road",
    "read_run_csv",
    "car_dict",
    "assert_csv_is_the_cosim_engine",
    "cosim_changed_car",
    "nrmse_against_ode",
    "reduced_body_on_seat",
    "solve_switching",
    "mount_tmpfs",
]

#: The repository's root (where ``build_fmu.py`` is).
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_cli(*args, cwd=None, timeout=600):
    """``python -m bodyvib.cli ARGS`` as a user runs it: the finished process, output as text."""
    return subprocess.run(
        [sys.executable, "-m", "bodyvib.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def run_text(cmd, cwd=None, env=None, timeout=600):
    """Run ``cmd`` (a list) in ``cwd`` with ``env``: the finished process, output as text."""
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def run_ok(cmd, cwd=None, env=None, timeout=600):
    """:func:`run_text`, asserting that ``cmd`` exits 0 (its output in the failure)."""
    out = run_text(cmd, cwd, env, timeout)
    assert out.returncode == 0, out.stdout + out.stderr
    return out


#: What every output holds before a command that is sent a signal runs.
OLD_CONTENT = "old content\n"


def write_old_outputs(outputs):
    """Give every output file (``pathlib.Path``) :data:`OLD_CONTENT`, creating its folder."""
    for p in outputs:
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(OLD_CONTENT)


def check_stopped_run(rc, err, outputs, status, line, what):
    """Assert what a command sent a signal must leave; True if the signal stopped it.

    It ends with ``status`` and ``line`` last on stderr (or with 0 when the signal came
    after the work), never killed by a signal, without a traceback or a fatal FMU status;
    its outputs are all new or all :data:`OLD_CONTENT`, and no staged ``.tmp-*`` file is
    left beside them.
    """
    assert rc in (0, status), what  # never killed by a signal (segfault, abort)
    assert "Traceback" not in err and "fatal" not in err.lower(), what
    new = [p.read_text(errors="replace") != OLD_CONTENT for p in outputs]
    if rc:
        assert err.strip().splitlines()[-1] == line, what
        assert all(new) or not any(new), (what, new)  # all outputs or none
    else:
        assert all(new), what
    beside = [
        f for d in {p.parent for p in outputs} for f in os.listdir(d) if f.startswith(".tmp-")
    ]
    assert not beside, (what, beside)
    return bool(rc)


#: What a model description declares of a variable, as fmpy reads it.
VARIABLE_ATTRIBUTES = (
    "valueReference",
    "causality",
    "variability",
    "unit",
    "start",
    "min",
    "max",
    "description",
)


def fmpy_headers():
    """fmpy's copy of the FMI C headers, which the C test hosts include."""
    import fmpy

    return os.path.join(os.path.dirname(fmpy.__file__), "c-code")


def compile_c_host(
    sources, exe, flags=("-O2", "-Wall", "-Wextra", "-Werror"), includes=None, libs=("-ldl", "-lm")
):
    """Compile a C test host with gcc as C99 (the test skips where there is no gcc).

    ``includes`` are the header folders, fmpy's by default; returns ``exe``.
    """
    if shutil.which("gcc") is None:
        pytest.skip("gcc not found: cannot build the C host")
    includes = [fmpy_headers()] if includes is None else includes
    out = subprocess.run(
        [
            "gcc",
            "-std=c99",
            *flags,
            *(a for d in includes for a in ("-I", d)),
            *sources,
            "-o",
            exe,
            *libs,
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    return exe


def fmpy_compile_sources(fmu, path, cwd):
    """Copy ``fmu`` to ``path`` without its binaries and have ``fmpy compile`` build them
    from its sources (the test skips where there is no cmake)."""
    import zipfile

    if shutil.which("cmake") is None:
        pytest.skip("cmake not found: fmpy compile needs it")
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(path, "w") as dst:
        for info in src.infolist():
            if not info.filename.startswith("binaries/"):  # only the sources remain
                dst.writestr(info, src.read(info))
    out = subprocess.run(
        [sys.executable, "-m", "fmpy.cli", "compile", str(path)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=cwd,
    )
    assert out.returncode == 0, out.stdout + out.stderr


def handles_signal(pid, signum):
    """True once process ``pid`` catches ``signum`` (its SigCgt mask in /proc)."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("SigCgt:"):
                    return bool(int(line.split()[1], 16) >> (signum - 1) & 1)
    except OSError:
        pass
    return False


def start_cli(argv, cwd, tmpdir, program=None):
    """A command started as a shell starts it, once its signal handlers are in place.

    ``python -m bodyvib.cli ARGV`` (or ``python PROGRAM ARGV``) in its own process group
    and session, with ``TMPDIR`` = ``tmpdir``, stdout and stderr piped as text; returned
    once it catches SIGTERM (bodyvib catches its three signals at once, Python catches
    SIGINT from its start), or has ended, or after 60 s.
    """
    cmd = [sys.executable, "-m", "bodyvib.cli"] if program is None else [sys.executable, program]
    proc = subprocess.Popen(
        [*cmd, *argv],
        cwd=cwd,
        env=dict(os.environ, TMPDIR=str(tmpdir)),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    t0 = time.monotonic()
    while (
        not handles_signal(proc.pid, signal.SIGTERM)
        and proc.poll() is None
        and time.monotonic() < t0 + 60
    ):
        time.sleep(0.005)
    return proc


@contextlib.contextmanager
def win64_host(source, headers, exe, home):
    """A C host compiled for win64 (mingw-w64, static) and wine to run it; skips without them.

    Yields ``(wine, env)``: the wine program and the environment to run ``exe`` with (its
    own ``WINEPREFIX``, removed afterwards; ``WINEDEBUG=-all``; ``HOME`` = ``home``).
    """
    mingw = shutil.which("x86_64-w64-mingw32-gcc")
    wine = (
        shutil.which("wine")
        or shutil.which("wine64")
        or next((p for p in ("/usr/lib/wine/wine64",) if os.access(p, os.X_OK)), None)
    )
    if mingw is None or wine is None:
        pytest.skip(
            f"{'x86_64-w64-mingw32-gcc' if mingw is None else 'wine'} not found: "
            "install gcc-mingw-w64-x86-64 and wine64 to run the win64 binary"
        )
    out = subprocess.run(
        [
            mingw,
            "-std=c99",
            "-O2",
            "-Wall",
            "-Werror",
            "-static",
            "-I",
            headers,
            str(source),
            "-o",
            str(exe),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    prefix = tempfile.mkdtemp(prefix="bodyvib-wine-")
    try:
        yield (
            wine,
            {
                "WINEPREFIX": prefix,
                "WINEDEBUG": "-all",
                "HOME": str(home),
                "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
            },
        )
    finally:
        shutil.rmtree(prefix, ignore_errors=True)


def dynamic_stiffness_response(net, f_hz, point):
    """X_point / X_base by nodal analysis in the frequency domain.

    Independent of bodyvib.runtime.network.linear_model: every spring is k, every
    damper c*s, every mass m*s^2, and the unknown displacements of all masses
    and nodes solve K(s) X = F(s) with the base displaced by 1.
    """
    springs, dampers = net.primitives()
    pts = list(net.mass_names) + list(net.node_names)
    idx = {p: i for i, p in enumerate(pts)}
    masses = net.mass_values()
    out = []
    for f in np.atleast_1d(f_hz):
        s = 2j * np.pi * f
        K = np.zeros((len(pts), len(pts)), complex)
        F = np.zeros(len(pts), complex)
        for a, b, z in [(a, b, k) for a, b, k in springs] + [(a, b, c * s) for a, b, c in dampers]:
            for p, q in ((a, b), (b, a)):
                if p in idx:
                    K[idx[p], idx[p]] += z
                    if q in idx:
                        K[idx[p], idx[q]] -= z
                    else:  # base, displaced by 1
                        F[idx[p]] += z
        for m, mv in masses.items():
            K[idx[m], idx[m]] += mv * s * s
        X = np.linalg.solve(K, F)
        out.append(X[idx[net.point(point)]])
    return np.array(out)


# -- a sine road and the co-simulation against a hand-written ODE ---------------------------

#: The sine road's amplitude and wavelength, m
SINE_AMPLITUDE_M, SINE_WAVELENGTH_M = 0.01, 5.0


def sine_road(x):
    """The road height: A (1 - cos(2 pi x / wavelength)) from x = 0, level before."""
    x = np.asarray(x, dtype=float)
    return np.where(x >= 0, SINE_AMPLITUDE_M * (1 - np.cos(2 * np.pi * x / SINE_WAVELENGTH_M)), 0.0)


def write_sine_road(path, length_m):
    """The sine road as a road file (distance in m, elevation in mm, every 1 cm)."""
    x = np.arange(0.0, length_m + 1e-9, 0.01)
    rows = "\n".join(f"{xi:.2f},{1e3 * zi:.15g}" for xi, zi in zip(x, sine_road(x)))
    path.write_text("distance_m,elevation_mm\n" + rows + "\n")
    return path


def car_dict(name):
    """The shipped car file ``name`` as the dict it holds (to change and load again)."""
    import json

    from bodyvib.vehicle.quarter_car import CAR_DIR

    with open(f"{CAR_DIR}/{name}.json", encoding="utf-8") as f:
        return json.load(f)


def linear_car_dict(name):
    """The shipped car file ``name`` made linear by hand: its tire contacts as springs, no
    stops, none of their outputs, parameters or static loads (what ``load_car(name,
    linear=True)`` must give, matrix for matrix)."""
    data = car_dict(name)
    data["elements"] = [
        {**e, "kind": "spring"} if e["kind"] == "contact" else e
        for e in data["elements"]
        if e["kind"] != "stop"
    ]
    data["fmu_outputs"] = [
        o for o in data["fmu_outputs"] if not o["name"].startswith(("tire_contact", "stop_force"))
    ]
    del data["static_loads"]
    stop = ("k_stop", "c_stop", "gap_compression", "gap_rebound", "m_occupant")
    for key in ("parameters", "units"):
        data[key] = {k: v for k, v in data[key].items() if not k.startswith(stop)}
    return data


def read_run_csv(path):
    """The columns of a ``bodyvib cosim --csv`` table by name (units dropped)."""
    import csv

    with open(path, newline="") as f:
        table = list(csv.reader(f))
    data = np.array(table[1:], dtype=float)
    return {h.split(" [")[0]: data[:, i] for i, h in enumerate(table[0])}


def assert_csv_is_the_cosim_engine(csv, case):
    """Assert that ``bodyvib cosim``'s CSV ``csv`` holds the road input and the head
    acceleration of the sweep's cosim engine on ``case``, sample for sample (the CSV keeps
    10 significant digits: rtol 1e-9). Returns that road displacement and acceleration."""
    from bodyvib.vehicle.sweep.engines import case_road_input, run_cosim

    data = np.genfromtxt(csv, delimiter=",", names=True)
    z, v = case_road_input(case)
    _, hist = run_cosim([case], record=True)
    a = hist[0]["head_acceleration"]
    for column, x in (
        ("road_displacement_m", z),
        ("road_velocity_ms", v),
        ("head_acceleration_ms2", a),
    ):
        np.testing.assert_allclose(data[column], x, rtol=1e-9, atol=1e-9 * np.abs(x).max())
    return z, a


def cosim_changed_car(car_fmu, body_fmu, changed, car, body, z, v, step):
    """Co-simulate ``car_fmu`` with the parameters ``changed`` set and ``body_fmu`` on the
    road input ``z, v``, and assert the head acceleration within the coupling error
    (NRMSE 5e-4) of the monolithic reference of ``car`` (the changed model) and ``body``.
    Returns the run and the reference."""
    from bodyvib.vehicle.cosim import cosimulate, open_fmu
    from bodyvib.vehicle.reference import nrmse, reference_run

    with (
        open_fmu(car_fmu, "car", "car", start_values=changed) as c,
        open_fmu(body_fmu, "body", "body") as b,
    ):
        run = cosimulate(c, b, z, v, step)
    ref = reference_run(car, body, z, v, step)
    assert nrmse(run["head_acceleration"], ref["head_acceleration"]) <= 5e-4
    return run, ref


def reduced_body_on_seat(b, s, y, x2, x1, v2, v1):
    """The hand-written reduced body on a seat point at height ``s``: the seat spring ks to
    the massless platform ``y``, k2 || c2 to the torso ``x2``, k1 || c1 to the head ``x1``
    (parameters ``b``). Returns the platform's rate, the torso's and the head's
    accelerations and the force on the seat point, ``ks (y - s)``."""
    yd = v2 + (b["ks"] * (s - y) + b["k2"] * (x2 - y)) / b["c2"]  # massless platform
    a1 = (b["k1"] * (x2 - x1) + b["c1"] * (v2 - v1)) / b["m1"]
    a2 = (b["ks"] * (s - y) + b["k1"] * (x1 - x2) + b["c1"] * (v1 - v2)) / b["m2"]
    return yd, a2, a1, b["ks"] * (y - s)


def nrmse_against_ode(rhs, states, t, y, after):
    """NRMSE of ``y`` at times ``t`` (from ``after`` on) against the output of the ODE
    ``rhs(t, q) -> (dq/dt, output)`` solved from rest by DOP853 (rtol 1e-10)."""
    from scipy.integrate import solve_ivp

    sol = solve_ivp(
        lambda t, q: rhs(t, q)[0],
        (0.0, t[-1]),
        np.zeros(states),
        method="DOP853",
        rtol=1e-10,
        atol=1e-13,
        t_eval=t,
        max_step=1e-3,
    )
    assert sol.success
    exact = np.array([rhs(tk, qk)[1] for tk, qk in zip(sol.t, sol.y.T)])
    keep = t >= after
    return np.sqrt(np.mean((y[keep] - exact[keep]) ** 2) / np.mean(exact[keep] ** 2))


@contextlib.contextmanager
def mount_tmpfs(folder, size):
    """A tmpfs of ``size`` (``"16k"``) mounted on ``folder`` for the block: a disk that fills.

    Yields True when mounted (unmounted at the end), False where the machine cannot mount
    one (not root, no ``mount``): the caller then injects the failure instead.
    """
    if os.geteuid() != 0 or shutil.which("mount") is None:
        yield False
        return
    proc = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)], capture_output=True
    )
    if proc.returncode != 0:
        yield False
        return
    try:
        yield True
    finally:
        subprocess.run(["umount", str(folder)], check=True)


def solve_switching(rhs, switches, q, mode, t_end):
    """``rhs(t, q, mode)`` integrated by scipy (DOP853, rtol 1e-10) from ``q`` at 0 to
    ``t_end``, stopped at each sign change of a switching function ``switches(t, q)[i]``
    (falling while ``mode[i]``, rising otherwise), ``mode[i]`` flipped there: the pieces
    ``(dense solution, start, end, mode)`` and the events ``(t, i, mode[i] after)``."""
    from scipy.integrate import solve_ivp

    t, mode = 0.0, np.array(mode, dtype=bool)
    pieces, events = [], []
    while t < t_end:
        evs = []
        for i in range(mode.size):

            def ev(tt, qq, _mode, i=i):  # solve_ivp passes args to events too
                return float(switches(tt, qq)[i])

            ev.terminal = True
            ev.direction = -1 if mode[i] else 1
            evs.append(ev)
        sol = solve_ivp(
            rhs,
            (t, t_end),
            q,
            method="DOP853",
            rtol=1e-10,
            atol=1e-13,
            events=evs,
            dense_output=True,
            args=(mode.copy(),),
            first_step=1e-6,
            max_step=1e-3,  # a bump of 50 ms: never stepped over
        )
        pieces.append((sol.sol, t, sol.t[-1], mode.copy()))
        t, q = sol.t[-1], sol.y[:, -1]
        if sol.status == 1:
            i = next(i for i in range(mode.size) if sol.t_events[i].size)
            mode[i] = not mode[i]
            events.append((t, i, bool(mode[i])))
    return pieces, events


def fmi2_model_exchange(path, folder, name):
    """An FMI 2.0 FMU's model-exchange instance, instantiated and initialized, and its
    model description: ``(md, instance)`` (fmpy's ``FMU2Model``; the caller frees it)."""
    from fmpy import extract, read_model_description

    md = read_model_description(path)
    return md, fmi2_initialized(md, extract(path, unzipdir=str(folder)), name)


def fmi2_initialized(md, unzipped, name, slave=False):
    """An FMI 2.0 instance of an extracted FMU, instantiated and initialized at ``t = 0``:
    fmpy's ``FMU2Model``, or its ``FMU2Slave`` with ``slave`` (the caller frees it)."""
    from fmpy.fmi2 import FMU2Model, FMU2Slave

    cls, interface = (FMU2Slave, md.coSimulation) if slave else (FMU2Model, md.modelExchange)
    fmu = cls(
        guid=md.guid,
        unzipDirectory=unzipped,
        modelIdentifier=interface.modelIdentifier,
        instanceName=name,
    )
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    return fmu
