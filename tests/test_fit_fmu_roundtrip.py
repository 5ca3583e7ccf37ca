"""From the GA refit to a rebuilt FMU: the user's pipeline, end to end.

``bodyvib fit`` writes a parameter file, ``python build_fmu.py --params FILE``
bakes it into HumanBody3DOF.fmu, and the FMU run by fmpy responds exactly as
the fitted model simulated by the library (bodyvib.runtime.discretize.simulate, the
same exact discretization). Build and FMU run happen in subprocesses: a module
name loaded by an FMU is global to the host process.
"""

import json
import os
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

from bodyvib.models import load_model
from bodyvib.runtime.contract import MODEL_FILE
from bodyvib.runtime.discretize import simulate
from bodyvib.runtime.network import linear_model

pytestmark = pytest.mark.integration

from helpers import ROOT

OUTPUTS = {
    "head_acceleration": "head.a",
    "head_displacement": "head.x",
    "torso_displacement": "torso.x",
    "seat_force": "seat_force",
}

RUN_FMU = textwrap.dedent(f"""
    import json, sys
    import numpy as np
    sys.path.insert(0, {os.path.join(ROOT, "tests")!r})
    from test_fmu_integration import Slave

    path, outputs = sys.argv[1], sys.argv[2].split(",")
    fmu = Slave(path, name="refit")
    names = ["m1", "m2", "k1", "k2", "c1", "c2", "ks"]
    params = dict(zip(names, fmu.get(names)))
    t = np.arange(0, 1.5, 1e-3)
    w = 2 * np.pi * np.array([1.3, 4.3, 17.8])  # around the refit's two resonances
    a = np.array([0.004, 0.002, 0.0005])
    x = (a * np.sin(np.outer(t, w))).sum(1)
    v = (a * w * np.cos(np.outer(t, w))).sum(1)
    y = fmu.run(t, np.c_[x, v], ["seat_displacement", "seat_velocity"], outputs)
    fmu.close()
    print(json.dumps({{"params": params, "t": t.tolist(), "x": x.tolist(), "v": v.tolist(),
                      "y": y.tolist()}}))
""")


def test_refit_flows_into_the_rebuilt_fmu(tmp_path):
    refit_file = tmp_path / "refit.json"
    fit = subprocess.run(
        [sys.executable, "-m", "bodyvib.cli", *"fit --reference iso7962 --seed 1".split()]
        + ["--out", str(refit_file), "--quiet"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert fit.returncode == 0, fit.stderr
    refit = load_model(refit_file)

    build = subprocess.run(
        [
            sys.executable,
            "build_fmu.py",
            "--params",
            str(refit_file),
            "--dest",
            str(tmp_path),
            "--fmus",
            "HumanBody3DOF",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert build.returncode == 0, build.stdout + build.stderr
    fmu_path = tmp_path / "HumanBody3DOF.fmu"

    # the parameter start values in modelDescription.xml are exactly the refit's
    # (the build rewrites pythonfmu's 16-digit values with repr)
    with zipfile.ZipFile(fmu_path) as zf:
        root = ET.fromstring(zf.read("modelDescription.xml"))
    starts = {
        sv.get("name"): float(sv.find("Real").get("start"))
        for sv in root.iter("ScalarVariable")
        if sv.get("causality") == "parameter"
    }
    assert set(starts) == set(refit.parameters)
    for name, value in refit.parameters.items():
        assert starts[name] == value, name
    assert refit.parameters != dict(load_model("reduced-paper").parameters)  # not Table 2
    # the units of the parameter file survive the refit and the FMU's baked model file
    assert refit.units and refit.units == load_model("reduced-paper").units
    with zipfile.ZipFile(fmu_path) as zf:
        baked = json.loads(zf.read("resources/" + MODEL_FILE))
    assert baked["units"] == dict(refit.units)

    run = subprocess.run(
        [sys.executable, "-c", RUN_FMU, str(fmu_path), ",".join(OUTPUTS)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    res = json.loads(run.stdout.strip().splitlines()[-1])
    # the FMU runs with the refit's values, bit for bit
    assert res["params"] == dict(refit.parameters)

    lm = linear_model(refit)
    t, x, v = (np.array(res[k]) for k in ("t", "x", "v"))
    _, y_ref = simulate(lm, t, np.c_[x, v])
    y_ref = y_ref[:, [lm.output_index(s) for s in OUTPUTS.values()]]
    y_fmu = np.array(res["y"])
    err = np.max(np.abs(y_fmu - y_ref), axis=0) / np.max(np.abs(y_ref), axis=0)
    assert np.all(err < 1e-6), dict(zip(OUTPUTS, err))
