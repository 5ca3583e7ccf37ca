"""The real FMUs, built with pythonfmu, run by real importers (fmpy, libcosimpy).

The FMUs are built once per session, in a subprocess (a module name loaded by
an FMU is global to the process). References are the library's exact discrete
simulation (bodyvib.runtime.discretize.simulate, checked against Radau in
test_discretize.py). Values cross the FMI boundary as doubles, so FMU2Slave
runs must agree to the core's 1e-9; importer runs to the issue's 1e-6.

pythonfmu 0.7.0 status mapping (measured; see fmu_src/): a refused step
(do_step returns False) is fmi2Discard, any Python exception is fmi2Fatal, so
the slaves never raise.
"""

import json
import os
import re
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

from bodyvib.models import load_model, save_model
from bodyvib.runtime.contract import BODY_OUTPUTS, CAR_INPUTS, CAR_OUTPUTS
from bodyvib.runtime.discretize import simulate
from bodyvib.runtime.network import linear_model
from bodyvib.vehicle.quarter_car import CAR_FMU_OUTPUTS, load_car

pytestmark = pytest.mark.integration

from helpers import ROOT, run_cli

NAMES = ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar")
MODEL_OF = {"HumanBody3DOF": "reduced-paper", "HumanBodyISO7962": "iso7962"}
BODY_RATE = "seat_force_rate"
BODY_OUT = [n for n in BODY_OUTPUTS if n != BODY_RATE]
BODY_SIG = ["head.a", "head.x", "torso.x", "seat_force"]
CAR_IN = list(CAR_INPUTS)
CAR_OUT = list(CAR_OUTPUTS + CAR_FMU_OUTPUTS)
CAR_SIG = ["sprung.x", "sprung.v", "sprung.a", "suspension.deflection", "tire.force"]
FMI_DISCARD = 2


@pytest.fixture(scope="session")
def fmus(python_fmus):
    return {n: python_fmus[n] for n in NAMES}


def piecewise_linear(t, every=25, scale=0.01, seed=3):
    """Displacement linear between random knots on grid points, and its slope per step.

    Linear within every step, so the FMU's in-step extrapolation is exact and the
    outputs read right after doStep (libcosim, fmpy's simulate_fmu) are the
    library's outputs at the step's end.
    """
    rng = np.random.default_rng(seed)
    knots = np.arange(0, t.size + every, every)
    heights = scale * rng.standard_normal(knots.size)
    heights[0] = 0.0
    x = np.interp(np.arange(t.size), knots, heights)
    v = np.append(np.diff(x) / np.diff(t), 0.0)
    return x, v


def body_reference(model, t, x, v):
    lm = linear_model(load_model(model) if isinstance(model, str) else model)
    _, y = simulate(lm, t, np.c_[x, v])
    return y[:, [lm.output_index(s) for s in BODY_SIG]]


def rel_err(a, b):
    return np.max(np.abs(a - b), axis=0) / np.max(np.abs(b), axis=0)


class Slave:
    """fmpy FMU2Slave with captured log messages."""

    def __init__(self, path, name="instance", params=None, initialize=True):
        import shutil
        import tempfile
        import weakref

        from fmpy import calloc, extract, free, read_model_description
        from fmpy.fmi2 import (
            FMU2Slave,
            fmi2CallbackAllocateMemoryTYPE,
            fmi2CallbackFreeMemoryTYPE,
            fmi2CallbackFunctions,
            fmi2CallbackLoggerTYPE,
        )

        self.md = read_model_description(path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.messages = []
        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(
            lambda env, inst, status, cat, msg: self.messages.append((status, msg.decode()))
        )
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        # extracted into a folder of its own, deleted by close() (or, at the latest,
        # when the Slave is collected or the process exits)
        unzipdir = extract(path, unzipdir=tempfile.mkdtemp(prefix="bodyvib-test-fmu-"))
        self._cleanup = weakref.finalize(self, shutil.rmtree, unzipdir, True)
        self.fmu = FMU2Slave(
            guid=self.md.guid,
            unzipDirectory=unzipdir,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName=name,
        )
        self.fmu.instantiate(callbacks=cb, loggingOn=True)
        if initialize:
            self.init(params)

    def init(self, params=None):
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for k, val in (params or {}).items():
            self.fmu.setReal([self.vr[k]], [val])
        self.fmu.exitInitializationMode()

    def set(self, names, values):
        self.fmu.setReal([self.vr[n] for n in names], list(map(float, values)))

    def get(self, names):
        return self.fmu.getReal([self.vr[n] for n in names])

    def run(self, t, inputs, in_names, out_names, read_before_set=False):
        y = np.empty((t.size, len(out_names)))
        for k in range(t.size):
            if read_before_set and k > 0:
                y[k] = self.get(out_names)
                self.set(in_names, inputs[k])
            else:
                self.set(in_names, inputs[k])
                y[k] = self.get(out_names)
            if k + 1 < t.size:
                self.fmu.doStep(
                    currentCommunicationPoint=t[k], communicationStepSize=t[k + 1] - t[k]
                )
        return y

    def close(self):
        try:
            self.fmu.terminate()
            self.fmu.freeInstance()
        finally:
            self._cleanup()


def smooth_seat(t):
    w = 2 * np.pi * np.array([1.3, 4.4, 11.0])
    a = np.array([0.004, 0.002, 0.0005])
    return (a * np.sin(np.outer(t, w))).sum(1), (a * w * np.cos(np.outer(t, w))).sum(1)


# -- build and model description ---------------------------------------------------


def test_fmpy_validate_reports_no_problems(fmus):
    from fmpy.validation import validate_fmu

    for name in NAMES:
        assert validate_fmu(fmus[name]) == [], name


def documented_interface(heading):
    """Name -> (causality, unit) of the table under ``heading`` in docs/architecture.md:
    its rows that name one input or output."""
    with open(os.path.join(ROOT, "docs", "architecture.md"), encoding="utf-8") as f:
        table = f.read().split(heading, 1)[1].split("\n\n", 2)[1]
    rows = {}
    for line in table.splitlines()[2:]:  # below the header and its rule
        cells = [c.strip() for c in line.strip("|").split("|")]
        causality = cells[2].split()[0]
        if re.fullmatch(r"`\w+`", cells[1]) and causality in ("input", "output"):
            rows[cells[1].strip("`")] = (causality, cells[3])
    return rows


@pytest.mark.parametrize("name", NAMES)
def test_model_description_interface(fmus, name):
    """Names, causality, units of the FMU contract (docs/architecture.md); parameters with the parameter
    file's values as start, positive min; ModelStructure with all outputs."""
    with zipfile.ZipFile(fmus[name]) as zf:
        root = ET.fromstring(zf.read("modelDescription.xml"))
        files = zf.namelist()
    svs = {sv.get("name"): sv for sv in root.iter("ScalarVariable")}
    if name != "QuarterCar":
        expected = documented_interface("Body FMU (")
    else:  # the prose under the table names the shipped cars' `fmu_outputs`
        expected = documented_interface("Car FMU (")
        expected.update(sprung_acceleration=("output", "m/s2"), tire_force=("output", "N"))
        expected.update(suspension_deflection=("output", "m"))
    for var, (causality, unit) in expected.items():
        assert svs[var].get("causality") == causality
        assert svs[var].find("Real").get("unit") == unit
        assert svs[var].get("description")
    net = load_car() if name == "QuarterCar" else load_model(MODEL_OF[name])
    params = {n: sv for n, sv in svs.items() if sv.get("causality") == "parameter"}
    assert set(params) == set(net.parameters)
    for n, sv in params.items():
        real = sv.find("Real")
        assert float(real.get("start")) == net.parameters[n]
        assert float(real.get("min")) > 0
        assert real.get("unit") in ("kg", "N/m", "N.s/m", "m")  # m: a stop's gaps
    outputs = [u.get("index") for u in root.find("ModelStructure/Outputs")]
    assert len(outputs) == sum(sv.get("causality") == "output" for sv in svs.values())
    index = {sv.get("name"): str(i + 1) for i, sv in enumerate(root.iter("ScalarVariable"))}
    deps = {
        u.get("index"): u.get("dependencies").split() for u in root.find("ModelStructure/Outputs")
    }
    if (
        name != "QuarterCar"
    ):  # the exact dependencies: seat force on the displacement, its rate on both
        assert svs[BODY_RATE].get("causality") == "output"
        assert svs[BODY_RATE].find("Real").get("unit") == "N/s"
        assert deps[index["seat_force"]] == [index["seat_displacement"]]
        assert deps[index[BODY_RATE]] == [index["seat_displacement"], index["seat_velocity"]]
        assert deps[index["head_acceleration"]] == []
    # private, hashed module names: nothing called bodyvib inside the FMU
    mods = {f.split("/")[1] for f in files if f.startswith("resources/")}
    assert not any(m in ("bodyvib", "bodyvib.py", "vehicle") for m in mods)
    assert any(m.startswith(f"bodyvib_rt_{name.lower()}_") for m in mods)


def test_params_file_is_baked_into_humanbody3dof(fmus, tmp_path):
    """`bodyvib build --params FILE`: the FMU starts from the file's values and runs them,
    also beside the default HumanBody3DOF.fmu in the same process (different hashed names)."""
    net = load_model("reduced-paper").with_parameters(m1=5.5, c1=400.0)
    save_model(net, tmp_path / "refit.json")
    args = ["--params", str(tmp_path / "refit.json"), "--fmus", "HumanBody3DOF"]
    out = run_cli("build", *args, "--dest", str(tmp_path), cwd=ROOT, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "HumanBody3DOF.fmu" in out.stdout
    code = textwrap.dedent(f"""
        import json, sys
        sys.path.insert(0, {os.path.join(ROOT, "tests")!r})
        import numpy as np
        from test_fmu_integration import Slave, piecewise_linear, BODY_OUT
        t = np.arange(0, 0.5, 1e-3)
        x, v = piecewise_linear(t)
        out = []
        for path in sys.argv[1:]:  # the refit and the default FMU, side by side in one process
            s = Slave(path, name=path)
            out.append([s.get(['m1', 'c1']), s.run(t, np.c_[x, v], ['seat_displacement',
                                                                    'seat_velocity'], BODY_OUT).tolist()])
        print(json.dumps(out))
    """)
    run = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path / "HumanBody3DOF.fmu"), fmus["HumanBody3DOF"]],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    (params, y), (params0, y0) = json.loads(run.stdout.strip().splitlines()[-1])
    assert params == [5.5, 400.0] and params0 == [4.88, 333.0]
    t = np.arange(0, 0.5, 1e-3)
    x, v = piecewise_linear(t)
    assert np.all(rel_err(np.array(y), body_reference(net, t, x, v)) < 1e-9)
    assert np.all(rel_err(np.array(y0), body_reference("reduced-paper", t, x, v)) < 1e-9)


def test_build_in_a_process_that_already_ran_an_fmu(fmus, tmp_path):
    """Once a pythonfmu FMU has run in a process, 'pythonfmu' there is the FMU's
    embedded copy (no binaries): building must still give a complete, working FMU."""
    code = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {os.path.join(ROOT, "tests")!r})
        from test_fmu_integration import Slave
        s = Slave({fmus["QuarterCar"]!r}, name='first')
        s.fmu.doStep(0.0, 1e-3)
        import pythonfmu
        print(pythonfmu.__file__)
        from bodyvib.vehicle.fmus import build_project_fmu
        path = build_project_fmu('QuarterCar', {str(tmp_path)!r})
        t = Slave(str(path), name='second')
        for fmu in (s, t):  # the same inputs from the same state: identical outputs
            fmu.set(['road_displacement', 'road_velocity', 'seat_force'], [0.01, 0.3, 100.0])
            fmu.fmu.doStep(1e-3, 1e-3)
        print(s.get(['tire_force'])[0] == t.get(['tire_force'])[0] != 0.0)
    """)
    run = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT
    )
    assert run.returncode == 0, run.stderr[-3000:]
    embedded, same = run.stdout.split()[-2:]
    assert "site-packages" not in embedded  # the situation this test is about
    assert same == "True"


def test_bad_params_file_is_refused_by_the_build_command(tmp_path):
    (tmp_path / "bad.json").write_text('{"name": "x"}')
    out = run_cli(
        "build",
        "--params",
        str(tmp_path / "bad.json"),
        "--dest",
        str(tmp_path),
        cwd=ROOT,
        timeout=120,
    )
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and "missing field" in out.stderr
    assert not (tmp_path / "HumanBody3DOF.fmu").exists()


# -- importers -------------------------------------------------------------------


@pytest.mark.parametrize("name", ["HumanBody3DOF", "HumanBodyISO7962"])
def test_fmpy_simulate_fmu_example_agrees_with_library(fmus, name):
    """examples/fmu_from_fmpy.run: fmpy records outputs right after each doStep,
    before it applies the next input, so this also checks end-of-step outputs."""
    sys.path.insert(0, os.path.join(ROOT, "examples"))
    try:
        from fmu_from_fmpy import run, seat_bump
    finally:
        sys.path.pop(0)
    res = run(fmus[name], duration=1.0, step=1e-3)
    t = np.arange(1001) * 1e-3
    np.testing.assert_allclose(res["time"], t, rtol=0, atol=1e-12)
    x, v = seat_bump(t)
    ref = body_reference(MODEL_OF[name], t, x, v)
    y = np.column_stack([res[n] for n in BODY_OUT])
    assert np.all(rel_err(y, ref) < 1e-6), rel_err(y, ref)


def check_fmpy_snippet(code, fmu, tmp_path, capfd, monkeypatch):
    """Run a page's fmpy snippet as a reader pastes it next to ``dist/``: every input of
    the FMU given (fmpy prints a warning for one left out), and the run is the example's.
    tests/test_readme.py runs the short front page's with it."""
    os.makedirs(tmp_path / "dist")
    with open(fmu, "rb") as src, open(tmp_path / "dist" / "HumanBody3DOF.fmu", "wb") as dst:
        dst.write(src.read())
    monkeypatch.chdir(tmp_path)
    namespace = {}
    exec(compile(code, "snippet", "exec"), namespace)
    out, err = capfd.readouterr()
    assert "Warning" not in out + err and "missing input" not in out + err, out + err
    sys.path.insert(0, os.path.join(ROOT, "examples"))
    try:
        from fmu_from_fmpy import run
    finally:
        sys.path.pop(0)
    example = run(fmu, duration=1.0, step=1e-3)
    assert "Warning" not in capfd.readouterr().out
    for name in ("head_acceleration", "seat_force"):
        # a snippet's slope may divide by 1e-3, not by the grid's differences: a few ulps
        np.testing.assert_allclose(namespace["res"][name], example[name], rtol=1e-12, atol=0)


def test_the_tutorial_fmpy_snippet_runs_as_written(fmus, tmp_path, capfd, monkeypatch):
    text = open(os.path.join(ROOT, "docs", "tutorials", "fmu_hosts.md"), encoding="utf-8").read()
    code = text.split("From fmpy (", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    check_fmpy_snippet(code, fmus["HumanBody3DOF"], tmp_path, capfd, monkeypatch)


def test_the_fmpy_command_line_of_the_tutorial_runs_as_written(fmus, tmp_path):
    """The tutorial's two commands, in one folder: the example leaves ``seat_bump.csv``
    there for ``fmpy simulate``, which then runs as written (once it was deleted)."""
    text = open(os.path.join(ROOT, "docs", "tutorials", "fmu_hosts.md"), encoding="utf-8").read()
    block = text.split("From fmpy's command line", 1)[1].split("```bash\n", 1)[1].split("```", 1)[0]
    lines = block.replace("\\\n", " ").splitlines()
    assert [ln.split()[:2] for ln in lines] == [
        ["python", "examples/fmu_from_fmpy_cli.py"],
        ["fmpy", "simulate"],
    ]
    os.makedirs(tmp_path / "dist")
    with (
        open(fmus["HumanBody3DOF"], "rb") as src,
        open(tmp_path / "dist" / "HumanBody3DOF.fmu", "wb") as dst,
    ):
        dst.write(src.read())
    os.symlink(os.path.join(ROOT, "examples"), tmp_path / "examples")
    env = {**os.environ, "PATH": os.path.dirname(sys.executable) + os.pathsep + os.environ["PATH"]}
    for line in lines:
        out = subprocess.run(
            line.split(), cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
        )
        assert out.returncode == 0 and "Warning" not in out.stdout + out.stderr, (
            line,
            out.stdout + out.stderr,
        )
        assert (tmp_path / "seat_bump.csv").exists() and (tmp_path / "result.csv").exists()


@pytest.mark.parametrize("grid", ["fixed", "varying"])
@pytest.mark.parametrize("name", ["HumanBody3DOF", "HumanBodyISO7962"])
def test_fmu2slave_equals_library_fixed_and_varying_steps(fmus, name, grid):
    t = (
        np.arange(0, 1.0, 1e-3)
        if grid == "fixed"
        else np.concatenate([[0.0], np.cumsum(np.random.default_rng(5).uniform(2e-4, 3e-3, 600))])
    )
    x, v = smooth_seat(t)
    s = Slave(fmus[name])
    y = s.run(t, np.c_[x, v], ["seat_displacement", "seat_velocity"], BODY_OUT)
    s.close()
    assert np.all(rel_err(y, body_reference(MODEL_OF[name], t, x, v)) < 1e-9)


def test_outputs_right_after_do_step_are_those_of_the_step_end(fmus):
    t = np.arange(0, 0.6, 1e-3)
    x, v = piecewise_linear(t)
    s = Slave(fmus["HumanBody3DOF"])
    y = s.run(
        t, np.c_[x, v], ["seat_displacement", "seat_velocity"], BODY_OUT, read_before_set=True
    )
    s.close()
    assert np.all(rel_err(y, body_reference("reduced-paper", t, x, v)) < 1e-9)


@pytest.mark.parametrize("grid", ["fixed", "varying"])
def test_quarter_car_equals_library(fmus, grid):
    """QuarterCar: seat_force enters as -seat_force on the sprung mass, its slope
    from seat_force_rate; road displacement rises at road velocity."""
    t = (
        np.arange(0, 1.0, 1e-3)
        if grid == "fixed"
        else np.concatenate([[0.0], np.cumsum(np.random.default_rng(9).uniform(2e-4, 3e-3, 600))])
    )
    zr, vr = smooth_seat(t)
    fs, dfs = 400 * np.sin(2 * np.pi * 2 * t), 400 * 2 * np.pi * 2 * np.cos(2 * np.pi * 2 * t)
    s = Slave(fmus["QuarterCar"])
    y = s.run(t, np.c_[zr, vr, fs, dfs], CAR_IN, CAR_OUT)
    s.close()
    lm = linear_model(load_car())
    _, ref = simulate(lm, t, np.c_[zr, vr, -fs], np.c_[vr, 0 * t, -dfs])
    ref = ref[:, [lm.output_index(c) for c in CAR_SIG]]
    assert np.all(rel_err(y, ref) < 1e-9)


def test_libcosimpy_runs_both_body_fmus(fmus):
    """examples/fmu_from_libcosimpy.run in a subprocess: libcosim reads outputs after
    doStep and before new inputs; on a piecewise-linear seat motion those are the
    library's outputs at the step's end."""
    t = np.arange(0, 0.8 + 5e-4, 1e-3)
    x, v = piecewise_linear(t, seed=11)
    code = textwrap.dedent(f"""
        import json, sys
        import numpy as np
        sys.path.insert(0, {os.path.join(ROOT, "examples")!r})
        from fmu_from_libcosimpy import run
        x, v = np.array(json.loads(sys.argv[1]))
        out = {{}}
        for path in sys.argv[2:]:
            res = run(path, x, v, step=1e-3)
            out[path] = {{k: r.tolist() for k, r in res.items()}}
        print(json.dumps(out))
    """)
    paths = [fmus["HumanBody3DOF"], fmus["HumanBodyISO7962"]]
    run = subprocess.run(
        [sys.executable, "-c", code, json.dumps([x.tolist(), v.tolist()])] + paths,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    res = json.loads(run.stdout.strip().splitlines()[-1])
    for path, model in zip(paths, ["reduced-paper", "iso7962"]):
        np.testing.assert_allclose(res[path]["time"], t[1:], atol=1e-12)
        y = np.column_stack([res[path][n] for n in BODY_OUT])
        ref = body_reference(model, t, x, v)[1:]
        assert np.all(rel_err(y, ref) < 1e-6), (model, rel_err(y, ref))


def test_documented_fmu_snippets_run(fmus):
    """The fmpy and libcosimpy snippets of docs/tutorials/fmu_hosts.md, "FMUs", as written
    (paths pointed at this build)."""
    import re

    with open(os.path.join(ROOT, "docs", "tutorials", "fmu_hosts.md"), encoding="utf-8") as f:
        page = f.read()
    section = page[page.index("## FMUs") :]
    section = section[: section.index("\n## ", 5)]
    code = "\n".join(re.findall(r"```python\n(.*?)```", section, re.S))
    code = code.replace("dist/HumanBody3DOF.fmu", fmus["HumanBody3DOF"].replace("\\", "/"))
    run = subprocess.run(
        [sys.executable, "-c", code + "\nprint(float(res['seat_force'][150]), seat_force)"],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    f_fmpy, f_cosim = map(float, run.stdout.split()[-2:])
    t = np.arange(1001) * 1e-3
    x = 0.02 * np.clip(1 - np.abs(2 * (t - 0.1) / 0.1 - 1), 0, None)
    ref = body_reference("reduced-paper", t, x, np.append(np.diff(x) / 1e-3, 0.0))
    assert f_fmpy == pytest.approx(ref[150, 3], rel=1e-6)
    assert f_cosim == pytest.approx(ref[-1, 3], rel=1e-6, abs=1e-9 * np.abs(ref[:, 3]).max())


# -- robustness ---------------------------------------------------------------------


@pytest.mark.parametrize(
    "name, value", [("m1", 0.0), ("m2", -3.0), ("k2", -1.0), ("c1", float("nan"))]
)
def test_invalid_parameter_refused_at_initialization_with_reason(fmus, name, value):
    """Refused at fmi2ExitInitializationMode with the reason logged at error level;
    every step is then refused (fmi2Discard), never fmi2Fatal. (pythonfmu gives
    exitInitializationMode no error status short of fmi2Fatal, after which its
    fmi2FreeInstance releases Python objects twice and crashes the host later.)"""
    from fmpy.fmi1 import FMICallException

    s = Slave(fmus["HumanBody3DOF"], initialize=False)
    s.init({name: value})
    assert any(
        status == 3 and f"parameter {name} =" in m and "positive finite" in m
        for status, m in s.messages
    )
    for k in range(2):
        with pytest.raises(FMICallException) as exc:
            s.fmu.doStep(k * 1e-3, 1e-3)
        assert exc.value.status == FMI_DISCARD
        assert f"parameter {name} =" in s.messages[-1][1]
    s.close()
    other = Slave(fmus["HumanBody3DOF"], name="other")  # other instances are unaffected
    other.fmu.doStep(0.0, 1e-3)
    other.close()


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_non_finite_input_refused_without_fatal(fmus, bad):
    from fmpy.fmi1 import FMICallException

    t = np.arange(0, 0.3, 1e-3)
    x, v = smooth_seat(t)
    ref = body_reference("iso7962", t, x, v)
    s = Slave(fmus["HumanBodyISO7962"])
    y = np.empty_like(ref)
    for k in range(t.size):
        if k == 100:
            s.set(["seat_displacement"], [bad])
            with pytest.raises(FMICallException) as exc:
                s.fmu.doStep(t[k], t[k + 1] - t[k])
            assert exc.value.status == FMI_DISCARD  # refused, instance alive (not fmi2Fatal)
            assert "not finite" in s.messages[-1][1] and s.messages[-1][0] == 3  # logged as error
        s.set(["seat_displacement", "seat_velocity"], [x[k], v[k]])
        y[k] = s.get(BODY_OUT)
        if k + 1 < t.size:
            s.fmu.doStep(t[k], t[k + 1] - t[k])
    s.close()
    assert np.all(rel_err(y, ref) < 1e-9)  # the refused step left no trace


@pytest.mark.parametrize("h", [0.0, -1e-3])
def test_non_positive_step_refused(fmus, h):
    from fmpy.fmi1 import FMICallException

    s = Slave(fmus["QuarterCar"])
    with pytest.raises(FMICallException) as exc:
        s.fmu.doStep(0.0, h)
    assert exc.value.status == FMI_DISCARD
    assert "step size must be positive" in s.messages[-1][1]
    s.fmu.doStep(0.0, 1e-3)
    s.close()


@pytest.mark.parametrize("name", NAMES)
def test_state_roll_back_replay_and_serialize(fmus, name):
    t = np.arange(0, 0.4, 1e-3)
    x, v = smooth_seat(t)
    body = name != "QuarterCar"
    ins = ["seat_displacement", "seat_velocity"] if body else CAR_IN[:2]
    outs = BODY_OUT if body else CAR_OUT
    s = Slave(fmus[name])
    s.run(t[:150], np.c_[x, v][:150], ins, outs)
    state = s.fmu.getFMUstate()
    first = s.run(t[149:], np.c_[x, v][149:], ins, outs)
    s.fmu.setFMUstate(state)
    replay = s.run(t[149:], np.c_[x, v][149:], ins, outs)
    blob = s.fmu.serializeFMUstate(state)
    s.fmu.setFMUstate(s.fmu.deSerializeFMUstate(blob))
    again = s.run(t[149:], np.c_[x, v][149:], ins, outs)
    s.fmu.freeFMUstate(state)
    s.close()
    np.testing.assert_array_equal(replay, first)
    np.testing.assert_array_equal(again, first)


def test_reset_starts_over(fmus):
    t = np.arange(0, 0.3, 1e-3)
    x, v = smooth_seat(t)
    s = Slave(fmus["HumanBody3DOF"], params={"m1": 6.0})
    first = s.run(t, np.c_[x, v], ["seat_displacement", "seat_velocity"], BODY_OUT)
    s.fmu.reset()
    s.init()  # back to the baked-in parameters and a zero state
    assert s.get(["m1"]) == [4.88]
    second = s.run(t, np.c_[x, v], ["seat_displacement", "seat_velocity"], BODY_OUT)
    s.close()
    np.testing.assert_allclose(second, body_reference("reduced-paper", t, x, v), rtol=1e-9, atol=0)
    assert not np.allclose(first, second)


def test_two_instances_and_all_three_fmus_in_one_process(fmus):
    """Interleaved steps of two HumanBody3DOF instances (different parameters), the
    ISO body and the quarter car; each agrees with its own reference."""
    t = np.arange(0, 0.4, 1e-3)
    x, v = smooth_seat(t)
    a = Slave(fmus["HumanBody3DOF"], "a")
    b = Slave(fmus["HumanBody3DOF"], "b", params={"m2": 50.0, "ks": 6e5})
    c = Slave(fmus["HumanBodyISO7962"], "c")
    car = Slave(fmus["QuarterCar"], "car")
    ys = {k: np.empty((t.size, 4)) for k in "abc"}
    ycar = np.empty((t.size, 5))
    for k in range(t.size):
        for key, s in zip("abc", (a, b, c)):
            s.set(["seat_displacement", "seat_velocity"], [x[k], v[k]])
            ys[key][k] = s.get(BODY_OUT)
        car.set(CAR_IN, [x[k], v[k], 0.0, 0.0])
        ycar[k] = car.get(CAR_OUT)
        if k + 1 < t.size:
            for s in (a, b, c, car):
                s.fmu.doStep(t[k], t[k + 1] - t[k])
    for s in (a, b, c, car):
        s.close()
    net = load_model("reduced-paper")
    assert np.all(rel_err(ys["a"], body_reference(net, t, x, v)) < 1e-9)
    assert np.all(
        rel_err(ys["b"], body_reference(net.with_parameters(m2=50.0, ks=6e5), t, x, v)) < 1e-9
    )
    assert np.all(rel_err(ys["c"], body_reference("iso7962", t, x, v)) < 1e-9)
    lm = linear_model(load_car())
    _, ref = simulate(lm, t, np.c_[x, v, 0 * t])
    assert np.all(rel_err(ycar, ref[:, [lm.output_index(s) for s in CAR_SIG]]) < 1e-9)


def test_many_instances_in_one_process(fmus):
    """pythonfmu 0.7.0 drops a reference to the slave module's dictionary per
    instantiation; the slave script must survive many (a script without its own
    methods failed at the second). Run in a fresh process: a failure may crash it."""
    code = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {os.path.join(ROOT, "tests")!r})
        from test_fmu_integration import Slave
        alive = []
        for i in range(25):
            s = Slave({fmus["HumanBody3DOF"]!r}, name=f'n{{i}}')
            s.set(['seat_displacement', 'seat_velocity'], [0.01, 0.0])
            s.fmu.doStep(0.0, 1e-3)
            if i % 2:
                s.close()
            else:
                alive.append(s)
        print(len(alive), alive[-1].get(['seat_force'])[0] > 0)
    """)
    run = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT
    )
    assert run.returncode == 0, run.stderr[-3000:]
    assert run.stdout.split() == ["13", "True"]


def test_python_host_exit_does_not_touch_freed_memory(fmus):
    """pythonfmu 0.7.0's exit-time teardown writes into a freed block (which can abort a
    process that ran many instances, as test_many_instances_in_one_process does);
    each instance registers its binary with bodyvib.runtime.teardown, whose atexit handler
    releases the state before that. Under valgrind an fmpy host exits with no invalid
    access in finalizePythonInterpreter; with the handler unregistered the same script has
    one, so the check sees the bug when it is there."""
    from memcheck import freed_memory_errors, memcheck

    code = textwrap.dedent(f"""
        import atexit, sys
        sys.path.insert(0, {os.path.join(ROOT, "tests")!r})
        from test_fmu_integration import Slave
        s = Slave({fmus["HumanBody3DOF"]!r}, name='exit')
        s.set(['seat_displacement', 'seat_velocity'], [0.01, 0.0])
        s.fmu.doStep(0.0, 1e-3)
        s.close()
        (teardown,) = {{m for n, m in sys.modules.items() if n.endswith('.teardown') and n.startswith('bodyvib_rt_')}}
        assert len(teardown.registered_binaries()) == 1
        if sys.argv[1] == 'unregister':
            atexit.unregister(teardown.release_python_states)
        print('ok')
    """)
    runs = {
        mode: memcheck([sys.executable, "-c", code, mode], cwd=ROOT)
        for mode in ("as built", "unregister")
    }
    logs = {}
    for mode, proc in runs.items():
        stdout, logs[mode] = proc.communicate(timeout=600)
        assert proc.returncode == 0 and stdout.split() == ["ok"], logs[mode][-3000:]
    assert freed_memory_errors(logs["as built"], "finalizePythonInterpreter") == []
    assert len(freed_memory_errors(logs["unregister"], "finalizePythonInterpreter")) >= 1


def test_host_with_another_bodyvib_already_imported(fmus, tmp_path):
    """A host that imported a different 'bodyvib' (here a fake 9.9 whose modules
    fail if used) runs the FMUs unchanged, and keeps its own bodyvib."""
    fake = tmp_path / "fake" / "bodyvib"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text('__version__ = "9.9-fake"\n')
    for mod in ("runtime", "fmu_build", "network", "models", "discretize", "errors"):
        (fake / f"{mod}.py").write_text(
            f"raise ImportError('fake bodyvib: {mod} must not be used')\n"
        )
    t = np.arange(0, 0.3, 1e-3)
    x, v = smooth_seat(t)
    code = textwrap.dedent(f"""
        import json, os, sys, tempfile
        sys.path.insert(0, {str(tmp_path / "fake")!r})
        import bodyvib
        assert bodyvib.__version__ == '9.9-fake'
        import numpy as np
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave
        x, v = np.array(json.loads(sys.argv[1]))
        t = np.arange(x.size) * 1e-3
        out = {{}}
        for path in sys.argv[2:]:
            md = read_model_description(path)
            vr = {{m.name: m.valueReference for m in md.modelVariables}}
            fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path, unzipdir=tempfile.mkdtemp(dir=os.getcwd())),
                            modelIdentifier=md.coSimulation.modelIdentifier, instanceName='host')
            fmu.instantiate()
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            y = []
            for k in range(t.size):
                fmu.setReal([vr['seat_displacement'], vr['seat_velocity']], [x[k], v[k]])
                y.append(fmu.getReal([vr[n] for n in {BODY_OUT!r}]))
                if k + 1 < t.size:
                    fmu.doStep(t[k], t[k + 1] - t[k])
            fmu.terminate()
            fmu.freeInstance()
            out[path] = y
        assert sys.modules['bodyvib'].__version__ == '9.9-fake'
        assert not [m for m in sys.modules if m.startswith('bodyvib.')]
        print(json.dumps(out))
    """)
    paths = [fmus["HumanBody3DOF"], fmus["HumanBodyISO7962"]]
    env = {k: val for k, val in os.environ.items() if k != "PYTHONPATH"}
    run = subprocess.run(
        [sys.executable, "-c", code, json.dumps([x.tolist(), v.tolist()])] + paths,
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
        cwd=tmp_path,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    res = json.loads(run.stdout.strip().splitlines()[-1])
    for path, model in zip(paths, ["reduced-paper", "iso7962"]):
        assert np.all(rel_err(np.array(res[path]), body_reference(model, t, x, v)) < 1e-9)


def test_step_of_1e100_s_is_refused_not_ok_with_nan(fmus):
    """A step of 1e100 s returned fmi2OK with a NaN state, and every later step too."""
    from fmpy.fmi1 import FMICallException

    s = Slave(fmus["HumanBodyISO7962"])
    s.set(["seat_displacement", "seat_velocity"], [0.01, 0.0])
    s.fmu.doStep(0.0, 1e-3)
    before = s.get(BODY_OUT)
    try:
        s.fmu.doStep(1e-3, 1e100)
        refused = False
    except FMICallException as exc:
        assert exc.status == FMI_DISCARD and "step refused" in s.messages[-1][1]
        refused = True
    after = s.get(BODY_OUT)
    assert all(np.isfinite(after)) and (not refused or after == before)
    s.fmu.doStep(1e-3, 1e-3)  # the instance goes on
    assert all(np.isfinite(s.get(BODY_OUT)))
    s.close()


def test_state_of_another_fmu_or_with_bad_parameters_is_refused(fmus):
    """A deserialized FMU state with negative parameters was accepted; a state of another FMU
    must not be taken either, nor bytes that are no state. Refused with an error logged, the
    instance keeps its own state and stays usable (pythonfmu 0.7.0 can only answer fmi2OK
    or fmi2Fatal here)."""
    from bodyvib.runtime.statebytes import pack_state, unpack_state

    iso = Slave(fmus["HumanBodyISO7962"])
    foreign = iso.fmu.serializeFMUstate(iso.fmu.getFMUstate())
    s = Slave(fmus["HumanBody3DOF"])
    s.set(["seat_displacement", "seat_velocity"], [0.01, 0.1])
    s.fmu.doStep(0.0, 1e-3)
    mine = s.get(BODY_OUT)
    state = unpack_state(bytes(s.fmu.serializeFMUstate(s.fmu.getFMUstate())))
    state["params"][0] = -4.88
    negative = pack_state(state)  # a valid checksum over an invalid state
    for blob, words in (
        (foreign, "belongs to another FMU"),
        (negative, "m1 = -4.88"),
        (b"\x00not json", "not a bodyvib FMU state"),
        (pack_state({"time": 0.0}), "not a state of a bodyvib FMU"),
    ):
        s.messages.clear()
        s.fmu.setFMUstate(s.fmu.deSerializeFMUstate(blob))
        assert any(words in m and st == 3 for st, m in s.messages), s.messages
        assert s.get(BODY_OUT) == mine
    s.fmu.doStep(1e-3, 1e-3)
    assert all(np.isfinite(s.get(BODY_OUT)))
    s.close()
    iso.close()
