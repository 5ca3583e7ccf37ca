"""A C program as the FMI host: the body FMUs run outside any Python host.

tests/c_host/fmi2_host.c is a minimal FMI 2.0 co-simulation host (dlopen, fmi2Instantiate
with a file:// resource URI, setup/initialization, setReal/doStep/getReal, terminate,
freeInstance, dlclose). It computes its own seat bump and prints every output with %.17g,
so this test compares a C program's view of the FMUs with the library's exact discrete
simulation (bodyvib.runtime.discretize.simulate), an independent code path. Values cross the FMI
boundary as doubles and the FMUs step exactly, so they agree to the core's 1e-9.

What the host needs, measured here (pyenv CPython 3.11.7 built with --enable-shared, numpy
in its own site-packages), given in an otherwise empty environment (not even PATH):

* LD_PRELOAD=<LIBDIR>/<LDLIBRARY>: pythonfmu's linux64 binary has undefined Py* symbols and
  no DT_NEEDED entry for libpython, so without it dlopen fails ("undefined symbol:
  _Py_NoneStruct").
* PYTHONHOME=sys.base_prefix: the embedded interpreter otherwise locates its standard
  library from the program name "python3", through PATH or in the working directory; with
  the pyenv shims first on PATH, or no PATH and a harmless working directory, it happens to
  find the right one, but PATH=/usr/bin (Debian's Python 3.11) or a host started in / or
  /usr gives it Debian's standard library and fmi2Instantiate fails ("No module named
  'math'"). The test uses a fake prefix to show this on any machine.
* PYTHONPATH=<numpy's folder> only when numpy is not in the prefix's own site-packages (a
  virtual environment, as in CI); untested here whether it is needed, since the base
  installation on this machine has numpy too.

Exit: pythonfmu 0.7.0's binary cannot be unloaded and its teardown at process exit touches
freed memory (see the comment in fmi2_host.c and bodyvib/runtime/teardown.py), which aborts some
runs. The host calls the binary's finalizePythonInterpreter after fmi2FreeInstance, and
then exits normally; valgrind shows that this removes the use of freed memory, and that
leaving the call out (--skip-finalize) brings it back.
"""

import os
import re
import shlex
import subprocess
import sys
import sysconfig

import numpy as np
import pytest
from memcheck import freed_memory_errors, memcheck

from bodyvib.models import load_model
from bodyvib.runtime.contract import BODY_OUTPUTS
from bodyvib.runtime.discretize import simulate
from bodyvib.runtime.network import linear_model

pytestmark = pytest.mark.integration

from helpers import ROOT, compile_c_host

HOST_SOURCE = os.path.join(ROOT, "tests", "c_host", "fmi2_host.c")
MODEL_OF = {"HumanBody3DOF": "reduced-paper", "HumanBodyISO7962": "iso7962"}
BODY_OUT = list(BODY_OUTPUTS[:4])  # the four the host reads (not seat_force_rate)
BODY_SIG = ["head.a", "head.x", "torso.x", "seat_force"]
BUMP = (0.02, 0.1, 0.1)  # height m, start s, length s: BUMP_* in fmi2_host.c
STEP, N_STEPS = 1e-3, 400
FMI_OK, FMI_DISCARD = 0, 2


def libpython():
    """The running interpreter's shared libpython (skip if it was built without one)."""
    path = os.path.join(
        sysconfig.get_config_var("LIBDIR") or "", sysconfig.get_config_var("LDLIBRARY") or ""
    )
    if not sysconfig.get_config_var("Py_ENABLE_SHARED") or not os.path.isfile(path):
        pytest.skip(
            f"{sys.executable} was built without a shared libpython ({path}); a C host "
            "cannot run pythonfmu FMUs with it"
        )
    return path


def host_env(preload=True, home=True):
    """The whole environment the C host gets (nothing else, not even PATH).

    LD_PRELOAD: the running interpreter's libpython (the FMU binary does not link it).
    PYTHONHOME: that interpreter's prefix. Without it the embedded interpreter locates its
    standard library from the program name "python3": through PATH, or in the working
    directory, so another python3 first on PATH or a working directory that looks like a
    Python prefix gives it a foreign standard library (see the test below).
    PYTHONPATH: numpy's folder, only if that is not the prefix's own site-packages (a
    virtual environment), since the embedded interpreter knows nothing of the venv.
    """
    import numpy

    env = {"LD_PRELOAD": libpython()} if preload else {}
    if home:
        env["PYTHONHOME"] = (
            sys.base_prefix
            if sys.base_prefix == sys.base_exec_prefix
            else f"{sys.base_prefix}:{sys.base_exec_prefix}"
        )
    site = os.path.dirname(os.path.dirname(numpy.__file__))
    base = sysconfig.get_paths(vars={"base": sys.base_prefix, "platbase": sys.base_exec_prefix})
    if os.path.realpath(site) not in {
        os.path.realpath(base["purelib"]),
        os.path.realpath(base["platlib"]),
    }:
        env["PYTHONPATH"] = site
    return env


@pytest.fixture(scope="module")
def host(tmp_path_factory):
    exe = str(tmp_path_factory.mktemp("c_host") / "fmi2_host")
    flags = ("-O2", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off")
    return compile_c_host([HOST_SOURCE], exe, flags)


@pytest.fixture(scope="module")
def fmus(python_fmus):
    """The two body FMUs (built once per session, tests/conftest.py): name -> .fmu path."""
    return {name: python_fmus[name] for name in MODEL_OF}


def extracted(path, folder):
    """Extract an FMU into a new folder; the host's FMU arguments from modelDescription.xml."""
    from fmpy import extract, read_model_description

    md = read_model_description(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    return [
        str(extract(path, unzipdir=str(folder))),
        md.coSimulation.modelIdentifier,
        md.guid,
        f"{vr['seat_displacement']},{vr['seat_velocity']}",
        ",".join(str(vr[n]) for n in BODY_OUT),
    ]


def run_host(host, fmu_args, *options, env=None, cwd=None):
    return subprocess.run(
        [host, *options, *fmu_args, repr(STEP), str(N_STEPS)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=cwd,
        env=host_env() if env is None else env,
    )


def parse(stdout):
    """Rows ``k t x v y... status`` and the other lines."""
    rows, other = [], []
    for line in stdout.splitlines():
        (rows if line[:1].isdigit() else other).append(line)
    return np.array([[float(f) for f in r.split()] for r in rows]), other


def seat_bump(t):
    height, start, length = BUMP
    return height * np.maximum(0.0, 1.0 - np.abs(2.0 * (t - start) / length - 1.0))


def reference(name):
    t = np.arange(N_STEPS + 2) * STEP
    x = seat_bump(t)
    v = (x[1:] - x[:-1]) / STEP  # slope over the coming step
    t, x = t[:-1], x[:-1]
    lm = linear_model(load_model(MODEL_OF[name]))
    _, y = simulate(lm, t, np.c_[x, v])
    return t, x, v, y[:, [lm.output_index(s) for s in BODY_SIG]]


def rel_err(a, b):
    return np.max(np.abs(a - b), axis=0) / np.max(np.abs(b), axis=0)


def check_run(run, name):
    """Clean run: exit 0 after dlclose, every step fmi2OK, outputs = library to 1e-9."""
    assert run.returncode == 0, run.stderr[-3000:]
    rows, other = parse(run.stdout)
    assert other[-4:] == [f"terminate {FMI_OK}", "done", "finalized", "closed"]
    t, x, v, ref = reference(name)
    assert rows.shape == (N_STEPS + 1, 5 + len(BODY_OUT))
    np.testing.assert_array_equal(rows[:, 0], np.arange(N_STEPS + 1))
    np.testing.assert_allclose(rows[:, 1], t, rtol=1e-15, atol=0)
    # the C bump is the numpy bump (same IEEE operations, no contraction)
    np.testing.assert_allclose(rows[:, 2], x, rtol=0, atol=1e-15 * BUMP[0])
    np.testing.assert_allclose(rows[:, 3], v, rtol=0, atol=1e-12 * np.abs(v).max())
    assert set(rows[:-1, -1]) == {FMI_OK} and rows[-1, -1] == -1
    err = rel_err(rows[:, 4:-1], ref)
    assert np.all(err < 1e-9), dict(zip(BODY_OUT, err))
    return rows, other


@pytest.mark.parametrize("name", list(MODEL_OF))
def test_c_host_outputs_equal_library(host, fmus, name, tmp_path):
    """Each run is from a freshly extracted FMU (the embedded Python compiles its modules
    and writes their bytecode)."""
    run = run_host(host, extracted(fmus[name], tmp_path))
    check_run(run, name)
    assert "[log]" not in run.stderr  # nothing to complain about


def test_c_host_exit_does_not_touch_freed_memory(host, fmus, tmp_path):
    """pythonfmu 0.7.0's exit-time teardown writes into a freed block unless
    finalizePythonInterpreter runs first. A host may call it (fmi2_host.c, "Exit"); a host
    that does not (--skip-finalize, as the FMU Compliance Checker) now gets it from the C
    exit handler the FMU registers (bodyvib.runtime.teardown). Under valgrind neither run
    has an invalid access in that function (without the FMU's handler the --skip-finalize
    run had one: the check sees the bug when it is there). Both runs exit 0: the damage is
    silent here, which is why valgrind is the judge."""
    args = extracted(fmus["HumanBody3DOF"], tmp_path)
    runs = {
        opt: memcheck([host, *opt, *args, repr(STEP), str(N_STEPS)], env=host_env())
        for opt in [(), ("--skip-finalize",)]
    }
    logs = {}
    for opt, proc in runs.items():
        stdout, logs[opt] = proc.communicate(timeout=600)
        assert proc.returncode == 0, logs[opt][-3000:]
        assert stdout.splitlines()[-1] == "closed"
    for opt in runs:
        assert freed_memory_errors(logs[opt], "finalizePythonInterpreter") == [], opt


def test_nan_input_is_discarded_and_the_host_carries_on(host, fmus, tmp_path):
    """NaN seat displacement at t = 0.15 s (mid-bump): fmi2DoStep returns fmi2Discard (not
    fmi2Error/fmi2Fatal), the reason reaches the C logger at error level, the state is left
    unchanged (the rest equals the uninterrupted reference) and the host terminates cleanly."""
    name = "HumanBodyISO7962"
    run = run_host(host, extracted(fmus[name], tmp_path), "--nan-step", "150")
    rows, other = check_run(run, name)
    assert other[0] == f"refused 150 {FMI_DISCARD}"
    logs = [line for line in run.stderr.splitlines() if line.startswith("[log]")]
    assert len(logs) == 1
    assert logs[0].startswith("[log] c_host fmi2Error ")
    assert "seat_displacement = nan" in logs[0] and "not finite" in logs[0]


def test_without_libpython_preloaded_the_fmu_binary_does_not_load(host, fmus, tmp_path):
    """The claim of docs/tutorials/fmu_hosts.md, "FMUs" that a non-Python host must preload libpython: pythonfmu's binary
    does not link libpython, so dlopen (RTLD_NOW) fails on an undefined Python symbol."""
    env = host_env(preload=False)
    run = run_host(host, extracted(fmus["HumanBody3DOF"], tmp_path), env=env)
    assert run.returncode == 2, run.stderr
    assert "dlopen failed" in run.stderr and "undefined symbol: _Py" in run.stderr
    assert run.stdout == ""


def fake_prefix(folder):
    """A folder that looks like a Python prefix to CPython's start-up (lib/pythonX.Y/os.py,
    bin/python3) but has no standard library."""
    fake = folder / "fake-prefix"
    stdlib = fake / "lib" / f"python{sys.version_info.major}.{sys.version_info.minor}"
    stdlib.mkdir(parents=True)
    (stdlib / "os.py").write_text("")
    (fake / "bin").mkdir()
    (fake / "bin" / "python3").write_text("#!/bin/sh\n")
    (fake / "bin" / "python3").chmod(0o755)
    return fake


@pytest.mark.parametrize("where", ["working directory", "PATH"])
def test_without_pythonhome_a_foreign_prefix_takes_over(host, fmus, tmp_path, where):
    """Why docs/tutorials/fmu_hosts.md, "FMUs" sets PYTHONHOME. Without it, the interpreter the FMU starts looks for
    its standard library next to the "python3" it finds on PATH, or in the host's working
    directory. A fake prefix there (lib/pythonX.Y/os.py, no real standard library; on this
    machine /usr/bin/python3, Debian's, or a host started in / or /usr do the same) makes
    the host fail; with PYTHONHOME the same run is clean."""
    fake = fake_prefix(tmp_path)
    args = extracted(fmus["HumanBody3DOF"], tmp_path / "fmu")
    extra = {"PATH": str(fake / "bin")} if where == "PATH" else {}
    cwd = str(fake) if where == "working directory" else str(tmp_path)
    bad = run_host(host, args, env={**host_env(home=False), **extra}, cwd=cwd)
    assert bad.returncode != 0 and "closed" not in bad.stdout
    assert "No module named 'encodings'" in bad.stderr, bad.stderr[-2000:]
    check_run(run_host(host, args, env={**host_env(), **extra}, cwd=cwd), "HumanBody3DOF")


def test_documented_command_runs_the_c_host(host, fmus, tmp_path):
    """The non-Python-host command of docs/tutorials/fmu_hosts.md, "FMUs", verbatim, with PY
    and 'host ...' filled in, run with a fake Python prefix first on PATH and as the working
    directory (the cases PYTHONHOME is for)."""
    with open(os.path.join(ROOT, "docs", "tutorials", "fmu_hosts.md"), encoding="utf-8") as f:
        page = f.read()
    section = page[page.index("## FMUs") :]
    section = section[: section.index("\n## ", 5)]
    (block,) = [b for b in re.findall(r"```bash\n(.*?)```", section, re.S) if "LD_PRELOAD" in b]
    args = extracted(fmus["HumanBody3DOF"], tmp_path / "fmu")
    command = " ".join(shlex.quote(a) for a in [host, *args, repr(STEP), str(N_STEPS)])
    assert block.startswith("PY=python3 ") and block.rstrip().endswith("host ...")
    script = (
        f"PY={shlex.quote(sys.executable)} " + block.split(" ", 1)[1].rstrip()[: -len("host ...")]
    )
    env = {
        k: v for k, v in os.environ.items() if k not in ("LD_PRELOAD", "PYTHONHOME", "PYTHONPATH")
    }
    env.update({k: v for k, v in host_env().items() if k == "PYTHONPATH"})  # the venv case
    fake = fake_prefix(tmp_path)
    env["PATH"] = os.pathsep.join([str(fake / "bin"), env.get("PATH", os.defpath)])
    run = subprocess.run(
        ["bash", "-c", script + command],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
        cwd=str(fake),
    )
    check_run(run, "HumanBody3DOF")


def test_null_arrays_to_get_real_crash_inside_pythonfmus_wrapper(host, fmus, tmp_path):
    """``fmi2GetReal(c, NULL, 3, NULL)``: the native FMU returns
    fmi2Error; a pythonfmu FMU cannot. pythonfmu 0.7.0's ``PySlaveInstance::GetReal`` reads
    ``vr[0..2]`` to build the Python list before the slave's code runs, so the host dies of
    SIGSEGV in the wrapper: nothing a slave can change. This test pins that limit (the
    documentation states it); it fails, and should be turned around, once pythonfmu checks its
    arguments."""
    import signal

    run = run_host(host, extracted(fmus["HumanBody3DOF"], tmp_path), "--null-get", "5")
    assert run.returncode == -signal.SIGSEGV, (run.returncode, run.stderr[-2000:])
    rows, other = parse(run.stdout)
    assert not [line for line in other if line.startswith("nullget")]  # never returned
